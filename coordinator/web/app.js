// The page: wires the sketch pad, the job settings and the exemplar picker to the
// service's API, shows per-stage progress and the patches as they are placed, then
// the hillshade, the 3D view, the realism figures and the downloads. The drawing,
// the settings and the last job are kept in the browser (localStorage) so a reload
// finds them; earlier jobs are listed from the service. Every server error is shown
// in words. The last result can be edited (a painted mask, the strokes changed since,
// a grown border) and areas painted as regions with exemplars of their own.

import { SketchPad } from './sketchpad.js';
import { PaintLayer } from './layers.js';
import { TerrainView } from './view3d.js';

const $ = (id) => document.getElementById(id);
const pad = new SketchPad($('sketch'));
// the region map's unpainted colour is "the rest": the exemplars chosen in the grid
const REST = '#000000';
const PALETTE = ['#e0503a', '#3a8ee0', '#e0c03a', '#50c050', '#b060d0', '#40c8c8', '#e08ab0', '#a0a0a0'];
pad.paints.mask = new PaintLayer(pad.canvas.width, pad.canvas.height, '#000000');
pad.paints.region = new PaintLayer(pad.canvas.width, pad.canvas.height, REST);
// with no region chosen, the region pen paints the rest back
pad.paints.region.colour = REST;
// regions painted on the map: name, colour, exemplars; the one the region pen paints
const regions = [];
let chosenRegion = -1;
// the last finished job shown: what an edit starts from
let lastDone = null;
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
// the brush: a slider and a number box kept equal; [ and ] step it by one
function setBrush(v) {
  const w = Math.min(64, Math.max(1, Math.round(Number(v) || 1)));
  pad.width = w;
  $('brush').value = w;
  $('brush-num').value = w;
}
$('brush').addEventListener('input', (e) => setBrush(e.target.value));
$('brush-num').addEventListener('change', (e) => setBrush(e.target.value));
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
  if (e.key === '[' || e.key === ']') setBrush(pad.width + (e.key === ']' ? 1 : -1));
  const pens = { r: 'ridge', v: 'valley', e: 'eraser', g: 'region', m: 'mask' };
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

// --- the sketch as strokes JSON: saved, loaded, and kept across reloads
$('save-sketch').addEventListener('click', () => {
  const blob = new Blob([JSON.stringify(pad.toJSON())], { type: 'application/json' });
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = 'sketch.json';
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
});
$('load-sketch').addEventListener('change', async (e) => {
  const f = e.target.files[0];
  e.target.value = '';
  if (!f) return;
  try {
    let sketch;
    try { sketch = JSON.parse(await f.text()); } catch (err) { throw new Error(`not JSON (${err.message})`); }
    SketchPad.parse(sketch, 1, 1);
    // the canvas takes the sketch's size when it is one the service takes
    if (Number.isInteger(sketch.width) && Number.isInteger(sketch.height) && sketch.width >= 16 && sketch.height >= 16 && sketch.width <= 8192 && sketch.height <= 8192) {
      $('width').value = sketch.width;
      $('height').value = sketch.height;
      resizeSketch();
    }
    pad.load(sketch);
    showError('');
  } catch (err) {
    showError(`${f.name}: ${err.message}`);
  }
});

const SETTINGS = ['width', 'height', 'seed', 'patch', 'tiles', 'tile-format', 'cell', 'range-lo', 'range-hi', 'erode', 'masks', 'realism', 'debug', 'wrap', 'edit-mode', 'grow'];
function keep() {
  const settings = {};
  for (const id of SETTINGS) settings[id] = $(id).type === 'checkbox' ? $(id).checked : $(id).value;
  const unchecked = checkboxes().filter((c) => !c.checked).map((c) => c.value);
  try {
    localStorage.setItem('ridgeline-page', JSON.stringify({ sketch: pad.toJSON(), settings, unchecked, brush: pad.width }));
  } catch (_) { /* storage full or off: the page still works */ }
}
function restore() {
  let kept;
  try { kept = JSON.parse(localStorage.getItem('ridgeline-page') || 'null'); } catch (_) { kept = null; }
  if (!kept) return null;
  for (const id of SETTINGS) {
    const v = kept.settings?.[id];
    if (v === undefined) continue;
    if ($(id).type === 'checkbox') $(id).checked = Boolean(v); else $(id).value = v;
  }
  if (kept.brush) setBrush(kept.brush);
  $('grow-box').hidden = $('edit-mode').value !== 'grow';
  resizeSketch();
  try {
    pad.strokes = SketchPad.parse(kept.sketch, pad.canvas.width, pad.canvas.height);
    pad.render();
  } catch (_) { /* a drawing from another version: start empty */ }
  return kept;
}
pad.onchange = keep;
for (const id of SETTINGS) $(id).addEventListener('change', keep);

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

// --- editing the last result and regions
$('edit-mode').addEventListener('change', () => { $('grow-box').hidden = $('edit-mode').value !== 'grow'; });
$('clear-mask').addEventListener('click', () => { pad.paints.mask.clear(); pad.render(); });
$('clear-regions').addEventListener('click', (e) => { e.preventDefault(); pad.paints.region.clear(); pad.render(); });
function chooseRegion(i) {
  chosenRegion = i;
  pad.paints.region.colour = regions[i].colour;
  document.querySelector('button.pen[data-pen=region]').click();
  renderRegions();
}
function renderRegions() {
  const box = $('regions');
  box.querySelectorAll('.region').forEach((r) => r.remove());
  const names = checkboxes().map((c) => c.value);
  regions.forEach((r, i) => {
    const row = document.createElement('div');
    row.className = 'region';
    row.classList.toggle('chosen', i === chosenRegion);
    row.dataset.index = i;
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = r.colour;
    swatch.title = 'paint this region';
    swatch.addEventListener('click', () => chooseRegion(i));
    const name = document.createElement('input');
    name.type = 'text';
    name.value = r.name;
    name.addEventListener('change', () => { r.name = name.value.trim() || `region ${i + 1}`; });
    const pick = document.createElement('select');
    pick.multiple = true;
    pick.title = 'the exemplars this region is made from';
    for (const n of names) {
      const o = document.createElement('option');
      o.value = n;
      o.textContent = n.replace(/\.[^.]+$/, '');
      o.selected = r.exemplars.includes(n);
      pick.append(o);
    }
    pick.addEventListener('change', () => { r.exemplars = [...pick.selectedOptions].map((o) => o.value); });
    row.append(swatch, name, pick);
    box.append(row);
  });
}
$('add-region').addEventListener('click', (e) => {
  e.preventDefault();
  if (regions.length >= PALETTE.length) { showError(`at most ${PALETTE.length} regions on the page`); return; }
  regions.push({ name: `region ${regions.length + 1}`, colour: PALETTE[regions.length], exemplars: [] });
  chooseRegion(regions.length - 1);
});

/// The sketches of the jobs this browser submitted, by job id (an edit of the strokes
/// changed since a job needs the sketch it was made from).
function sketchOf(id) {
  try { return JSON.parse(localStorage.getItem('ridgeline-sketches') || '{}')[id] || null; } catch (_) { return null; }
}
function rememberSketch(id, sketch) {
  let all = {};
  try { all = JSON.parse(localStorage.getItem('ridgeline-sketches') || '{}'); } catch (_) { /* start again */ }
  all[id] = sketch;
  const ids = Object.keys(all);
  for (const old of ids.slice(0, Math.max(0, ids.length - 8))) delete all[old];
  try { localStorage.setItem('ridgeline-sketches', JSON.stringify(all)); } catch (_) { /* storage full: no changed-stroke edits */ }
}

/// The request's edit, or null for a new terrain; sets `body.sketch` to the grown
/// sketch when the border grows. Throws an Error saying what is missing.
function editOf(body) {
  const mode = $('edit-mode').value;
  if (mode === 'new') return null;
  if (!lastDone) throw new Error('make or show a terrain first: there is no result to edit');
  const edit = { base_job: lastDone.id };
  if (mode === 'mask') {
    if (!pad.paints.mask.painted) throw new Error('paint the area to remake with the Mask pen first');
    edit.mask_png_base64 = pad.paints.mask.toBase64();
  } else if (mode === 'changed') {
    const old = sketchOf(lastDone.id);
    if (!old) throw new Error(`this browser did not make job ${lastDone.id}: its sketch is unknown`);
    edit.changed_from = { strokes: old };
  } else {
    const by = $('grow').value.split(',').map((v) => Number(v.trim()));
    if (by.length !== 4 || !by.every((v) => Number.isInteger(v) && v >= 0) || !by.some((v) => v > 0)) {
      throw new Error(`grow by '${$('grow').value}': give four whole numbers of cells, left, top, right, bottom`);
    }
    edit.extend = by;
    const s = pad.toJSON();
    body.sketch = { strokes: { ...s, width: s.width + by[0] + by[2], height: s.height + by[1] + by[3],
      strokes: s.strokes.map((k) => ({ ...k, points: k.points.map(([x, y]) => [x + by[0], y + by[1]]) })) } };
  }
  return edit;
}

/// The request's regions, or null when none is painted.
function regionsOf(chosen) {
  if (!regions.length || !pad.paints.region.painted) return null;
  const empty = regions.find((r) => !r.exemplars.length);
  if (empty) throw new Error(`${empty.name}: pick the exemplars it is made from`);
  return {
    map_png_base64: pad.paints.region.toBase64(),
    regions: [{ name: 'the rest', colour: REST, exemplars: chosen }, ...regions.map((r) => ({ name: r.name, colour: r.colour, exemplars: r.exemplars }))],
  };
}

// --- exemplars
function countExemplars() {
  const all = checkboxes();
  $('exemplar-count').textContent = `${all.filter((c) => c.checked).length} of ${all.length} selected`;
}
async function loadExemplars(unchecked = []) {
  const res = await api('/api/exemplars');
  const { exemplars } = await res.json();
  const box = $('exemplars');
  box.textContent = '';
  for (const e of exemplars) {
    const label = document.createElement('label');
    label.className = 'exemplar';
    label.title = e.generator ? `${e.name} (generated: ${e.generator} noise)` : e.name;
    const cb = document.createElement('input');
    cb.type = 'checkbox';
    cb.value = e.name;
    cb.checked = !unchecked.includes(e.name);
    label.classList.toggle('off', !cb.checked);
    cb.addEventListener('change', () => { label.classList.toggle('off', !cb.checked); countExemplars(); keep(); });
    const img = document.createElement('img');
    img.loading = 'lazy';
    img.alt = e.name;
    img.src = withToken(`/api/exemplars/${encodeURIComponent(e.name)}/thumbnail.png`);
    const name = document.createElement('span');
    name.textContent = e.generator ? `${e.name} · ${e.generator}` : e.name.replace(/\.[^.]+$/, '');
    label.append(cb, img, name);
    box.append(label);
  }
  countExemplars();
  renderRegions();
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
  await showJob(status);
}

/// A finished job's result: hillshade, downloads, realism figures, 3D view.
async function showJob(status) {
  const base = `/api/jobs/${status.id}`;
  lastDone = { id: status.id, width: status.width, height: status.height };
  showProgress(status);
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
    'masks/slope.png': 'mask: slope in degrees / 90',
    'masks/curvature.png': 'mask: curvature (above mid-grey convex, below concave)',
    'masks/flow.png': 'mask: flow accumulation (log)',
    'masks/landforms.png': 'mask: geomorphon class / 9',
    'masks/splat.png': 'RGBA splat map of four masks',
    'masks/masks.json': 'what each mask holds',
  };
  const describeFile = (f) => describe[f] || (f.startsWith('masks/source_') ? 'mask: cells this exemplar supplied' : f.includes('_x') ? 'tile' : '');
  for (const f of status.files) {
    const li = document.createElement('li');
    const a = document.createElement('a');
    a.href = withToken(`${base}/files/${encodeURIComponent(f)}`);
    a.textContent = f;
    a.download = f;
    const what = describeFile(f);
    li.append(a, document.createTextNode(what ? ` — ${what}` : ''));
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
    try {
      const report = await (await api(`${base}/files/report.json`)).json();
      cell = report.cell_size_m || 90;
      showFigures(report.evaluation);
    } catch (_) { /* keep 90 m */ }
    view.setTerrain(heights, w, h, cell * status.width / w);
    view.setExaggeration(Number($('exaggeration').value));
    $('view3d').dataset.rendered = 'true';
  } catch (e) {
    showError(`the 3D view could not be shown: ${e.message}`);
  }
}
// the realism figures of report.json, when the job computed them
function showFigures(ev) {
  $('figures').hidden = !ev;
  if (!ev) return;
  const f = (v, d = 3) => (v === null || v === undefined ? '–' : Number(v).toFixed(d));
  const pct = (v) => (v === null || v === undefined ? '–' : `${(100 * v).toFixed(1)}%`);
  const rows = [
    ['ridge adherence', f(ev.adherence?.ridge), 'share of ridge points that are crests'],
    ['valley adherence', f(ev.adherence?.valley), 'share of valley points that are floors'],
    ['landform distance', f(ev.landform_distance), 'vs the exemplars (0 = same mix)'],
    ['roughness ratio', f(ev.roughness_ratio, 2), 'vs the exemplars (1 = as rough)'],
    ['spectral slope difference', f(ev.spectral_slope_difference, 2), 'negative: smoother'],
    ['seam score', f(ev.seams?.mean_ratio, 2), 'jumps across seams / inside patches'],
    ['ridge above valley', f(ev.ridge_above_valley?.above_nearest_valley), 'share of ridge cells above the nearest valley'],
    ['sink area', pct(ev.drainage?.sink_share), `exemplars ${pct(ev.source_drainage?.sink_share)}`],
    ['elevation range', `${f(ev.elevation_range?.[0], 0)} to ${f(ev.elevation_range?.[1], 0)} m`, `exemplars ${f(ev.source_elevation_range?.[0], 0)} to ${f(ev.source_elevation_range?.[1], 0)} m`],
  ];
  const table = $('figures-table');
  table.textContent = '';
  for (const r of rows) {
    const tr = document.createElement('tr');
    for (const c of r) { const td = document.createElement('td'); td.textContent = c; tr.append(td); }
    table.append(tr);
  }
}

// --- earlier jobs (the service keeps the latest ones and their files)
async function listJobs() {
  const { jobs } = await (await api('/api/jobs')).json();
  const ul = $('jobs');
  ul.textContent = '';
  for (const j of jobs) {
    const li = document.createElement('li');
    li.dataset.id = j.id;
    li.classList.toggle('current', j.id === job?.id);
    const label = document.createElement('span');
    label.textContent = `${j.id} · ${j.state}${j.seconds ? ` · ${j.seconds.toFixed(1)} s` : ''}`;
    li.append(label);
    if (j.state === 'done' || j.state === 'queued' || j.state === 'running') {
      const a = document.createElement('a');
      a.href = '#';
      a.textContent = 'show';
      a.addEventListener('click', (e) => { e.preventDefault(); openJob(j.id).catch((err) => showError(err.message)); });
      li.append(a);
    }
    ul.append(li);
  }
}
$('refresh-jobs').addEventListener('click', (e) => { e.preventDefault(); listJobs().catch((err) => showError(err.message)); });

/// Shows job `id`: its result when done, its progress while it runs.
async function openJob(id) {
  const status = await (await api(`/api/jobs/${encodeURIComponent(id)}`)).json();
  job = status;
  localStorage.setItem('ridgeline-job', id);
  showError('');
  if (status.state === 'done') {
    events?.close();
    await showJob(status);
  } else if (status.state === 'queued' || status.state === 'running') {
    $('submit').disabled = true;
    $('cancel').disabled = false;
    showProgress(status);
    watch(id);
  } else {
    showProgress(status);
  }
  document.querySelectorAll('#jobs li').forEach((li) => li.classList.toggle('current', li.dataset.id === id));
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
    if (['done', 'failed', 'cancelled'].includes(s.state)) { events.close(); finished(s); listJobs().catch(() => {}); }
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
  const erode = $('erode').value === '' ? 0 : Number($('erode').value);
  if (!(erode >= 0 && erode <= 10)) { showError(`erosion ${$('erode').value}: give a strength from 0 (none) to 10`); return; }
  const cell = $('cell').value === '' ? null : Number($('cell').value);
  if (cell !== null && !(cell > 0 && cell <= 100000)) { showError(`cell size ${$('cell').value}: give metres above 0, at most 100000 (empty: the exemplars')`); return; }
  const body = {
    sketch: { strokes: pad.toJSON() },
    exemplars: chosen.length === checkboxes().length ? null : chosen,
    seed: Number($('seed').value),
    patch_size: Number($('patch').value),
    tiles: tiles > 0 ? tiles : null,
    tile_format: $('tile-format').value,
    masks: $('masks').checked,
    realism: $('realism').checked,
    debug: $('debug').checked,
    elevation_range: lo === '' ? null : [Number(lo), Number(hi)],
    erode: erode > 0 ? erode : null,
    cell_size: cell,
    wrap: $('wrap').checked,
  };
  try {
    body.edit = editOf(body);
    body.regions = regionsOf(chosen);
  } catch (e) { showError(e.message); return; }
  $('submit').disabled = true;
  $('result').hidden = true;
  $('downloads').hidden = true;
  $('figures').hidden = true;
  try {
    const res = await api('/api/jobs', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    job = await res.json();
    localStorage.setItem('ridgeline-job', job.id);
    rememberSketch(job.id, body.sketch.strokes);
    // a grown terrain: the sketch grows with it, so the next edit matches its size
    if (body.edit?.extend) {
      const [l, t, r, b] = body.edit.extend;
      pad.grow(l, t, r, b);
      $('width').value = pad.canvas.width;
      $('height').value = pad.canvas.height;
      $('preview').width = pad.canvas.width;
      $('preview').height = pad.canvas.height;
      $('edit-mode').value = 'new';
      $('grow-box').hidden = true;
      keep();
    }
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

// start: the kept drawing and settings, the library, the last job and the list
const kept = restore();
if (!kept) resizeSketch();
loadExemplars(kept?.unchecked || []).catch((e) => showError(`the exemplar library could not be listed: ${e.message}`));
listJobs().catch(() => { /* shown when the user asks */ });
const lastJob = localStorage.getItem('ridgeline-job');
if (lastJob) {
  openJob(lastJob).catch(() => localStorage.removeItem('ridgeline-job'));
}
