// Paint layers over the sketch, one pixel per output cell: the edit mask (white where
// the last result is made anew, on black) and the region map (each region's colour,
// on the colour of "the rest"). The sketch pad paints on them with the mask and
// region pens and shows them over the strokes; the page sends them as PNGs.

export class PaintLayer {
  constructor(w, h, background) {
    this.canvas = document.createElement('canvas');
    this.background = background;
    this.colour = '#ffffff';
    this.resize(w, h);
  }

  /// A blank layer of w x h cells (what was painted is dropped).
  resize(w, h) {
    this.canvas.width = w;
    this.canvas.height = h;
    this.clear();
  }

  clear() {
    const c = this.canvas.getContext('2d');
    c.fillStyle = this.background;
    c.fillRect(0, 0, this.canvas.width, this.canvas.height);
    this.painted = false;
  }

  /// Starts painting at cell p with a round brush `width` cells across.
  begin(p, width) {
    this.last = p;
    this.width = width;
    this.to(p);
  }

  to(p) {
    const c = this.canvas.getContext('2d');
    c.strokeStyle = c.fillStyle = this.colour;
    c.lineCap = 'round';
    c.lineWidth = this.width;
    c.beginPath();
    if (p === this.last) {
      c.arc(p[0], p[1], this.width / 2, 0, 2 * Math.PI);
      c.fill();
    } else {
      c.moveTo(...this.last);
      c.lineTo(...p);
      c.stroke();
    }
    this.last = p;
    this.painted = true;
  }

  /// The layer as a PNG, base64 (what the service takes).
  toBase64() {
    return this.canvas.toDataURL('image/png').split(',')[1];
  }
}
