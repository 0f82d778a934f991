#!/usr/bin/env node
// End-to-end test of the browser front-end: the real featureline-server serving the built
// page, driven in Debian's headless Chromium by playwright-core.
//
//   node tests/web/e2e.mjs
//
// Environment:
//   SERVER     the server binary (default build/server/featureline-server, from the repo root)
//   ARTIFACTS  where the screenshot goes (default build/test-artifacts/web.png); a
//              curvature view goes beside it as web-curvature.png, and on failure web-failure.png
//   CHROMIUM   the browser (default /usr/bin/chromium); a missing browser FAILS the test
//   WEB_ROOT   a built page to serve (default: the page is built into a temporary folder)
// Prints "ok"/"FAIL" per check and closes with "N passed, N failed"; exits 1 on any failure.
// The server, browser and check helpers are shared with tests/web/workbench_e2e.mjs
// (tests/web/harness.mjs).
import fs from 'node:fs';
import path from 'node:path';
import { createHarness, repo, sleep, until, Fatal } from './harness.mjs';

const h = createHarness({ totalTimeoutMs: 180_000, artifactName: 'web.png' });
const { check, ok } = h;
const ARTIFACT = h.ARTIFACT;
const SAMPLE = path.join(repo, 'samples', 'ridge_field.off');
await h.prepare();
let page = null;

const state = () => page.evaluate(() => {
  const f = window.featureline;
  return {
    meshId: f.meshId,
    mesh: f.mesh,
    lines: f.lines,
    activeLineId: f.activeLineId,
    lastResult: f.lastResult,
    requestCount: f.requestCount,
    responseCount: f.responseCount,
    message: f.message,
    decomposeMessage: f.decomposeMessage,
    segmentation: f.segmentation,
  };
});
const idle = () => page.evaluate(() => window.featureline.idle());
const screenOf = (v) => page.evaluate((vv) => window.featureline.screenPositionOfVertex(vv), v);
const activeOf = (s) => s.lines.find((l) => l.id === s.activeLineId);
const dist = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

async function run() {
  const base = await h.startServer(['--preload', SAMPLE]);
  ok('the server starts with --preload, serving its page');
  page = await h.launch({ width: 1280, height: 800 });
  const tmp = h.tmp;

  let s;
  // ---- the page loads, the sample list comes from the build ----------------------------
  const response = await page.goto(`${base}/?trace=0`);
  check(response && response.status() === 200, 'GET / serves the page', () => `status ${response?.status()}`);
  await until('the app to start', () => page.evaluate(() => !!window.featureline && window.featureline.samples.length > 0));
  const samples = await page.evaluate(() => window.featureline.samples);
  const sample = samples.find((s) => s.file === 'samples/ridge_field.off');
  check(sample, 'the bundled sample is listed', JSON.stringify(samples));
  const webgl = await page.evaluate(() => !!document.querySelector('#canvas-host canvas')?.getContext('webgl2'));
  check(webgl, 'WebGL is available in headless chromium');

  // ---- drag and drop a mesh file (OBJ) ------------------------------------------------------
  const tetra = 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n';
  const dataTransfer = await page.evaluateHandle((text) => {
    const dt = new DataTransfer();
    dt.items.add(new File([text], 'tetra.obj'));
    return dt;
  }, tetra);
  await page.dispatchEvent('#drop-zone', 'drop', { dataTransfer });
  await until('the dropped mesh to open', async () => (await state()).mesh?.faceCount === 4);
  s = await state();
  check(s.mesh.vertexCount === 4 && s.mesh.description.format === 'obj', 'a dropped OBJ file opens', JSON.stringify(s.mesh));

  // ---- a broken upload shows the server's error message ---------------------------------
  await page.setInputFiles('#file-input', { name: 'broken.obj', mimeType: 'application/octet-stream', buffer: Buffer.from('v 0 0 0\nf 1 2 3\n') });
  await until('the upload error', async () => (await state()).message.startsWith('Could not open'));
  const bad = await state();
  check(/HTTP 4\d\d/.test(bad.message) && (await page.locator('#message.error').count()) === 1,
    'a refused upload shows the server\'s error plainly', bad.message);

  // ---- open the sample ---------------------------------------------------------------
  await page.selectOption('#sample-select', 'samples/ridge_field.off');
  await page.click('#sample-open');
  await until('the sample to open', async () => {
    const s = await state();
    return s.meshId && s.mesh?.faceCount === 3200;
  });
  await idle();
  s = await state();
  check(/^[0-9a-f]{32}$/.test(s.meshId) && s.mesh.vertexCount === 1681, 'the sample opens: 1681 vertices, 3200 triangles', JSON.stringify(s.mesh));
  check(/3200 triangles/.test(await page.textContent('#mesh-info')), 'the mesh description is shown');
  const progress = await page.evaluate(() => window.featureline.uploadProgress);
  check(progress && progress.total === sample.bytes && progress.loaded === sample.bytes, 'upload progress was reported', JSON.stringify(progress));
  let stats = await page.evaluate(() => window.featureline.sceneStats());
  check(stats.triangles === 3200 && stats.frames > 0, 'the mesh is in the scene and rendered', JSON.stringify(stats));

  // ---- three keys by clicking the canvas ---------------------------------------------
  const keys = sample.keys.length >= 3 ? sample.keys.slice(0, 3) : [701, 963, 1184];
  for (const v of keys) {
    const p = await screenOf(v);
    await page.mouse.click(p.x, p.y);
    await idle();
  }
  s = await state();
  let line = activeOf(s);
  check(line.keys.length === 3, 'three clicks place three keys', () => JSON.stringify(line.keys));
  check(JSON.stringify(line.keys) === JSON.stringify(keys), 'clicks snap to the clicked vertices', () => `${line.keys} vs ${keys}`);
  const r1 = s.lastResult;
  check(r1 && r1.refined && r1.refined.points.length >= 10, 'a refined line came back', () => JSON.stringify(r1)?.slice(0, 300));
  if (!r1?.refined) throw new Fatal('no refined line; cannot go on');
  const kp = r1.initial.points;
  const first = kp[0];
  const last = kp[kp.length - 1];
  const mid = r1.initial.points[r1.initial.vertices.indexOf(keys[1])];
  const chords = dist(first, mid) + dist(mid, last);
  check(r1.refined.length >= 0.95 * chords && r1.refined.length <= 1.5 * chords && r1.refined.length <= r1.initial.length * 1.05,
    `the refined line's length is plausible (${r1.refined.length.toFixed(3)}; chords ${chords.toFixed(3)}, initial ${r1.initial.length.toFixed(3)})`);
  check(s.requestCount >= 2 && s.requestCount === s.responseCount, `requests were answered (${s.requestCount})`);
  stats = await page.evaluate(() => window.featureline.sceneStats());
  check(stats.refinedLines === 1 && stats.initialLines === 1 && stats.keyMarkers === 3, 'the initial and refined lines and three keys are drawn', JSON.stringify(stats));
  let probe = await page.evaluate(() => window.featureline.probe());
  check(probe.refined > 200 && probe.initial > 30, `the lines show on the canvas (${probe.refined} refined, ${probe.initial} initial pixels)`, JSON.stringify(probe));
  check(/total/.test(await page.textContent('#timings')), 'the last run\'s timings are shown');

  // ---- drag the middle key ---------------------------------------------------------------
  const before = await state();
  const anchorBefore = await screenOf(keys[0]);
  const from = await screenOf(keys[1]);
  const to = { x: from.x + 10, y: from.y + 45 };
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) {
    await page.mouse.move(from.x + ((to.x - from.x) * i) / 10, from.y + ((to.y - from.y) * i) / 10);
    await sleep(30);
  }
  await page.mouse.up();
  await idle();
  s = await state();
  line = activeOf(s);
  const anchorAfter = await screenOf(keys[0]);
  check(Math.hypot(anchorAfter.x - anchorBefore.x, anchorAfter.y - anchorBefore.y) < 0.5, 'dragging a key does not orbit the camera');
  check(line.keys.length === 3 && line.keys[1] !== keys[1], `the dragged key moved (vertex ${keys[1]} -> ${line.keys[1]})`);
  check(s.requestCount > before.requestCount, `dragging sent new requests (${before.requestCount} -> ${s.requestCount})`);
  const r2 = s.lastResult;
  check(r2 && r2.keys[1] === line.keys[1] && JSON.stringify(r2.refined.points) !== JSON.stringify(r1.refined.points),
    'the line follows the dragged key', () => `result keys ${r2?.keys}`);
  stats = await page.evaluate(() => window.featureline.sceneStats());
  check(stats.refinedLines === 1 && stats.keyMarkers === 3, 'the updated line is drawn', JSON.stringify(stats));

  // ---- options -------------------------------------------------------------------------------
  // The inputs' limits and choices come from the server's option tables (GET /v1/options).
  const tables = await (await fetch(`${base}/v1/options`)).json();
  const row = (name) => tables.feature_line.find((r) => r.name === name);
  await until('the option tables to reach the form', async () => (await page.getAttribute('#opt-s-iterations', 'max')) !== null, 5000);
  const inputs = await page.evaluate(() => ({
    iterations: ['min', 'max', 'step'].map((a) => document.getElementById('opt-s-iterations').getAttribute(a)),
    alpha: ['min', 'max', 'step'].map((a) => document.getElementById('opt-s-alpha').getAttribute(a)),
    forces: [...document.getElementById('opt-s-force').options].map((o) => o.value),
  }));
  check(JSON.stringify(inputs.iterations) === JSON.stringify([String(row('snake.max_iterations').minimum), String(row('snake.max_iterations').maximum), '1']),
    'the iterations input takes its limits from /v1/options', JSON.stringify(inputs.iterations));
  check(inputs.alpha[1] === String(row('snake.alpha').maximum) && inputs.alpha[2] === 'any', 'a number input gets step "any"', JSON.stringify(inputs.alpha));
  check(JSON.stringify(inputs.forces) === JSON.stringify(['', ...row('snake.force').enum]), 'a choice lists the table\'s names', JSON.stringify(inputs.forces));
  let n0 = s.requestCount;
  const defaultIterations = s.lastResult.stats.iterations;
  await page.fill('#opt-s-iterations', '5');
  await until('the options to be applied', async () => (await state()).requestCount > n0);
  await idle();
  s = await state();
  check(JSON.stringify(await page.evaluate(() => window.featureline.options)) === '{"snake":{"max_iterations":5}}', 'the options panel maps to "options"');
  // stats.iterations adds up the snake's iterations over the line's pieces.
  check(s.lastResult.stats.iterations <= 5 * s.lastResult.stats.pieces && s.lastResult.stats.iterations < defaultIterations,
    `snake iterations follow the options panel (${s.lastResult.stats.iterations} over ${s.lastResult.stats.pieces} piece(s))`);
  n0 = s.requestCount;
  await page.selectOption('#opt-initial', 'marching');
  await until('the initial method to be applied', async () => (await state()).requestCount > n0);
  await idle();
  s = await state();
  check(s.lastResult.initial.method === 'marching' || s.lastResult.stats.fallbacks.length > 0,
    `the initial method follows the options panel (${s.lastResult.initial.method})`);
  await page.selectOption('#opt-initial', '');
  // The fitted curve: asked for by the options panel, answered, drawn beside the line.
  n0 = s.requestCount;
  await page.selectOption('#opt-fitted', 'true');
  await until('the fitted curve to be asked for', async () => (await state()).requestCount > n0);
  await idle();
  s = await state();
  stats = await page.evaluate(() => window.featureline.sceneStats());
  check(Array.isArray(s.lastResult.fitted?.points) && s.lastResult.fitted.points.length >= 2 && stats.fittedLines === 1,
    'the fitted-curve option gets a fitted curve, drawn', `${s.lastResult.fitted?.points?.length} points, ${JSON.stringify(stats)}`);
  // Back to the options of an earlier answer: that answer is taken from the page's cache (no
  // request), after the options' debounce.
  await page.selectOption('#opt-fitted', '');
  for (let i = 0; i < 50 && (await page.evaluate(() => window.featureline.sceneStats())).fittedLines !== 0; i++) await sleep(100);
  await idle();
  stats = await page.evaluate(() => window.featureline.sceneStats());
  check(stats.fittedLines === 0, 'without it no fitted curve is drawn', JSON.stringify(stats));
  await page.fill('#opt-s-iterations', '');
  await sleep(400);
  await idle();

  // ---- closed loop, delete a key ------------------------------------------------------------
  await page.check('#closed-toggle');
  await idle();
  s = await state();
  check(s.lastResult.closed === true, 'the closed-loop toggle closes the line');
  await page.uncheck('#closed-toggle');
  await idle();
  const extra = await screenOf(keys[2] - 3 * 41 < 0 ? 5 : keys[2] - 3 * 41);
  await page.mouse.click(extra.x, extra.y);
  await idle();
  const withExtra = activeOf(await state()).keys.length;
  const p4 = await screenOf(activeOf(await state()).keys[3]);
  await page.mouse.click(p4.x, p4.y, { button: 'right' });
  await idle();
  s = await state();
  check(withExtra === 4 && activeOf(s).keys.length === 3 && s.lastResult.keys.length === 3, 'a fourth key is added and deleted by right-click',
    () => `${withExtra} then ${activeOf(s).keys.length}`);

  // ---- a second line ---------------------------------------------------------------------------
  await page.click('#add-line');
  // Near the left and right borders, across the ridge: with the first line it cuts the field in two.
  // Placed exactly where clicked: snapping off (S), as for a cut meant to run border to border.
  await page.keyboard.press('s');
  check(!(await page.evaluate(() => window.featureline.snapping)) && !(await page.isChecked('#snap-toggle')), 'S turns snapping off');
  const underPointer = [];
  for (const v of [821, 859]) {
    const p = await screenOf(v);
    underPointer.push((await page.evaluate(([x, y]) => window.featureline.pickVertexAt(x, y), [p.x, p.y])).vertex);
    await page.mouse.click(p.x, p.y);
    await idle();
  }
  s = await state();
  check(s.lines.length === 2 && s.lines.every((l) => l.result && !l.error), 'a second line is detected', () => JSON.stringify(s.lines.map((l) => [l.keys, l.error])));
  check(JSON.stringify(s.lines[1].keys) === JSON.stringify(underPointer), 'without snapping keys land on the vertices under the pointer',
    () => `${s.lines[1].keys} vs ${underPointer}`);
  await page.keyboard.press('s');
  stats = await page.evaluate(() => window.featureline.sceneStats());
  check(stats.refinedLines === 2 && stats.initialLines === 2 && stats.keyMarkers === 5, 'both lines are drawn', JSON.stringify(stats));
  check((await page.locator('#line-list li').count()) === 2, 'the line list shows both lines');

  // ---- downloads ------------------------------------------------------------------------------------
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#download-json')]);
  const saved = path.join(tmp, 'lines.json');
  await download.saveAs(saved);
  const doc = JSON.parse(fs.readFileSync(saved, 'utf8'));
  check(doc.lines?.length === 2 && doc.lines[0].refined.points.length >= 2, `the lines download as JSON (${download.suggestedFilename()})`);
  const [glbDownload] = await Promise.all([page.waitForEvent('download'), page.click('#download-glb')]);
  const glbPath = path.join(tmp, 'lines.glb');
  await glbDownload.saveAs(glbPath);
  check(fs.readFileSync(glbPath).subarray(0, 4).toString() === 'glTF', `the lines download as GLB (${glbDownload.suggestedFilename()})`);

  // ---- curvature colours -------------------------------------------------------------------------
  await page.check('#curvature-toggle');
  check(await page.isVisible('#legend'), 'the curvature colour map has a legend');
  const range = await page.evaluate(() => window.featureline.curvatureRange);
  check(range > 0, `the curvature range is symmetric and robust (±${range.toFixed(3)})`);
  fs.mkdirSync(path.dirname(ARTIFACT), { recursive: true });
  await sleep(200);
  await page.screenshot({ path: path.join(path.dirname(ARTIFACT), 'web-curvature.png') });
  await page.uncheck('#curvature-toggle');

  // ---- decomposition by the real server: the border-to-border line cuts the field in two -----------
  // Requests are counted: one POST /segmentation per Decompose, carrying the lines the page
  // already has (computed once, not detected again), and nothing asked again as GLB.
  const apiRequests = [];
  const countRequest = (r) => {
    const u = new URL(r.url());
    if (u.pathname.startsWith('/v1/')) apiRequests.push({ what: `${r.method()} ${u.pathname.replace(/meshes\/[^/]+/, 'meshes/ID')}${u.search}`, body: r.postData() });
  };
  const segmentationPosts = () => apiRequests.filter((r) => r.what.startsWith('POST /v1/meshes/ID/segmentation'));
  page.on('request', countRequest);
  await page.click('#decompose');
  await until('the decomposition to finish', async () => {
    const t = await state();
    return t.segmentation || t.decomposeMessage;
  }, 30000);
  s = await state();
  const seg = s.segmentation;
  check(seg && seg.segments.length >= 2 && seg.faceColored && seg.labels.length === 3200,
    `decomposition answered ${seg?.segments?.length} segment(s), a label per face`, () => JSON.stringify(seg ?? s.decomposeMessage).slice(0, 300));
  if (seg) {
    const total = seg.segments.reduce((a, x) => a + x.area, 0);
    check(Math.abs(total - seg.total_area) < 1e-9 && seg.segments[1].area > 0.2 * total,
      `the two large parts are real halves (areas ${seg.segments.map((x) => x.area.toFixed(3)).join(', ')})`);
    check((await page.locator('#segments tbody tr').count()) === seg.segments.length + 1, 'the segments and their areas are listed');
  }
  let sent = JSON.parse(segmentationPosts()[0]?.body ?? 'null');
  check(segmentationPosts().length === 1 && apiRequests.length === 1 && sent?.lines?.length === 2 && sent.lines.every((l) => Array.isArray(l.refined?.faces) && l.refined.faces.length === l.refined.barycentric.length),
    'one segmentation request per Decompose, sending the lines the page already has (faces and barycentric coordinates)',
    () => JSON.stringify(apiRequests.map((r) => r.what)));
  check(seg && seg.segments.every((x) => Array.isArray(x.color)) &&
    (await page.locator('#segments .swatch').first().evaluate((e) => getComputedStyle(e).backgroundColor)) ===
      `rgb(${seg.segments[0].color.map((c) => Math.round(c * 255)).join(', ')})`,
    'the swatches show the colours the server answers');
  // Remesh mode: the parts are drawn from the answer itself, and downloaded from it too.
  apiRequests.length = 0;
  await page.selectOption('#decompose-mode', 'remesh');
  await page.click('#decompose');
  await until('the remesh decomposition', async () => (await page.evaluate(() => window.featureline.sceneStats())).segmentSceneShown, 30000);
  s = await state();
  sent = JSON.parse(segmentationPosts()[0]?.body ?? 'null');
  check(!s.segmentation.faceColored && s.segmentation.remeshed.faces.length === s.segmentation.labels.length &&
    segmentationPosts().length === 1 && apiRequests.length === 1 && sent?.mode === 'remesh' && sent.lines.every((l) => l.refined),
    'remesh mode: one request, its answer\'s remeshed parts drawn (no GLB asked for, no line detected again)',
    () => JSON.stringify(apiRequests.map((r) => r.what)));
  const [remeshDownload] = await Promise.all([page.waitForEvent('download'), page.click('#download-segmented')]);
  const remeshPath = path.join(tmp, 'segments.glb');
  await remeshDownload.saveAs(remeshPath);
  const remeshGlb = fs.readFileSync(remeshPath);
  check(remeshGlb.subarray(0, 4).toString() === 'glTF' && apiRequests.length === 1,
    `the remeshed parts download as GLB written from the answer, with no request (${remeshGlb.length} bytes)`);
  page.off('request', countRequest);
  await page.uncheck('#segments-toggle');
  await page.selectOption('#decompose-mode', 'snap');

  // ---- the screenshot -------------------------------------------------------------------------------
  await page.click('#line-list li:first-child .name');
  await page.mouse.move(5, 5); // off the canvas: no key shown as hovered
  await sleep(300);
  probe = await page.evaluate(() => window.featureline.probe());
  check(probe.refined > 200 && probe.background < probe.total * 0.9, 'the final view shows the mesh and the lines', JSON.stringify(probe));
  await page.screenshot({ path: ARTIFACT });
  check(fs.statSync(ARTIFACT).size > 10000, `screenshot saved to ${path.relative(process.cwd(), ARTIFACT)}`);

  // ---- the decomposition display, against the documented answer (served by a stand-in) -----
  // Snap mode: one label per face of the session's mesh -> faces coloured by label.
  const labels = Array.from({ length: 3200 }, (_, f) => (f < 1600 ? 0 : 1));
  const snapAnswer = {
    labels,
    segments: [
      { label: 0, faces: 1600, area: 2.1, boundary_length: 3.5 },
      { label: 1, faces: 1600, area: 2.2, boundary_length: 3.4 },
    ],
    warnings: ['stand-in answer'],
  };
  const glbBytes = fs.readFileSync(glbPath);
  let segmentationRequest = null;
  await page.route('**/segmentation*', async (route) => {
    const req = route.request();
    segmentationRequest = JSON.parse(req.postData() || 'null');
    if (new URL(req.url()).searchParams.get('format') === 'glb')
      return route.fulfill({ status: 200, contentType: 'model/gltf-binary', body: glbBytes });
    const mode = segmentationRequest?.mode;
    const answer = mode === 'remesh'
      ? { ...snapAnswer, mode, labels: Array.from({ length: 3300 }, (_, f) => f % 2), remeshed: { vertices: 1700, faces: 3300 } }
      : { ...snapAnswer, mode };
    return route.fulfill({ status: 200, contentType: 'application/json', body: JSON.stringify(answer) });
  });
  await page.click('#decompose');
  await until('the stand-in decomposition', async () => (await state()).segmentation);
  s = await state();
  check(segmentationRequest?.mode === 'snap' && segmentationRequest.lines.length === 2 && segmentationRequest.lines[0].keys.length === 3,
    'decompose sends {"lines": [...], "mode"}', JSON.stringify(segmentationRequest));
  check(s.segmentation.faceColored && (await page.evaluate(() => window.featureline.colorMode)) === 'segments' && (await page.isChecked('#segments-toggle')),
    'snap-mode labels colour the faces');
  check((await page.locator('#segments tbody tr').count()) === 3 && /4\.3/.test(await page.textContent('#segments')), 'segment areas are listed with their total');
  const [segDownload] = await Promise.all([page.waitForEvent('download'), page.click('#download-segmented')]);
  check(/segments\.glb$/.test(segDownload.suggestedFilename()), `the segmented mesh downloads (${segDownload.suggestedFilename()})`);
  await page.screenshot({ path: path.join(path.dirname(ARTIFACT), 'web-segments.png') });
  // Remesh mode: labels of another surface -> the server's segmented GLB is shown instead.
  await page.selectOption('#decompose-mode', 'remesh');
  await page.evaluate(() => (document.getElementById('decompose-status').textContent = ''));
  await page.click('#decompose');
  await until('the stand-in remesh decomposition', async () => (await page.evaluate(() => window.featureline.sceneStats())).segmentSceneShown);
  s = await state();
  check(!s.segmentation.faceColored && s.segmentation.labels.length === 3300, 'remesh-mode labels show the segmented GLB instead');
  await page.uncheck('#segments-toggle');
  check(!(await page.evaluate(() => window.featureline.sceneStats())).segmentSceneShown, 'the segment colours toggle off');
  await page.unroute('**/segmentation*');

  check(h.pageErrors.length === 0, 'no uncaught errors in the page', h.pageErrors.join('\n'));
  const unexpected = h.consoleErrors.filter((t) => !/Failed to load resource/.test(t));
  check(unexpected.length === 0, 'no errors logged in the console', unexpected.join('\n'));
}

await h.run(run);
