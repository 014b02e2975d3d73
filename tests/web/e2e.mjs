// The web page end to end in a real browser: headless Chromium (Debian's, driven by
// playwright-core) opens `ridgeline serve`, draws a ridge and a valley on the sketch
// canvas with the mouse (the ridge with the pen's elevation set, in an elevation range
// asked for), submits, checks that the request carries the ridge's elevation at every
// point and the range, waits for the job, checks that the 3D view rendered (non-blank
// pixels), downloads the RAW16 terrain and checks its size, that it stays in the
// range, that the ridge stands near the elevation it was drawn at and that the
// terrain is higher under the drawn ridge than beside it. Saves a screenshot.
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
const dems = ['appalachians.png', 'rockies.png', 'highlands.png'];
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
  await page.waitForFunction(() => document.querySelectorAll('#exemplars img').length === 3, null, { timeout: 30000 });
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
  // undo and redo leave the same drawing
  await page.click('#undo');
  await page.click('#redo');
  const strokes = await page.evaluate(() => document.querySelectorAll('#sketch').length);
  if (strokes !== 1) fail('no sketch canvas');

  const posted = page.waitForRequest((r) => r.url().endsWith('/api/jobs') && r.method() === 'POST');
  await page.click('#submit');
  const sent = JSON.parse((await posted).postData());
  const [ridgeSent, valleySent] = sent.sketch.strokes.strokes;
  if (!ridgeSent.elevations || ridgeSent.elevations.length !== ridgeSent.points.length || ridgeSent.elevations.some((e) => e !== RIDGE_M))
    fail(`the ridge was sent without its elevation at every point: ${JSON.stringify(ridgeSent).slice(0, 200)}`);
  if (valleySent.elevations) fail('the valley, drawn with the elevation unset, was sent with elevations');
  if (JSON.stringify(sent.elevation_range) !== JSON.stringify(RANGE)) fail(`elevation_range sent: ${JSON.stringify(sent.elevation_range)}`);
  await page.waitForSelector('#job-state[data-state=done], #job-state[data-state=failed]', { timeout: 300000 });
  const state = await page.getAttribute('#job-state', 'data-state');
  if (state !== 'done') fail(`job ended ${state}: ${await page.textContent('#error')}`);
  await page.waitForSelector('#view3d[data-rendered=true]', { timeout: 60000 });
  const placed = await page.textContent('#placed-count');
  if (!/\(\d+\)/.test(placed || '')) fail(`no placed patches were shown: '${placed}'`);

  // the 3D view: share of pixels that are not the clear colour
  const drawn = await page.evaluate(() => {
    const c = document.getElementById('view3d');
    const t = document.createElement('canvas');
    t.width = c.width; t.height = c.height;
    const ctx = t.getContext('2d');
    ctx.drawImage(c, 0, 0);
    const px = ctx.getImageData(0, 0, t.width, t.height).data;
    let lit = 0, distinct = new Set();
    for (let i = 0; i < px.length; i += 4) {
      if (Math.abs(px[i] - 20) + Math.abs(px[i + 1] - 23) + Math.abs(px[i + 2] - 28) > 12) lit++;
      distinct.add((px[i] >> 3) * 1024 + (px[i + 1] >> 3) * 32 + (px[i + 2] >> 3));
    }
    return { share: lit / (px.length / 4), colours: distinct.size };
  });
  console.log(`3D view: ${(100 * drawn.share).toFixed(1)}% of pixels drawn, ${drawn.colours} colours`);
  if (drawn.share < 0.1 || drawn.colours < 20) fail(`the 3D view looks blank: ${JSON.stringify(drawn)}`);

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
