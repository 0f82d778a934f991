#!/usr/bin/env node
// End-to-end test of dragging a key on a small and a big mesh (the bundled sample, 3,200
// triangles, and igea, 269k) in key mode: three keys are placed by clicks, the middle one is
// dragged along 30 pointer moves (about 30 per second), and the test prints how many answers
// were drawn per second while dragging and the page's main-thread time per move (median, from
// the DevTools protocol's TaskDuration). Figures are printed, never asserted: machines are
// noisy. What is checked: the key ends on the vertex under the final pointer position, the
// line drawn is the answer for the final keys, the mesh itself was not drawn again while only
// the key and its line changed, the surface layer shows the mesh as drawing it directly does
// (also after colours, shading, edges, the view and the window's size change), and the page
// raised no errors.
//
//   node tests/web/drag_e2e.mjs
//
// Environment: as tests/web/e2e.mjs (SERVER, ARTIFACTS, CHROMIUM, WEB_ROOT); screenshot
// web-drag.png beside ARTIFACTS.
import { createHarness, sharedMesh, sleep, until, Fatal } from './harness.mjs';

const h = createHarness({ totalTimeoutMs: 240_000, artifactName: 'web.png' });
const { check } = h;
const MOVES = 30;
const MOVE_INTERVAL_MS = 33;
// Where keys are placed (fractions of the view) and the drag's step per move (pixels): down
// and a little right, away from the other two keys.
const KEY_SPOTS = [[0.4, 0.45], [0.5, 0.45], [0.6, 0.45]];
const STEP = { x: 1, y: 3 };

await h.prepare();
let IGEA;
try {
  IGEA = sharedMesh('igea.ply');
} catch (e) {
  h.fail('the test meshes are there', e.message);
  await h.cleanup();
  h.finish(1);
}

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

await h.run(async () => {
  await h.startServer();
  const page = await h.launch({ width: 1280, height: 800 });
  await page.goto(`${h.base}/?trace=0`);
  await page.waitForFunction(() => window.featureline);
  const cdp = await page.context().newCDPSession(page);
  await cdp.send('Performance.enable');
  const mainThreadMs = async () => (await cdp.send('Performance.getMetrics')).metrics.find((m) => m.name === 'TaskDuration').value * 1000;
  const idle = () => page.evaluate(() => window.featureline.idle());
  const nextFrame = () => page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(() => r()))));
  const line = () => page.evaluate(() => window.featureline.lines[0]);
  const view = await page.locator('#view').boundingBox();
  const at = ([fx, fy]) => ({ x: view.x + view.width * fx, y: view.y + view.height * fy });

  // Snapping off: the key goes exactly to the vertex under the pointer, which is what is checked.
  await page.uncheck('#snap-toggle');
  check(!(await page.evaluate(() => window.featureline.snapping)), 'snapping is off (keys go to the vertex under the pointer)');

  await until('the bundled samples to be listed', () => page.evaluate(() => window.featureline.samples.length > 0), 20000);
  const meshes = [
    { name: 'the bundled sample (ridge_field, 3,200 triangles)', faces: 3200, open: () => page.selectOption('#sample-select', 'samples/ridge_field.off').then(() => page.click('#sample-open')) },
    { name: 'igea (268,686 triangles)', faces: 268686, open: () => page.setInputFiles('#file-input', IGEA) },
  ];
  const report = [];
  for (const mesh of meshes) {
    const hasKeys = await page.evaluate(() => window.featureline.lines.some((l) => l.keys.length > 0));
    await mesh.open();
    if (hasKeys) {
      await until('the confirmation to replace the keys', () => page.isVisible('#confirm'), 10000);
      await page.click('#confirm-ok');
    }
    await until(`${mesh.name} to open`, () => page.evaluate((n) => window.featureline.mesh?.faceCount === n, mesh.faces), 120000);
    await idle();

    // ---- three keys, the middle one dragged ------------------------------------------------
    const path = [];
    const start = at(KEY_SPOTS[1]);
    for (let i = 1; i <= MOVES; ++i) path.push({ x: start.x + STEP.x * i, y: start.y + STEP.y * i });
    const onMesh = await page.evaluate((ps) => ps.every((p) => window.featureline.pickVertexAt(p.x, p.y)), [...KEY_SPOTS.map(at), ...path]);
    if (!onMesh) throw new Fatal(`the keys' spots or the drag's path leave ${mesh.name}`);
    for (const spot of KEY_SPOTS) {
      const p = at(spot);
      await page.mouse.click(p.x, p.y);
      await sleep(350); // apart, so no two clicks make a double-click
    }
    await idle();
    const placed = await line();
    check(placed.keys.length === 3 && placed.result && !placed.stale, `${mesh.name}: three keys placed by clicks and their line drawn`, () => JSON.stringify({ keys: placed.keys, stale: placed.stale }));

    const from = await page.evaluate((v) => window.featureline.screenPositionOfVertex(v), placed.keys[1]);
    const before = await page.evaluate(() => ({ requests: window.featureline.requestCount, responses: window.featureline.responseCount, ...window.featureline.sceneStats() }));
    await page.mouse.move(from.x, from.y);
    await page.mouse.down();
    const shift = { x: from.x - start.x, y: from.y - start.y }; // the path, from where the key is drawn
    const moves = path.map((p) => ({ x: p.x + shift.x, y: p.y + shift.y }));
    const windows = [];
    const t0 = performance.now();
    let busy = await mainThreadMs();
    for (const [i, p] of moves.entries()) {
      const due = t0 + i * MOVE_INTERVAL_MS;
      if (performance.now() < due) await sleep(due - performance.now());
      await page.mouse.move(p.x, p.y);
      if (i > 0) {
        const now = await mainThreadMs();
        windows.push(now - busy);
        busy = now;
      }
    }
    await page.mouse.up();
    await idle();
    await nextFrame();
    const t1 = performance.now();
    const end = await mainThreadMs();
    windows.push(end - busy);
    const after = await page.evaluate(() => ({ requests: window.featureline.requestCount, responses: window.featureline.responseCount, ...window.featureline.sceneStats() }));
    const answers = after.responses - before.responses;
    const figures = {
      mesh: mesh.name,
      answers,
      seconds: (t1 - t0) / 1000,
      perSecond: answers / ((t1 - t0) / 1000),
      medianMs: median(windows),
      totalMs: windows.reduce((a, b) => a + b, 0),
      frames: after.frames - before.frames,
      surfaceDraws: after.surfaceDraws === undefined ? null : after.surfaceDraws - before.surfaceDraws,
    };
    report.push(figures);
    console.log(`# ${mesh.name}: drag of ${MOVES} moves every ${MOVE_INTERVAL_MS} ms: ${answers} answers drawn in ${figures.seconds.toFixed(2)} s (${figures.perSecond.toFixed(1)} per second, to the last answer drawn); main-thread time per move median ${figures.medianMs.toFixed(1)} ms, mean ${(figures.totalMs / MOVES).toFixed(1)} ms, ${figures.totalMs.toFixed(0)} ms in all; ${after.requests - before.requests} requests; ${figures.frames} frames, the mesh drawn ${figures.surfaceDraws ?? '?'} times`);

    // ---- where the key ended, and what is drawn -----------------------------------------------
    const last = moves[moves.length - 1];
    const under = await page.evaluate(([x, y]) => window.featureline.pickVertexAt(x, y)?.vertex, [last.x, last.y]);
    const dragged = await line();
    check(dragged.keys.length === 3 && dragged.keys[0] === placed.keys[0] && dragged.keys[2] === placed.keys[2] && dragged.keys[1] === under,
      `${mesh.name}: the dragged key ends on the vertex under the final pointer position (vertex ${placed.keys[1]} -> ${dragged.keys[1]}, under the pointer ${under})`,
      () => JSON.stringify({ before: placed.keys, after: dragged.keys, under }));
    const result = dragged.result;
    check(result && !dragged.stale && JSON.stringify(result.keys) === JSON.stringify(dragged.keys),
      `${mesh.name}: the line's answer is for the final keys`, () => JSON.stringify({ stale: dragged.stale, answered: result?.keys, keys: dragged.keys }));
    const drawn = (kind) => (after.drawnLines ?? []).find((d) => d.lineId === dragged.id && d.kind === kind);
    for (const kind of ['initial', 'refined']) {
      const d = drawn(kind);
      const points = result?.[kind]?.points ?? [];
      const same = (a, b) => a && b && a.every((x, k) => Math.abs(x - b[k]) <= 1e-6 * (1 + Math.abs(b[k])));
      check(d && !d.stale && d.segments === points.length - 1 && same(d.first, points[0]) && same(d.last, points[points.length - 1]),
        `${mesh.name}: the ${kind} line drawn is the final answer's (${points.length} points)`, () => JSON.stringify({ drawn: d, points: points.length }));
    }
    check(figures.surfaceDraws === 0, `${mesh.name}: the mesh itself was not drawn again while the key was dragged (drawn ${figures.surfaceDraws} times)`);
    const difference = await page.evaluate(() => window.featureline.surfaceLayerDifference?.() ?? { differing: 'all', pixels: '?' });
    check(difference.differing === 0, `${mesh.name}: the surface layer shows the mesh pixel for pixel as drawing it directly does (${difference.differing} of ${difference.pixels} pixels differ)`);
  }
  // ---- the surface is drawn again whenever it changes -------------------------------------------
  // Whatever changes the surface's picture must show: colours, shading, edges, the view, the size.
  const changes = [
    ['curvature colours on', () => page.check('#curvature-toggle')],
    ['flat shading on', () => page.check('#flat-toggle')],
    ['sharp edges on', () => page.check('#edges-toggle')],
    ['the view from the top', () => page.click('#view-top')],
    ['a smaller window', () => page.setViewportSize({ width: 1100, height: 700 })],
    ['curvature colours off', () => page.uncheck('#curvature-toggle')],
  ];
  for (const [what, change] of changes) {
    const draws = (await page.evaluate(() => window.featureline.sceneStats())).surfaceDraws;
    await change();
    await nextFrame();
    const now = (await page.evaluate(() => window.featureline.sceneStats())).surfaceDraws;
    const difference = await page.evaluate(() => window.featureline.surfaceLayerDifference?.() ?? { differing: 'all', pixels: '?' });
    check(now > draws && difference.differing === 0, `after ${what} the surface is drawn again and matches drawing directly (${difference.differing} pixels differ)`,
      () => JSON.stringify({ draws, now, difference }));
  }
  await page.screenshot({ path: h.artifact('web-drag.png') });
  console.log('# mesh | answers drawn per second while dragging | main-thread time per move (median) | main-thread time for the drag');
  for (const f of report) console.log(`# ${f.mesh} | ${f.perSecond.toFixed(1)} | ${f.medianMs.toFixed(1)} ms | ${f.totalMs.toFixed(0)} ms`);
  check(h.pageErrors.length === 0 && h.consoleErrors.length === 0, 'no uncaught errors or console errors in the page', [...h.pageErrors, ...h.consoleErrors].join('\n'));
});
