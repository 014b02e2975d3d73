// The sketch canvas: strokes with a ridge pen, a valley pen and an eraser, undo and
// redo, an optional background image to trace over. The canvas holds one pixel per
// output cell; strokes are kept as polylines in cells and sent to the service as
// such: pen, width, and, when the elevation control is set, the height at every point
// (the service keeps them as typed strokes; see `stages/sketch`).

export class SketchPad {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.strokes = [];
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
      for (const s of [...this.strokes, ...this.redoStack]) s.points = s.points.map(([x, y]) => [x * sx, y * sy]);
    }
    this.canvas.width = w;
    this.canvas.height = h;
    this.layer.width = w;
    this.layer.height = h;
    this.render();
  }

  cell(e) {
    const r = this.canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * this.canvas.width / r.width, (e.clientY - r.top) * this.canvas.height / r.height];
  }

  down(e) {
    this.canvas.setPointerCapture?.(e.pointerId);
    this.current = { pen: this.pen, width: this.width, elevation: this.pen === 'eraser' ? null : this.elevation, points: [this.cell(e)] };
    this.strokes.push(this.current);
    this.redoStack = [];
    this.render();
  }

  move(e) {
    if (!this.current) return;
    const p = this.cell(e);
    const last = this.current.points[this.current.points.length - 1];
    if (Math.hypot(p[0] - last[0], p[1] - last[1]) >= 0.75) {
      this.current.points.push(p);
      this.render();
    }
  }

  up() {
    if (!this.current) return;
    this.current = null;
    this.onchange();
  }

  undo() {
    if (this.strokes.length) this.redoStack.push(this.strokes.pop());
    this.render();
    this.onchange();
  }

  redo() {
    if (this.redoStack.length) this.strokes.push(this.redoStack.pop());
    this.render();
    this.onchange();
  }

  clear() {
    this.redoStack = this.strokes.reverse().concat(this.redoStack);
    this.strokes = [];
    this.render();
    this.onchange();
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
  }

  /// The strokes as the service takes them.
  toJSON() {
    return {
      width: this.canvas.width,
      height: this.canvas.height,
      strokes: this.strokes.map((s) => {
        const out = { pen: s.pen, width: s.width, points: s.points };
        if (s.elevation !== null && s.elevation !== undefined) out.elevations = s.points.map(() => s.elevation);
        return out;
      }),
    };
  }
}
