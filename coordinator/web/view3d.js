// The 3D view: the terrain as a mesh (WebGL 1), an orbit camera (drag to turn,
// wheel to zoom) and a vertical exaggeration. Heights come from the service's
// `/heights` (f32 rows), at most 255 samples a side here so 16-bit indices suffice.
// Colour follows real elevation in metres and real slope (green lowlands, alpine
// meadow above about 1,800 m, rock on slopes steeper than about 35 degrees and high
// up, snow above about 4,000 m where it can lie); light comes from a low sun in the
// north-west with cast shadows (marched over the heights at the exaggeration shown)
// and a sky term, so the relief reads at any exaggeration.

const VS = `
attribute vec3 pos; attribute vec3 nrm; attribute float elev; attribute float lit;
uniform mat4 mvp; uniform float exag;
varying float m; varying float steep; varying float sun; varying vec3 n;
void main() {
  m = elev;
  // the real slope (unexaggerated normal): 0 flat, 1 vertical
  steep = 1.0 - nrm.y / length(nrm);
  sun = lit;
  n = normalize(vec3(nrm.x * exag, nrm.y, nrm.z * exag));
  gl_Position = mvp * vec4(pos.x, pos.y * exag, pos.z, 1.0);
}`;
const FS = `
precision highp float;
uniform vec2 range; uniform vec3 sunDir;
varying float m; varying float steep; varying float sun; varying vec3 n;
void main() {
  float t = clamp((m - range.x) / max(range.y - range.x, 1.0), 0.0, 1.0);
  vec3 lowland = mix(vec3(0.24, 0.36, 0.18), vec3(0.36, 0.45, 0.24), t);
  vec3 alpine = vec3(0.55, 0.52, 0.38);
  vec3 rock = mix(vec3(0.42, 0.39, 0.36), vec3(0.55, 0.53, 0.50), t);
  vec3 snow = vec3(0.93, 0.95, 0.98);
  vec3 c = mix(lowland, alpine, smoothstep(1600.0, 2400.0, m));
  // 1 - cos: 35 degrees is 0.18, 50 degrees 0.36
  float r = max(smoothstep(0.14, 0.26, steep), 0.8 * smoothstep(3000.0, 3800.0, m));
  c = mix(c, rock, r);
  c = mix(c, snow, smoothstep(3800.0, 4300.0, m) * (1.0 - smoothstep(0.25, 0.40, steep)));
  vec3 nn = normalize(n);
  float diffuse = max(dot(nn, sunDir), 0.0) * sun;
  float sky = 0.5 + 0.5 * nn.y;
  gl_FragColor = vec4(c * (0.28 * sky + 0.95 * diffuse), 1.0);
}`;

// the sun: azimuth 315 degrees (north-west, as hillshades), 35 degrees up; scene
// x is east, z is south, y is up
const SUN_ALT = 35 * Math.PI / 180;
const SUN_AZ = 315 * Math.PI / 180;
const SUN = [Math.sin(SUN_AZ) * Math.cos(SUN_ALT), Math.sin(SUN_ALT), -Math.cos(SUN_AZ) * Math.cos(SUN_ALT)];

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
    const pos = new Float32Array(gw * gh * 3), nrm = new Float32Array(gw * gh * 3), elev = new Float32Array(gw * gh);
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
        elev[y * gw + x] = at(x, y);
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
    this.elevBuf = buf(gl.ARRAY_BUFFER, elev);
    this.litBuf = gl.createBuffer();
    this.grid = { elev, gw, gh, spacing: step * cell, hi };
    this.idxBuf = buf(gl.ELEMENT_ARRAY_BUFFER, idx);
    this.count = idx.length;
    this.range = [lo, hi];
    this.shadows();
    this.draw();
  }

  setExaggeration(e) {
    this.exag = e;
    this.shadows();
    this.draw();
  }

  /// Which vertices the sun reaches at this exaggeration: a ray from each towards
  /// the sun, one sample a step, is in shadow where the terrain rises above it.
  shadows() {
    if (!this.grid) return;
    const { elev, gw, gh, spacing, hi } = this.grid;
    const lit = new Float32Array(gw * gh);
    const len = Math.hypot(SUN[0], SUN[2]);
    const [sx, sz] = [SUN[0] / len, SUN[2] / len];
    // metres the ray climbs per step, in unexaggerated heights
    const rise = spacing * Math.tan(SUN_ALT) / this.exag;
    for (let y = 0; y < gh; y++) {
      for (let x = 0; x < gw; x++) {
        let h = elev[y * gw + x], px = x, pz = y, shade = 1;
        for (;;) {
          px += sx; pz += sz; h += rise;
          if (h > hi || px < 0 || pz < 0 || px > gw - 1 || pz > gh - 1) break;
          if (elev[Math.round(pz) * gw + Math.round(px)] > h) { shade = 0; break; }
        }
        lit[y * gw + x] = shade;
      }
    }
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.litBuf);
    gl.bufferData(gl.ARRAY_BUFFER, lit, gl.STATIC_DRAW);
    this.litShare = lit.reduce((a, v) => a + v, 0) / lit.length;
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
    gl.uniform3f(loc('sunDir'), SUN[0], SUN[1], SUN[2]);
    for (const [name, b, size] of [['pos', this.posBuf, 3], ['nrm', this.nrmBuf, 3], ['elev', this.elevBuf, 1], ['lit', this.litBuf, 1]]) {
      const a = gl.getAttribLocation(this.prog, name);
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.enableVertexAttribArray(a);
      gl.vertexAttribPointer(a, size, gl.FLOAT, false, 0, 0);
    }
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.idxBuf);
    gl.drawElements(gl.TRIANGLES, this.count, gl.UNSIGNED_SHORT, 0);
  }
}
