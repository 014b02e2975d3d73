// The page: wires the sketch pad, the job settings and the exemplar picker to the
// service's API, shows per-stage progress and the patches as they are placed, then
// the hillshade, the 3D view and the downloads. Every server error is shown in words.

import { SketchPad } from './sketchpad.js';
import { TerrainView } from './view3d.js';

const $ = (id) => document.getElementById(id);
const pad = new SketchPad($('sketch'));
let view = null;
let job = null;
let events = null;
let lastHillshade = null;
let placed = [];

function token() {
  return $('token').value || localStorage.getItem('ridgeline-token') || '';
}

function withToken(url) {
  const t = token();
  return t ? `${url}${url.includes('?') ? '&' : '?'}token=${encodeURIComponent(t)}` : url;
}

async function api(path, opts = {}) {
  const headers = { ...(opts.headers || {}) };
  if (token()) headers.Authorization = `Bearer ${token()}`;
  let res;
  try {
    res = await fetch(path, { ...opts, headers });
  } catch (e) {
    throw new Error('cannot reach the ridgeline service: is it still running?');
  }
  if (res.status === 401) {
    $('token-box').hidden = false;
    throw new Error('the service needs its token: enter it at the top right and try again');
  }
  if (!res.ok) {
    let msg = `the service answered ${res.status}`;
    try { msg = (await res.json()).error || msg; } catch (_) { /* not JSON */ }
    throw new Error(msg);
  }
  return res;
}

function showError(msg) {
  $('error').textContent = msg;
  $('error').hidden = !msg;
}

// --- drawing tools
for (const b of document.querySelectorAll('button.pen')) {
  b.addEventListener('click', () => {
    document.querySelectorAll('button.pen').forEach((o) => o.classList.toggle('active', o === b));
    pad.pen = b.dataset.pen;
  });
}
$('brush').addEventListener('input', (e) => { pad.width = Number(e.target.value); $('brush-out').value = e.target.value; });
// the pens' elevation: strokes drawn while it is set carry it at every point
const pinElevation = () => {
  $('elevation').disabled = !$('pin-elevation').checked;
  pad.elevation = $('pin-elevation').checked ? Number($('elevation').value) : null;
};
$('pin-elevation').addEventListener('change', pinElevation);
$('elevation').addEventListener('input', pinElevation);
$('undo').addEventListener('click', () => pad.undo());
$('redo').addEventListener('click', () => pad.redo());
$('clear').addEventListener('click', () => pad.clear());
document.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT') return;
  if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === 'z') { e.preventDefault(); e.shiftKey ? pad.redo() : pad.undo(); }
  const pens = { r: 'ridge', v: 'valley', e: 'eraser' };
  if (pens[e.key]) document.querySelector(`button.pen[data-pen=${pens[e.key]}]`).click();
});
$('background').addEventListener('change', (e) => {
  const f = e.target.files[0];
  if (!f) return;
  const img = new Image();
  img.onload = () => pad.setBackground(img);
  img.onerror = () => showError(`${f.name}: the browser cannot read this image`);
  img.src = URL.createObjectURL(f);
});
$('use-result').addEventListener('click', () => lastHillshade && pad.setBackground(lastHillshade));
$('no-background').addEventListener('click', () => pad.setBackground(null));
$('token').addEventListener('change', (e) => localStorage.setItem('ridgeline-token', e.target.value));

// the sketch's size: refused with a message, not ignored, outside 16..8192
function sizeProblem() {
  for (const side of ['width', 'height']) {
    const v = Number($(side).value);
    if (!Number.isInteger(v) || v < 16 || v > 8192) return `${side} ${$(side).value}: give a whole number of cells from 16 to 8192`;
  }
  return '';
}
function resizeSketch() {
  const problem = sizeProblem();
  showError(problem);
  if (problem) return;
  const w = Number($('width').value), h = Number($('height').value);
  pad.resize(w, h);
  $('preview').width = w;
  $('preview').height = h;
}
$('width').addEventListener('change', resizeSketch);
$('height').addEventListener('change', resizeSketch);

// --- exemplars
async function loadExemplars() {
  const res = await api('/api/exemplars');
  const { exemplars } = await res.json();
  const box = $('exemplars');
  box.textContent = '';
  for (const e of exemplars) {
    const label = document.createElement('label');
    label.className = 'exemplar';
    label.title = e.name;
    const cb = document.createElement('input');
    cb.type = 'checkbox';
    cb.checked = true;
    cb.value = e.name;
    cb.addEventListener('change', () => label.classList.toggle('off', !cb.checked));
    const img = document.createElement('img');
    img.loading = 'lazy';
    img.alt = e.name;
    img.src = withToken(`/api/exemplars/${encodeURIComponent(e.name)}/thumbnail.png`);
    const name = document.createElement('span');
    name.textContent = e.name.replace(/\.[^.]+$/, '');
    label.append(cb, img, name);
    box.append(label);
  }
}
const checkboxes = () => [...document.querySelectorAll('#exemplars input')];
$('all').addEventListener('click', (e) => { e.preventDefault(); checkboxes().forEach((c) => { c.checked = true; c.dispatchEvent(new Event('change')); }); });
$('none').addEventListener('click', (e) => { e.preventDefault(); checkboxes().forEach((c) => { c.checked = false; c.dispatchEvent(new Event('change')); }); });

// --- progress and live preview
function showProgress(status) {
  const box = $('progress');
  box.textContent = '';
  const head = document.createElement('div');
  const where = status.state === 'queued' && status.queue_position != null ? ` (${status.queue_position} ahead)` : '';
  head.textContent = `job ${status.id}: ${status.state}${where}${status.seconds ? `, ${status.seconds.toFixed(1)} s` : ''}`;
  head.id = 'job-state';
  head.dataset.state = status.state;
  box.append(head);
  for (const s of status.stages) {
    const d = document.createElement('div');
    d.className = 'stage';
    const pct = s.total ? Math.round(100 * s.done / s.total) : 0;
    d.innerHTML = `<div class="name"><span></span><span>${pct}%</span></div><div class="bar"><div style="width:${pct}%"></div></div>`;
    d.querySelector('span').textContent = s.label;
    box.append(d);
  }
}

function drawPlaced() {
  const c = $('preview'), ctx = c.getContext('2d');
  ctx.fillStyle = '#222';
  ctx.fillRect(0, 0, c.width, c.height);
  if (!placed.length) return;
  let lo = Infinity, hi = -Infinity;
  for (const p of placed) { lo = Math.min(lo, p.height); hi = Math.max(hi, p.height); }
  for (const p of placed) {
    const v = Math.round(40 + 200 * (p.height - lo) / Math.max(hi - lo, 1));
    ctx.fillStyle = p.fill ? `rgb(${v},${v},${v})` : `rgb(${v},${Math.round(v * 0.8)},${Math.round(v * 0.6)})`;
    ctx.globalAlpha = 0.85;
    ctx.fillRect(p.x - p.size / 2, p.y - p.size / 2, p.size, p.size);
  }
  ctx.globalAlpha = 1;
  $('placed-count').textContent = `(${placed.length})`;
}

async function finished(status) {
  $('submit').disabled = false;
  $('cancel').disabled = true;
  if (status.state === 'failed') { showError(`the job failed: ${status.error}`); return; }
  // a cancel is what the user asked for, not an error: the job's line says "cancelled"
  if (status.state === 'cancelled') return;
  const base = `/api/jobs/${status.id}`;
  const img = $('hillshade');
  img.src = withToken(`${base}/files/preview.png`);
  img.onload = () => { lastHillshade = img; $('use-result').disabled = false; };
  $('result').hidden = false;
  const list = $('files');
  list.textContent = '';
  const describe = {
    'terrain.tif': '32-bit float TIFF, metres',
    'terrain.exr': 'OpenEXR, 32-bit float metres (one channel, Y)',
    'terrain16.png': '16-bit PNG (with terrain16.json: the mapping to metres)',
    'terrain16.json': 'sidecar of the 16-bit PNG',
    'terrain.r16': 'RAW16, little-endian (with terrain.json)',
    'terrain.json': 'sidecar of the RAW16',
    'preview.png': 'hillshade',
    'report.json': 'job report: timings, adherence, realism figures',
    'sketch_features.png': 'debug: detected ridge and valley lines, user patches',
    'features_only.png': 'debug: the terrain before hole filling',
    'provenance.png': 'debug: which exemplar each cell came from',
    'provenance.json': 'debug: every placement (for ridgeline evaluate --provenance)',
    'provenance_cells.u32': 'debug: the placement of every cell',
    'landforms.png': 'debug: landforms of the output beside its main source',
    'seams.png': 'debug: seam map',
  };
  for (const f of status.files) {
    const li = document.createElement('li');
    const a = document.createElement('a');
    a.href = withToken(`${base}/files/${encodeURIComponent(f)}`);
    a.textContent = f;
    a.download = f;
    li.append(a, document.createTextNode(describe[f] ? ` — ${describe[f]}` : (f.includes('_x') ? ' — tile' : '')));
    list.append(li);
  }
  $('downloads').hidden = false;
  try {
    const res = await api(`${base}/heights?max=512`);
    const w = Number(res.headers.get('x-width')), h = Number(res.headers.get('x-height'));
    const heights = new Float32Array(await res.arrayBuffer());
    view = view || new TerrainView($('view3d'));
    // the report knows the output's cell size; the heights come at w of status.width samples
    let cell = 90;
    try { cell = (await (await api(`${base}/files/report.json`)).json()).cell_size_m || 90; } catch (_) { /* keep 90 m */ }
    view.setTerrain(heights, w, h, cell * status.width / w);
    view.setExaggeration(Number($('exaggeration').value));
    $('view3d').dataset.rendered = 'true';
  } catch (e) {
    showError(`the 3D view could not be shown: ${e.message}`);
  }
}
$('exaggeration').addEventListener('input', (e) => { $('exaggeration-out').value = e.target.value; view?.setExaggeration(Number(e.target.value)); });

function watch(id) {
  events?.close();
  placed = [];
  drawPlaced();
  events = new EventSource(withToken(`/api/jobs/${id}/events`));
  events.addEventListener('placed', (e) => { placed.push(...JSON.parse(e.data).patches); drawPlaced(); });
  events.addEventListener('status', (e) => {
    const s = JSON.parse(e.data);
    showProgress(s);
    if (['done', 'failed', 'cancelled'].includes(s.state)) { events.close(); finished(s); }
  });
  events.onerror = () => {
    if (events.readyState === EventSource.CLOSED) showError('lost the connection to the service while watching the job');
  };
}

$('submit').addEventListener('click', async () => {
  showError(sizeProblem());
  if (sizeProblem()) return;
  const chosen = checkboxes().filter((c) => c.checked).map((c) => c.value);
  if (!chosen.length) { showError('pick at least one exemplar'); return; }
  const tiles = Number($('tiles').value);
  const [lo, hi] = [$('range-lo').value, $('range-hi').value];
  if ((lo === '') !== (hi === '')) { showError('give both the lowest and the highest elevation, or neither'); return; }
  if (lo !== '' && Number(hi) <= Number(lo)) { showError('the highest elevation must be above the lowest'); return; }
  const body = {
    sketch: { strokes: pad.toJSON() },
    exemplars: chosen.length === checkboxes().length ? null : chosen,
    seed: Number($('seed').value),
    patch_size: Number($('patch').value),
    tiles: tiles > 0 ? tiles : null,
    debug: $('debug').checked,
    elevation_range: lo === '' ? null : [Number(lo), Number(hi)],
  };
  $('submit').disabled = true;
  $('result').hidden = true;
  $('downloads').hidden = true;
  try {
    const res = await api('/api/jobs', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    job = await res.json();
    $('cancel').disabled = false;
    showProgress(job);
    watch(job.id);
  } catch (e) {
    showError(e.message);
    $('submit').disabled = false;
  }
});

$('cancel').addEventListener('click', async () => {
  if (!job) return;
  try { await api(`/api/jobs/${job.id}/cancel`, { method: 'POST' }); } catch (e) { showError(e.message); }
});

resizeSketch();
loadExemplars().catch((e) => showError(`the exemplar library could not be listed: ${e.message}`));
