// SPDX-License-Identifier: GPL-3.0-or-later
// Node half of the client bench: starts Debian's headless chromium through playwright-core, serves this
// folder's page, three.js and the GLB from disk through request interception (no network, no server),
// and runs the page's fhLoad / fhSample / fhRender. Reads a job JSON file (argv[2]):
//   {glb, mesh, clip, times: [s], vertices: [i], shots: [{time, png}], focus: [x, y, z], width, height,
//    chromium, influences (false: positions only), views_shots: [{time, png, views}] (fhRenderViews),
//    all_meshes (true: every vertex of every mesh at each time, fhSampleMeshes, instead of fhSample)}
// and writes the result JSON to argv[3].
import { readFile, writeFile } from 'node:fs/promises';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const here = dirname(fileURLToPath(import.meta.url));
const job = JSON.parse(await readFile(process.argv[2], 'utf8'));
const ORIGIN = 'http://fh-bench.invalid';
const TYPES = { '.html': 'text/html', '.mjs': 'text/javascript', '.js': 'text/javascript' };

const browser = await chromium.launch({
  executablePath: job.chromium || '/usr/bin/chromium',
  headless: true,
  args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'],
});
let exitCode = 0;
try {
  const page = await browser.newPage({ viewport: { width: job.width || 1200, height: job.height || 700 } });
  const logs = [];
  page.on('console', (m) => logs.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => logs.push(`pageerror: ${e.message}`));
  await page.route(`${ORIGIN}/**`, async (route) => {
    const path = new URL(route.request().url()).pathname;
    let file;
    if (path === '/model.glb') file = job.glb;
    else if (path.startsWith('/three/')) file = join(here, 'node_modules', 'three', path.slice(7));
    else if (path === '/' || path === '/page.html') file = join(here, 'page.html');
    else if (path === '/page.mjs') file = join(here, 'page.mjs');
    if (!file) return route.fulfill({ status: 404, body: 'not found' });
    const ext = file.slice(file.lastIndexOf('.'));
    try {
      await route.fulfill({ status: 200, body: await readFile(file),
        contentType: TYPES[ext] || 'application/octet-stream' });
    } catch (e) {
      await route.fulfill({ status: 404, body: String(e) });
    }
  });
  await page.goto(`${ORIGIN}/page.html`);
  await page.waitForFunction(() => window.fhReady === true, null, { timeout: 60000 });
  const started = performance.now();
  const info = await page.evaluate(([m, c]) => window.fhLoad('/model.glb', m, c), [job.mesh, job.clip || null]);
  const loadMs = performance.now() - started;
  const sampleStart = performance.now();
  const samples = job.all_meshes
    ? { meshes: await page.evaluate((t) => window.fhSampleMeshes(t), job.times) }
    : await page.evaluate(([t, v, w]) => window.fhSample(t, v, w), [job.times, job.vertices, job.influences !== false]);
  const sampleMs = performance.now() - sampleStart;
  const shots = [];
  for (const shot of job.shots || []) {
    const r = await page.evaluate(([t, w, h, f]) => window.fhRender(t, w, h, f),
      [shot.time, job.width || 1200, job.height || 700, job.focus || [0, 0, 0]]);
    await page.locator('canvas').screenshot({ path: shot.png });
    shots.push({ ...shot, ...r });
  }
  for (const shot of job.views_shots || []) {   // {time, png, views: [...]} for fhRenderViews
    const r = await page.evaluate(([t, w, h, v]) => window.fhRenderViews(t, w, h, v),
      [shot.time, job.width || 1200, job.height || 700, shot.views]);
    await page.locator('canvas').screenshot({ path: shot.png });
    shots.push({ time: shot.time, png: shot.png, ...r });
  }
  const result = { info, samples, shots, logs, loadMs, sampleMs, browser: browser.version() };
  await writeFile(process.argv[3], JSON.stringify(result));
} catch (e) {
  process.stderr.write(`gltf client: ${e.stack || e}\n`);
  exitCode = 1;
} finally {
  await browser.close();
}
process.exit(exitCode);
