// The web page end to end in a real browser: headless Chromium (Debian's, driven by
// playwright-core) opens `ridgeline serve`, draws a ridge and a valley on the sketch
// canvas with the mouse (the ridge with the pen's elevation set, in an elevation range
// asked for), submits, checks that the request carries the ridge's elevation at every
// point and the range, waits for the job, checks that the 3D view rendered (non-blank
// pixels), downloads the RAW16 terrain and checks its size, that it stays in the
// range, that the ridge stands near the elevation it was drawn at and that the
// terrain is higher under the drawn ridge than beside it. Also: the exemplar grid
// (four whole columns of equal thumbnails, a count of what is selected), the brush
// width's box and keys, Clear undone, a sketch saved and loaded as strokes JSON, the
// 3D view's colours (not all green) and light, a texture mask, the EXR terrain and EXR
// tiles downloaded through the page, the realism figures shown when asked for, and a
// reload that finds the drawing, the settings and the job; then the last result
// edited with a painted mask (every other cell kept), a region painted with its own
// exemplar, and the border grown. Saves a screenshot.
//
// usage: node tests/web/e2e.mjs [RIDGELINE_BINARY] [SHARED_DATA] [SCREENSHOT]
import { chromium } from 'playwright-core';
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import readline from 'node:readline';

const bin = process.argv[2] || 'target/release/ridgeline';
const data = process.argv[3] || '../shared/data';
const shot = process.argv[4] || 'out/web/page.png';
const chromiumPath = process.env.CHROMIUM || '/usr/bin/chromium';
const SIZE = 256;

function fail(msg) {
  console.error(`web e2e FAILED: ${msg}`);
  process.exitCode = 1;
  throw new Error(msg);
}

// a small library: three real DEMs, linked
const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'rl-web-'));
const lib = path.join(dir, 'lib');
fs.mkdirSync(lib);
// five in the library (a grid row of four and one more), three used by the job
const dems = ['appalachians.png', 'rockies.png', 'highlands.png', 'norway.png', 'alaska.png'];
const UNUSED = ['norway', 'alaska'];
for (const n of dems) fs.symlinkSync(path.resolve(data, 'dems', n), path.join(lib, n));
fs.writeFileSync(path.join(lib, 'dems.csv'), 'file,cell_size_m,vertical_unit\n' + dems.map((n) => `${n},90,feet`).join('\n') + '\n');

const server = spawn(bin, ['serve', '--listen', '127.0.0.1:0', '--exemplars', lib, '--jobs-dir', path.join(dir, 'jobs'),
  '--cache-dir', path.join(dir, 'cache'), '--gpu', 'off'], { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((resolve, reject) => {
  const rl = readline.createInterface({ input: server.stdout });
  rl.once('line', (l) => resolve(l.replace('ridgeline is serving on ', '').trim()));
  server.once('exit', (c) => reject(new Error(`ridgeline serve exited with ${c}`)));
});
console.log(`service at ${url}`);

const browser = await chromium.launch({
  executablePath: chromiumPath,
  args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1500, height: 1250 }, acceptDownloads: true });
  const consoleErrors = [];
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  const missing = [];
  page.on('response', (r) => { if (r.status() === 404) missing.push(r.url()); });
  await page.goto(url);
  await page.waitForFunction(() => [...document.querySelectorAll('#exemplars img')].filter((i) => i.complete && i.naturalWidth).length === 5, null, { timeout: 30000 });
  // the grid: four columns inside its box, thumbnails of one size, a count
  const grid = await page.evaluate(() => {
    const box = document.getElementById('exemplars').getBoundingClientRect();
    const imgs = [...document.querySelectorAll('#exemplars img')].map((i) => i.getBoundingClientRect());
    return { box: [box.left, box.right], imgs: imgs.map((r) => [r.left, r.right, r.top, r.width, r.height]) };
  });
  const row = grid.imgs.filter((r) => Math.abs(r[2] - grid.imgs[0][2]) < 1);
  if (row.length !== 4) fail(`the exemplar grid's first row has ${row.length} thumbnails, want 4`);
  if (row.some((r) => r[0] < grid.box[0] - 0.5 || r[1] > grid.box[1] + 0.5)) fail(`a thumbnail is clipped: ${JSON.stringify(grid)}`);
  if (grid.imgs.some((r) => Math.abs(r[3] - grid.imgs[0][3]) > 0.5 || Math.abs(r[4] - r[3]) > 0.5)) fail(`thumbnails of uneven sizes: ${JSON.stringify(grid.imgs)}`);
  if ((await page.textContent('#exemplar-count')) !== '5 of 5 selected') fail(`count: ${await page.textContent('#exemplar-count')}`);
  for (const n of UNUSED) await page.uncheck(`#exemplars input[value="${n}.png"]`);
  if ((await page.textContent('#exemplar-count')) !== '3 of 5 selected') fail(`count after unchecking two: ${await page.textContent('#exemplar-count')}`);
  // engine sizes are valid in the size and tile fields; a width over the limit is
  // refused with a message instead of being ignored
  for (const [field, v] of [['#width', '1009'], ['#height', '505'], ['#tiles', '1009'], ['#tiles', '505']]) {
    await page.fill(field, v);
    if (!(await page.$eval(field, (e) => e.checkValidity()))) fail(`${field} = ${v} is marked invalid`);
  }
  await page.fill('#tiles', '0');
  await page.fill('#width', '9000');
  await page.dispatchEvent('#width', 'change');
  if (!(await page.isVisible('#error')) || !(await page.textContent('#error')).includes('16 to 8192')) {
    fail(`a width of 9000 is not refused with a message: '${await page.textContent('#error')}'`);
  }
  if (missing.length) fail(`requests answered 404: ${missing.join(', ')}`);
  await page.fill('#width', String(SIZE));
  await page.dispatchEvent('#width', 'change');
  await page.fill('#height', String(SIZE));
  await page.dispatchEvent('#height', 'change');
  await page.selectOption('#patch', '32');
  await page.fill('#seed', '5');
  // the brush width: typed exactly, stepped by [ and ], the slider follows
  await page.fill('#brush-num', '8');
  await page.dispatchEvent('#brush-num', 'change');
  if ((await page.inputValue('#brush')) !== '8') fail(`brush box 8 gave slider ${await page.inputValue('#brush')}`);
  await page.evaluate(() => document.activeElement?.blur());
  await page.keyboard.press(']');
  await page.keyboard.press('[');
  await page.keyboard.press('[');
  await page.keyboard.press('[');
  if ((await page.inputValue('#brush-num')) !== '6') fail(`8, ], [, [, [ gave ${await page.inputValue('#brush-num')}`);
  await page.fill('#brush-num', '4');
  await page.dispatchEvent('#brush-num', 'change');

  // draw: the canvas shows SIZE cells on 512 CSS pixels
  const box = await page.locator('#sketch').boundingBox();
  const toPage = (cx, cy) => [box.x + cx * box.width / SIZE, box.y + cy * box.height / SIZE];
  async function stroke(points) {
    const [x0, y0] = toPage(...points[0]);
    await page.mouse.move(x0, y0);
    await page.mouse.down();
    for (const p of points.slice(1)) {
      const [x, y] = toPage(...p);
      await page.mouse.move(x, y, { steps: 12 });
    }
    await page.mouse.up();
  }
  const ridgeY = 0.32 * SIZE, valleyY = 0.72 * SIZE;
  // the ridge is drawn with its elevation set, in a range the job asks for
  const RIDGE_M = 3600, RANGE = [0, 4500];
  await page.click('button[data-pen=ridge]');
  await page.check('#pin-elevation');
  await page.fill('#elevation', String(RIDGE_M));
  await page.dispatchEvent('#elevation', 'input');
  await stroke([[0.1 * SIZE, ridgeY], [0.5 * SIZE, ridgeY], [0.9 * SIZE, ridgeY]]);
  await page.uncheck('#pin-elevation');
  await page.fill('#range-lo', String(RANGE[0]));
  await page.fill('#range-hi', String(RANGE[1]));
  await page.click('button[data-pen=valley]');
  await stroke([[0.1 * SIZE, valleyY], [0.9 * SIZE, valleyY]]);
  // drawn cells on the sketch canvas (not its grey)
  const inked = () => page.evaluate(() => {
    const c = document.getElementById('sketch');
    const px = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 0; i < px.length; i += 4) if (Math.abs(px[i] - 128) + Math.abs(px[i + 1] - 128) + Math.abs(px[i + 2] - 128) > 30) n++;
    return n;
  });
  const drawnCells = await inked();
  if (drawnCells < 100) fail(`the strokes drew ${drawnCells} cells`);
  // undo and redo leave the same drawing; Clear is undone
  await page.click('#undo');
  await page.click('#redo');
  if ((await inked()) !== drawnCells) fail('undo and redo changed the drawing');
  await page.click('#clear');
  if ((await inked()) !== 0) fail('Clear left strokes');
  await page.click('#undo');
  if ((await inked()) !== drawnCells) fail(`undoing Clear gave ${await inked()} drawn cells, want ${drawnCells}`);
  // the sketch saved as strokes JSON and loaded back after a Clear
  const [saved] = await Promise.all([page.waitForEvent('download'), page.click('#save-sketch')]);
  const sketchFile = path.join(dir, 'sketch.json');
  await saved.saveAs(sketchFile);
  const sketchJson = JSON.parse(fs.readFileSync(sketchFile, 'utf8'));
  if (sketchJson.width !== SIZE || sketchJson.strokes.map((s) => s.pen).join() !== 'ridge,valley') fail(`saved sketch: ${JSON.stringify(sketchJson).slice(0, 200)}`);
  await page.click('#clear');
  await page.setInputFiles('#load-sketch', sketchFile);
  // the file is read asynchronously: wait for the drawing
  let loaded = await inked();
  for (let i = 0; i < 50 && loaded !== drawnCells; i++) {
    await page.waitForTimeout(100);
    loaded = await inked();
  }
  if (loaded !== drawnCells) fail(`the loaded sketch draws ${loaded} cells, want ${drawnCells}`);
  // a file that is not a sketch is refused with its name
  const junk = path.join(dir, 'junk.json');
  fs.writeFileSync(junk, '{"width": 10, "height": 10, "strokes": [{"pen": "cliff", "width": 3, "points": [[1, 1]]}]}');
  await page.setInputFiles('#load-sketch', junk);
  await page.waitForSelector('#error:not([hidden])');
  if (!(await page.textContent('#error')).includes('junk.json: stroke 1')) fail(`a bad sketch file: '${await page.textContent('#error')}'`);
  if ((await inked()) !== drawnCells) fail('a refused sketch file changed the drawing');
  // masks, realism figures and EXR tiles for this job
  await page.check('#masks');
  await page.check('#realism');
  await page.fill('#tiles', '129');
  await page.selectOption('#tile-format', 'exr');
  // erosion: a strength outside 0..10 is refused on the page; 2 is sent
  await page.fill('#erode', '12');
  await page.click('#submit');
  if (!(await page.textContent('#error')).includes('erosion 12')) fail(`erosion 12 not refused: '${await page.textContent('#error')}'`);
  await page.fill('#erode', '2');
  // a cell size that is no length is refused on the page; empty sends none (the
  // exemplars' own)
  await page.fill('#cell', '-3');
  await page.click('#submit');
  if (!(await page.textContent('#error')).includes('cell size -3')) fail(`cell size -3 not refused: '${await page.textContent('#error')}'`);
  await page.fill('#cell', '');

  const posted = page.waitForRequest((r) => r.url().endsWith('/api/jobs') && r.method() === 'POST');
  await page.click('#submit');
  const sent = JSON.parse((await posted).postData());
  const [ridgeSent, valleySent] = sent.sketch.strokes.strokes;
  if (!ridgeSent.elevations || ridgeSent.elevations.length !== ridgeSent.points.length || ridgeSent.elevations.some((e) => e !== RIDGE_M))
    fail(`the ridge was sent without its elevation at every point: ${JSON.stringify(ridgeSent).slice(0, 200)}`);
  if (valleySent.elevations) fail('the valley, drawn with the elevation unset, was sent with elevations');
  if (JSON.stringify(sent.elevation_range) !== JSON.stringify(RANGE)) fail(`elevation_range sent: ${JSON.stringify(sent.elevation_range)}`);
  if (!sent.masks || !sent.realism || sent.tile_format !== 'exr' || sent.tiles !== 129 || sent.erode !== 2 || sent.cell_size !== null) fail(`options sent: ${JSON.stringify({ ...sent, sketch: undefined })}`);
  if (JSON.stringify(sent.exemplars) !== JSON.stringify(['appalachians.png', 'highlands.png', 'rockies.png'])) fail(`exemplars sent: ${JSON.stringify(sent.exemplars)}`);
  await page.waitForSelector('#job-state[data-state=done], #job-state[data-state=failed]', { timeout: 300000 });
  const state = await page.getAttribute('#job-state', 'data-state');
  if (state !== 'done') fail(`job ended ${state}: ${await page.textContent('#error')}`);
  await page.waitForSelector('#view3d[data-rendered=true]', { timeout: 60000 });
  const placed = await page.textContent('#placed-count');
  if (!/\(\d+\)/.test(placed || '')) fail(`no placed patches were shown: '${placed}'`);

  // the 3D view: the share of pixels that are not the clear colour, and among the
  // terrain's, colour by elevation and slope lit by a sun: some are not green (rock,
  // meadow, snow: this terrain reaches 3,600 m) and the light spreads their brightness
  const [drawn, tones] = await page.evaluate(() => {
    const c = document.getElementById('view3d');
    const t = document.createElement('canvas');
    t.width = c.width; t.height = c.height;
    const ctx = t.getContext('2d');
    ctx.drawImage(c, 0, 0);
    const px = ctx.getImageData(0, 0, t.width, t.height).data;
    let terrain = 0, notGreen = 0;
    const distinct = new Set(), lum = [];
    for (let i = 0; i < px.length; i += 4) {
      const [r, g, b] = [px[i], px[i + 1], px[i + 2]];
      distinct.add((r >> 3) * 1024 + (g >> 3) * 32 + (b >> 3));
      if (Math.abs(r - 20) + Math.abs(g - 23) + Math.abs(b - 28) <= 12) continue;
      terrain++;
      if (!(g > r + 8 && g > b + 8)) notGreen++;
      lum.push(0.3 * r + 0.59 * g + 0.11 * b);
    }
    lum.sort((x, y) => x - y);
    return [{ share: terrain / (px.length / 4), colours: distinct.size },
      { notGreen: notGreen / Math.max(terrain, 1), p10: lum[Math.floor(0.1 * lum.length)] || 0, p90: lum[Math.floor(0.9 * lum.length)] || 0 }];
  });
  console.log(`3D view: ${(100 * drawn.share).toFixed(1)}% of pixels drawn, ${drawn.colours} colours`);
  if (drawn.share < 0.1 || drawn.colours < 20) fail(`the 3D view looks blank: ${JSON.stringify(drawn)}`);
  console.log(`3D view: ${(100 * tones.notGreen).toFixed(1)}% of the terrain not green, brightness p10 ${tones.p10.toFixed(0)} p90 ${tones.p90.toFixed(0)}`);
  if (tones.notGreen < 0.2) fail(`the 3D view is all green: ${JSON.stringify(tones)}`);
  if (tones.p90 - tones.p10 < 55) fail(`the 3D view's light does not read: ${JSON.stringify(tones)}`);
  // the realism figures, asked for, are shown
  await page.waitForSelector('#figures:not([hidden])', { timeout: 10000 }).catch(() => fail('the realism figures are not shown'));
  const figureRows = await page.$$eval('#figures-table tr', (rows) => rows.map((r) => r.textContent));
  if (!figureRows.some((r) => r.startsWith('landform distance0.'))) fail(`realism figures: ${figureRows.join(' | ')}`);
  // the erosion asked for ran
  const erosion = await page.evaluate(async () => {
    const a = document.querySelector('#files a[download="report.json"]');
    return (await (await fetch(a.href)).json()).erosion;
  });
  if (!(erosion?.cells_lowered > 0)) fail(`the erosion asked for did not run: ${JSON.stringify(erosion)}`);
  // a texture mask and the EXR terrain and tiles through the page's links
  const fetchBytes = (name) => page.evaluate(async (n) => {
    const a = document.querySelector(`#files a[download="${n}"]`);
    if (!a) return null;
    return [...new Uint8Array(await (await fetch(a.href)).arrayBuffer())];
  }, name);
  const [maskDl] = await Promise.all([page.waitForEvent('download'), page.click('#files a[download="masks/slope.png"]')]);
  const maskFile = path.join(dir, 'slope.png');
  await maskDl.saveAs(maskFile);
  const mask = fs.readFileSync(maskFile);
  if (mask.readUInt32BE(0) !== 0x89504e47 || mask.readUInt32BE(16) !== SIZE || mask.readUInt32BE(20) !== SIZE) fail('masks/slope.png is not a PNG the size of the terrain');
  const exr = await fetchBytes('terrain.exr');
  if (!exr || Buffer.from(exr).readUInt32LE(0) !== 20000630) fail('terrain.exr is missing or not OpenEXR');
  const tileNames = await page.$$eval('#files a', (as) => as.map((a) => a.download).filter((n) => /_x\d+_y\d+\.exr$/.test(n)));
  if (tileNames.length < 4) fail(`EXR tiles listed: ${tileNames.join(', ')}`);
  const tile = await fetchBytes(tileNames[0]);
  if (!tile || Buffer.from(tile).readUInt32LE(0) !== 20000630) fail(`${tileNames[0]} is not OpenEXR`);
  console.log(`downloaded masks/slope.png, terrain.exr (${exr.length} bytes) and ${tileNames.length} EXR tiles`);

  // download the RAW16 terrain through the page's link
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#files a[download="terrain.r16"]')]);
  const file = path.join(dir, 'terrain.r16');
  await download.saveAs(file);
  const raw = fs.readFileSync(file);
  if (raw.length !== SIZE * SIZE * 2) fail(`terrain.r16 has ${raw.length} bytes, want ${SIZE * SIZE * 2}`);
  // the r16's sidecar maps samples to metres
  const href = await page.getAttribute('#files a[download="terrain.r16"]', 'href');
  const side = await page.evaluate(async (u) => (await fetch(u)).json(), href.replace('terrain.r16', 'terrain.json'));
  console.log(`elevations ${side.min_elevation.toFixed(0)}..${side.max_elevation.toFixed(0)} m, asked ${RANGE[0]}..${RANGE[1]}`);
  if (side.min_elevation < RANGE[0] - 1 || side.max_elevation > RANGE[1] + 1) fail('the terrain leaves the elevation range asked for');
  const v = (x, y) => raw.readUInt16LE(2 * (Math.round(y) * SIZE + Math.round(x)));
  const metres = (x, y) => side.min_elevation + v(x, y) * side.scale;
  const crest = [];
  for (let x = 0.2 * SIZE; x < 0.8 * SIZE; x += 4) crest.push(metres(x, ridgeY));
  crest.sort((a, b) => a - b);
  const crestM = crest[crest.length >> 1];
  console.log(`ridge crest median ${crestM.toFixed(0)} m, drawn at ${RIDGE_M} m`);
  if (Math.abs(crestM - RIDGE_M) > 600) fail(`the ridge drawn at ${RIDGE_M} m stands at ${crestM.toFixed(0)} m`);
  let on = 0, off = 0;
  for (let x = 0.2 * SIZE; x < 0.8 * SIZE; x += 4) {
    on += v(x, ridgeY);
    off += (v(x, ridgeY - 16) + v(x, ridgeY + 16)) / 2;
  }
  console.log(`under the ridge ${on} vs beside it ${off}`);
  if (!(on > off)) fail('the terrain is not higher under the drawn ridge');
  if (await page.isVisible('#error')) fail(`the page shows an error: ${await page.textContent('#error')}`);
  if (consoleErrors.length) fail(`page errors: ${consoleErrors.join('; ')}`);

  fs.mkdirSync(path.dirname(shot), { recursive: true });
  await page.screenshot({ path: shot, fullPage: true });

  // a reload finds the drawing, the settings and the job (and lists it)
  const jobId = (await page.textContent('#job-state')).match(/job (\S+):/)[1];
  await page.reload();
  await page.waitForSelector('#job-state[data-state=done]', { timeout: 30000 }).catch(() => fail('after a reload the job is not shown'));
  if (!(await page.textContent('#job-state')).includes(jobId)) fail(`after a reload: ${await page.textContent('#job-state')}, want job ${jobId}`);
  await page.waitForSelector('#view3d[data-rendered=true]', { timeout: 60000 });
  if (await page.isHidden('#result')) fail('after a reload the result is hidden');
  if ((await inked()) !== drawnCells) fail(`after a reload the sketch has ${await inked()} drawn cells, want ${drawnCells}`);
  if ((await page.inputValue('#width')) !== String(SIZE) || (await page.inputValue('#tile-format')) !== 'exr' || !(await page.isChecked('#masks'))) fail('after a reload the settings are lost');
  await page.waitForFunction(() => document.querySelectorAll('#exemplars input').length === 5);
  if ((await page.textContent('#exemplar-count')) !== '3 of 5 selected') fail(`after a reload: ${await page.textContent('#exemplar-count')}`);
  await page.waitForSelector(`#jobs li[data-id="${jobId}"]`, { timeout: 10000 }).catch(() => fail('the earlier job is not listed'));
  console.log(`reload: the sketch (${drawnCells} cells), the settings and job ${jobId} are back`);
  await page.uncheck('#masks');
  await page.uncheck('#realism');
  await page.fill('#erode', '');
  await page.fill('#tiles', '0');

  // edit the last result: paint a mask with the Mask pen and remake it; every cell
  // outside the painted area keeps its height, bit for bit
  const heightsOf = (id) => page.evaluate(async ([i, n]) => [...new Float32Array(await (await fetch(`/api/jobs/${i}/heights?max=${n}`)).arrayBuffer())], [id, 512]);
  const sentJob = async () => {
    const answered = page.waitForResponse((r) => r.url().endsWith('/api/jobs') && r.request().method() === 'POST');
    await page.click('#submit');
    const res = await answered;
    const sent = JSON.parse(res.request().postData());
    if (res.status() !== 202) fail(`a job was refused: ${await res.text()}`);
    const { id } = await res.json();
    // this job's line, finished (the last job's stays until the new one is shown)
    await page.waitForFunction((i) => {
      const e = document.getElementById('job-state');
      return e && e.textContent.includes(i) && ['done', 'failed', 'cancelled'].includes(e.dataset.state);
    }, id, { timeout: 300000 });
    if ((await page.getAttribute('#job-state', 'data-state')) !== 'done') fail(`job ${id} ended ${await page.getAttribute('#job-state', 'data-state')}: ${await page.textContent('#error')}`);
    return [sent, id];
  };
  const before = await heightsOf(jobId);
  await page.fill('#brush-num', '12');
  await page.dispatchEvent('#brush-num', 'change');
  await page.click('button[data-pen=mask]');
  await stroke([[0.55 * SIZE, 0.45 * SIZE], [0.8 * SIZE, 0.55 * SIZE]]);
  await page.selectOption('#edit-mode', 'mask');
  const [editSent, editId] = await sentJob();
  if (editSent.edit?.base_job !== jobId || !editSent.edit.mask_png_base64) fail(`the edit was sent as ${JSON.stringify(editSent.edit)?.slice(0, 120)}`);
  const maskOn = await page.evaluate(async (b64) => {
    const img = new Image();
    img.src = `data:image/png;base64,${b64}`;
    await img.decode();
    const c = document.createElement('canvas');
    [c.width, c.height] = [img.width, img.height];
    c.getContext('2d').drawImage(img, 0, 0);
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    return [...Array(d.length / 4).keys()].map((i) => d[4 * i] > 127);
  }, editSent.edit.mask_png_base64);
  const after = await heightsOf(editId);
  let kept = 0, keptSame = 0, remade = 0, remadeChanged = 0;
  for (let i = 0; i < SIZE * SIZE; i++) {
    if (maskOn[i]) { remade++; if (after[i] !== before[i]) remadeChanged++; } else { kept++; if (after[i] === before[i]) keptSame++; }
  }
  console.log(`edit of job ${jobId}: ${remade} painted cells, ${remadeChanged} of them made anew; ${keptSame} of ${kept} others kept`);
  if (after.length !== SIZE * SIZE || keptSame !== kept) fail(`the edit changed ${kept - keptSame} cells outside the mask`);
  if (remade < 1000 || remadeChanged < remade / 2) fail(`the edit remade ${remadeChanged} of ${remade} painted cells`);
  // a region painted with the Region pen, made from one exemplar alone
  await page.selectOption('#edit-mode', 'new');
  await page.click('#add-region');
  await page.selectOption('#regions .region select', ['rockies.png']);
  await stroke([[0.2 * SIZE, 0.15 * SIZE], [0.35 * SIZE, 0.6 * SIZE]]);
  const [regionSent, regionId] = await sentJob();
  const sentRegions = regionSent.regions?.regions || [];
  if (sentRegions.length !== 2 || sentRegions[1].exemplars.join() !== 'rockies.png' || !regionSent.regions.map_png_base64) fail(`regions sent: ${JSON.stringify(sentRegions)}`);
  const regionReport = await page.evaluate(async (id) => (await (await fetch(`/api/jobs/${id}/files/report.json`)).json()).regions, regionId);
  const painted = regionReport?.regions?.find((r) => r.name === 'region 1');
  console.log(`regions: ${JSON.stringify(regionReport?.regions?.map((r) => [r.name, r.cells, r.exemplars_used]))}`);
  if (!painted || painted.exemplars_used.join() !== 'rockies.png') fail(`the painted region was made from ${JSON.stringify(painted?.exemplars_used)}`);
  await page.screenshot({ path: shot.replace(/\.png$/, '-regions.png'), fullPage: true });
  // the border grown: the old cells kept where they were, shifted by the growth
  await page.click('#clear-regions');
  await page.selectOption('#edit-mode', 'grow');
  await page.fill('#grow', '32,0,0,16');
  const base = await heightsOf(regionId);
  const [growSent, grownId] = await sentJob();
  if (JSON.stringify(growSent.edit?.extend) !== '[32,0,0,16]' || growSent.sketch.strokes.width !== SIZE + 32) fail(`the growth was sent as ${JSON.stringify(growSent.edit)}`);
  const grown = await heightsOf(grownId);
  let moved = 0;
  for (let y = 0; y < SIZE; y++) for (let x = 0; x < SIZE; x++) if (grown[y * (SIZE + 32) + x + 32] === base[y * SIZE + x]) moved++;
  if (grown.length !== (SIZE + 32) * (SIZE + 16) || moved !== SIZE * SIZE) fail(`grown: ${grown.length} cells, ${moved} of the old ones kept`);
  if ((await page.inputValue('#width')) !== String(SIZE + 32)) fail(`after growing the sketch is ${await page.inputValue('#width')} wide`);
  console.log(`grown by 32,0,0,16 to ${SIZE + 32} x ${SIZE + 16}: every old cell kept`);

  // a cancel the user asked for is shown as the job's state, not as an error
  await page.fill('#width', '2048');
  await page.dispatchEvent('#width', 'change');
  await page.fill('#height', '2048');
  await page.dispatchEvent('#height', 'change');
  await page.click('#submit');
  await page.waitForSelector('#job-state[data-state="running"]', { timeout: 60000 });
  await page.click('#cancel');
  await page.waitForSelector('#job-state[data-state="cancelled"], #job-state[data-state="done"]', { timeout: 120000 });
  const ended = await page.getAttribute('#job-state', 'data-state');
  if (ended === 'cancelled' && (await page.isVisible('#error'))) fail(`a cancel is shown as an error: ${await page.textContent('#error')}`);
  console.log(`cancelled job: ${ended}, no error shown`);
  console.log(`web e2e passed; screenshot ${shot}`);
} finally {
  await browser.close();
  server.kill('SIGTERM');
  fs.rmSync(dir, { recursive: true, force: true });
}
