// The sketch canvas: strokes with a ridge pen, a valley pen and an eraser, undo and
// redo of every change (a stroke, Clear, a loaded sketch), an optional background
// image to trace over, and the strokes as JSON (saved, loaded, kept by the page). The canvas holds one pixel per
// output cell; strokes are kept as polylines in cells and sent to the service as
// such: pen, width, and, when the elevation control is set, the height at every point
// (the service keeps them as typed strokes; see `stages/sketch`). The mask and region
// pens paint on the pad's paint layers (`layers.js`) instead, shown over the strokes.

export class SketchPad {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.strokes = [];
    // earlier and undone states of the stroke list (strokes are never changed once
    // drawn, so states share them)
    this.undoStack = [];
    this.redoStack = [];
    this.pen = 'ridge';
    this.width = 4;
    // metres, or null: strokes then take the default profile
    this.elevation = null;
    this.background = null;
    this.backgroundAlpha = 0.6;
    this.current = null;
    this.onchange = () => {};
    this.layer = document.createElement('canvas');
    // paint layers by pen ('mask', 'region'), drawn over the strokes
    this.paints = {};
    this.painting = null;
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', () => this.up());
    canvas.addEventListener('pointerleave', () => this.up());
    this.resize(canvas.width, canvas.height);
  }

  resize(w, h) {
    // strokes are in cells: scale them with the canvas so the drawing keeps its shape
    const sx = w / this.canvas.width, sy = h / this.canvas.height;
    if (sx !== 1 || sy !== 1) {
      const all = new Set([this.strokes, ...this.undoStack, ...this.redoStack].flat());
      for (const s of all) s.points = s.points.map(([x, y]) => [x * sx, y * sy]);
    }
    this.canvas.width = w;
    this.canvas.height = h;
    this.layer.width = w;
    this.layer.height = h;
    for (const p of Object.values(this.paints)) p.resize(w, h);
    this.render();
  }

  cell(e) {
    const r = this.canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * this.canvas.width / r.width, (e.clientY - r.top) * this.canvas.height / r.height];
  }

  down(e) {
    this.canvas.setPointerCapture?.(e.pointerId);
    const paint = this.paints[this.pen];
    if (paint) {
      // paint brushes are four times the pen's width: areas, not lines
      this.painting = paint;
      paint.begin(this.cell(e), 4 * this.width);
      this.render();
      return;
    }
    this.current = { pen: this.pen, width: this.width, elevation: this.pen === 'eraser' ? null : this.elevation, points: [this.cell(e)] };
    this.change([...this.strokes, this.current], false);
  }

  move(e) {
    if (this.painting) {
      this.painting.to(this.cell(e));
      this.render();
      return;
    }
    if (!this.current) return;
    const p = this.cell(e);
    const last = this.current.points[this.current.points.length - 1];
    if (Math.hypot(p[0] - last[0], p[1] - last[1]) >= 0.75) {
      this.current.points.push(p);
      this.render();
    }
  }

  up() {
    if (this.painting) {
      this.painting = null;
      this.onchange();
      return;
    }
    if (!this.current) return;
    this.current = null;
    this.onchange();
  }

  /// Makes `strokes` the drawing, the old one undoable.
  change(strokes, notify = true) {
    this.undoStack.push(this.strokes);
    this.redoStack = [];
    this.strokes = strokes;
    this.render();
    if (notify) this.onchange();
  }

  undo() {
    if (!this.undoStack.length) return;
    this.redoStack.push(this.strokes);
    this.strokes = this.undoStack.pop();
    this.render();
    this.onchange();
  }

  redo() {
    if (!this.redoStack.length) return;
    this.undoStack.push(this.strokes);
    this.strokes = this.redoStack.pop();
    this.render();
    this.onchange();
  }

  /// Clears the drawing (undoable).
  clear() {
    if (this.strokes.length) this.change([]);
  }

  setBackground(img) {
    this.background = img;
    this.render();
  }

  render() {
    const { ctx, canvas, layer } = this;
    const l = layer.getContext('2d');
    l.clearRect(0, 0, layer.width, layer.height);
    l.lineCap = 'round';
    l.lineJoin = 'round';
    for (const s of this.strokes) {
      l.globalCompositeOperation = s.pen === 'eraser' ? 'destination-out' : 'source-over';
      l.strokeStyle = l.fillStyle = s.pen === 'ridge' ? '#ff5a36' : '#3a78ff';
      l.lineWidth = s.width;
      if (s.points.length === 1) {
        l.beginPath();
        l.arc(s.points[0][0], s.points[0][1], s.width / 2, 0, 2 * Math.PI);
        l.fill();
      } else {
        l.beginPath();
        l.moveTo(...s.points[0]);
        for (const p of s.points.slice(1)) l.lineTo(...p);
        l.stroke();
      }
    }
    l.globalCompositeOperation = 'source-over';
    ctx.fillStyle = '#808080';
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    if (this.background) {
      ctx.globalAlpha = this.backgroundAlpha;
      ctx.drawImage(this.background, 0, 0, canvas.width, canvas.height);
      ctx.globalAlpha = 1;
    }
    ctx.drawImage(layer, 0, 0);
    // the paint layers tint what is under them (their black shows nothing)
    ctx.globalCompositeOperation = 'screen';
    ctx.globalAlpha = 0.5;
    for (const p of Object.values(this.paints)) if (p.painted) ctx.drawImage(p.canvas, 0, 0);
    ctx.globalAlpha = 1;
    ctx.globalCompositeOperation = 'source-over';
  }

  /// Moves the drawing by (l, t) cells on a canvas grown by l + r and t + b (undoable
  /// as a change of strokes; the paint layers start blank at the new size).
  grow(l, t, r, b) {
    const moved = this.strokes.map((s) => ({ ...s, points: s.points.map(([x, y]) => [x + l, y + t]) }));
    const [w, h] = [this.canvas.width + l + r, this.canvas.height + t + b];
    this.canvas.width = w;
    this.canvas.height = h;
    this.layer.width = w;
    this.layer.height = h;
    for (const p of Object.values(this.paints)) p.resize(w, h);
    this.change(moved);
  }

  /// Replaces the drawing with a sketch as `toJSON` gives it (undoable), its
  /// strokes scaled to this canvas; throws an Error saying what is wrong with it.
  load(sketch) {
    this.change(SketchPad.parse(sketch, this.canvas.width, this.canvas.height));
  }

  /// The strokes of a sketch object, checked, in cells of a w x h canvas.
  static parse(sketch, w, h) {
    const num = (v) => typeof v === 'number' && Number.isFinite(v);
    if (!sketch || typeof sketch !== 'object' || !Array.isArray(sketch.strokes)) throw new Error('not a sketch: it needs "width", "height" and a list of "strokes"');
    if (!num(sketch.width) || !num(sketch.height) || sketch.width < 1 || sketch.height < 1) throw new Error('"width" and "height" must be positive numbers');
    const sx = w / sketch.width, sy = h / sketch.height;
    return sketch.strokes.map((s, i) => {
      if (!s || !['ridge', 'valley', 'eraser'].includes(s.pen)) throw new Error(`stroke ${i + 1}: "pen" must be ridge, valley or eraser`);
      if (!num(s.width) || s.width < 1 || s.width > 64) throw new Error(`stroke ${i + 1}: "width" must be 1 to 64 cells`);
      if (!Array.isArray(s.points) || !s.points.length || !s.points.every((p) => Array.isArray(p) && p.length === 2 && num(p[0]) && num(p[1]))) {
        throw new Error(`stroke ${i + 1}: "points" must be a list of [x, y] numbers`);
      }
      const out = { pen: s.pen, width: s.width, elevation: null, points: s.points.map(([x, y]) => [x * sx, y * sy]) };
      // per-point values are kept as they came (the pad draws with the stroke's width)
      for (const k of ['elevations', 'widths']) {
        if (s[k] === undefined || s[k] === null) continue;
        if (!Array.isArray(s[k]) || s[k].length !== s.points.length || !s[k].every(num)) throw new Error(`stroke ${i + 1}: "${k}" must be one number per point`);
        out[k] = s[k].slice();
      }
      return out;
    });
  }

  /// The strokes as the service takes them.
  toJSON() {
    return {
      width: this.canvas.width,
      height: this.canvas.height,
      strokes: this.strokes.map((s) => {
        const out = { pen: s.pen, width: s.width, points: s.points };
        if (s.elevations) out.elevations = s.elevations;
        else if (s.elevation !== null && s.elevation !== undefined) out.elevations = s.points.map(() => s.elevation);
        if (s.widths) out.widths = s.widths;
        return out;
      }),
    };
  }
}
