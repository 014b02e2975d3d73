// The 3D view: the terrain as a lit mesh (WebGL 1), an orbit camera (drag to turn,
// wheel to zoom) and a vertical exaggeration. Heights come from the service's
// `/heights` (f32 rows), at most 255 samples a side here so 16-bit indices suffice.

const VS = `
attribute vec3 pos; attribute vec3 nrm;
uniform mat4 mvp; uniform float exag; uniform vec2 range;
varying float h; varying vec3 n;
void main() {
  h = (pos.y - range.x) / max(range.y - range.x, 1.0);
  n = normalize(vec3(nrm.x * exag, nrm.y, nrm.z * exag));
  gl_Position = mvp * vec4(pos.x, pos.y * exag, pos.z, 1.0);
}`;
const FS = `
precision mediump float;
varying float h; varying vec3 n;
void main() {
  vec3 low = vec3(0.30, 0.42, 0.25), mid = vec3(0.55, 0.50, 0.38), high = vec3(0.92, 0.92, 0.90);
  vec3 c = h < 0.6 ? mix(low, mid, h / 0.6) : mix(mid, high, (h - 0.6) / 0.4);
  float d = max(dot(normalize(n), normalize(vec3(-0.5, 0.8, -0.4))), 0.0);
  gl_FragColor = vec4(c * (0.25 + 0.8 * d), 1.0);
}`;

function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
  return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}

function lookAt(eye, at, up) {
  const sub = (a, b) => a.map((v, i) => v - b[i]);
  const norm = (a) => { const l = Math.hypot(...a); return a.map((v) => v / l); };
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const z = norm(sub(eye, at)), x = norm(cross(up, z)), y = cross(z, x);
  return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, eye), -dot(y, eye), -dot(z, eye), 1];
}

function mul(a, b) {
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return o;
}

export class TerrainView {
  constructor(canvas) {
    this.canvas = canvas;
    const gl = canvas.getContext('webgl', { preserveDrawingBuffer: true, antialias: true });
    if (!gl) throw new Error('this browser cannot show 3D (no WebGL)');
    this.gl = gl;
    const sh = (type, src) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const p = gl.createProgram();
    gl.attachShader(p, sh(gl.VERTEX_SHADER, VS));
    gl.attachShader(p, sh(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(p);
    this.prog = p;
    this.yaw = 0.7;
    this.pitch = 0.6;
    this.dist = 1.6;
    this.exag = 1.5;
    this.count = 0;
    let drag = null;
    canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture?.(e.pointerId); });
    canvas.addEventListener('pointerup', () => { drag = null; });
    canvas.addEventListener('pointermove', (e) => {
      if (!drag) return;
      this.yaw += (e.clientX - drag[0]) * 0.01;
      this.pitch = Math.min(1.5, Math.max(0.05, this.pitch + (e.clientY - drag[1]) * 0.01));
      drag = [e.clientX, e.clientY];
      this.draw();
    });
    canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.dist = Math.min(5, Math.max(0.4, this.dist * Math.exp(e.deltaY * 0.001)));
      this.draw();
    }, { passive: false });
  }

  /// heights: Float32Array of w*h rows; cell: metres per sample.
  setTerrain(heights, w, h, cell) {
    const gl = this.gl;
    const step = Math.max(1, Math.ceil(Math.max(w, h) / 255));
    const gw = Math.ceil(w / step), gh = Math.ceil(h / step);
    const extent = Math.max(w, h) * cell;
    let lo = Infinity, hi = -Infinity;
    for (const v of heights) { if (v < lo) lo = v; if (v > hi) hi = v; }
    const at = (x, y) => heights[Math.min(h - 1, y * step) * w + Math.min(w - 1, x * step)];
    const pos = new Float32Array(gw * gh * 3), nrm = new Float32Array(gw * gh * 3);
    const s = 1 / extent;
    for (let y = 0; y < gh; y++) {
      for (let x = 0; x < gw; x++) {
        const i = (y * gw + x) * 3;
        pos[i] = (x * step * cell - w * cell / 2) * s;
        pos[i + 1] = (at(x, y) - (lo + hi) / 2) * s;
        pos[i + 2] = (y * step * cell - h * cell / 2) * s;
        const dx = (at(Math.min(gw - 1, x + 1), y) - at(Math.max(0, x - 1), y)) / (2 * step * cell);
        const dz = (at(x, Math.min(gh - 1, y + 1)) - at(x, Math.max(0, y - 1))) / (2 * step * cell);
        nrm[i] = -dx; nrm[i + 1] = 1; nrm[i + 2] = -dz;
      }
    }
    const idx = new Uint16Array((gw - 1) * (gh - 1) * 6);
    let k = 0;
    for (let y = 0; y < gh - 1; y++) {
      for (let x = 0; x < gw - 1; x++) {
        const a = y * gw + x;
        idx.set([a, a + gw, a + 1, a + 1, a + gw, a + gw + 1], k);
        k += 6;
      }
    }
    const buf = (target, data) => { const b = gl.createBuffer(); gl.bindBuffer(target, b); gl.bufferData(target, data, gl.STATIC_DRAW); return b; };
    this.posBuf = buf(gl.ARRAY_BUFFER, pos);
    this.nrmBuf = buf(gl.ARRAY_BUFFER, nrm);
    this.idxBuf = buf(gl.ELEMENT_ARRAY_BUFFER, idx);
    this.count = idx.length;
    this.range = [(lo - (lo + hi) / 2) * s, (hi - (lo + hi) / 2) * s];
    this.draw();
  }

  setExaggeration(e) {
    this.exag = e;
    this.draw();
  }

  draw() {
    const gl = this.gl;
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.clearColor(0.08, 0.09, 0.11, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (!this.count) return;
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.prog);
    const eye = [Math.sin(this.yaw) * Math.cos(this.pitch) * this.dist, Math.sin(this.pitch) * this.dist, Math.cos(this.yaw) * Math.cos(this.pitch) * this.dist];
    const mvp = mul(perspective(0.8, this.canvas.width / this.canvas.height, 0.01, 20), lookAt(eye, [0, 0, 0], [0, 1, 0]));
    const loc = (n) => gl.getUniformLocation(this.prog, n);
    gl.uniformMatrix4fv(loc('mvp'), false, new Float32Array(mvp));
    gl.uniform1f(loc('exag'), this.exag);
    gl.uniform2f(loc('range'), this.range[0], this.range[1]);
    for (const [name, b] of [['pos', this.posBuf], ['nrm', this.nrmBuf]]) {
      const a = gl.getAttribLocation(this.prog, name);
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.enableVertexAttribArray(a);
      gl.vertexAttribPointer(a, 3, gl.FLOAT, false, 0, 0);
    }
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.idxBuf);
    gl.drawElements(gl.TRIANGLES, this.count, gl.UNSIGNED_SHORT, 0);
  }
}
