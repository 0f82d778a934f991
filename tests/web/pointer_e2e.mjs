#!/usr/bin/env node
// End-to-end test of pointing at the mesh: on a touch screen a tap places a key and
// a finger dragged from a key's marker moves that key; on igea (269k triangles) the page's
// picking (a triangle grid walked along the ray, web/src/raycast.js) finds the same face at the
// same distance as three.js's raycast of every triangle, and the time per hover (pick, snap,
// read-out, preview) is printed beside three.js's raycast alone (figures, not assertions).
//
//   node tests/web/pointer_e2e.mjs
//
// Environment: as tests/web/e2e.mjs (SERVER, ARTIFACTS, CHROMIUM, WEB_ROOT); screenshot
// web-touch.png beside ARTIFACTS.
import path from 'node:path';
import { createHarness, repo, sharedMesh, until, Fatal } from './harness.mjs';

const h = createHarness({ totalTimeoutMs: 180_000, artifactName: 'web.png' });
const { check } = h;
const SAMPLE = path.join(repo, 'samples', 'ridge_field.off');

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
  const page = await h.launch({ width: 1280, height: 800 }, { hasTouch: true });
  await page.goto(`${h.base}/?trace=0`);
  await page.waitForFunction(() => window.featureline);
  const state = () => page.evaluate(() => ({ mesh: window.featureline.mesh, lines: window.featureline.lines.map((l) => ({ keys: l.keys })) }));
  const screenOf = (v) => page.evaluate((vv) => window.featureline.screenPositionOfVertex(vv), v);

  await page.setInputFiles('#file-input', SAMPLE);
  await until('the sample to open', async () => (await state()).mesh?.faceCount === 3200, 20000);
  await page.evaluate(() => window.featureline.idle());

  // ---- a tap places a key -------------------------------------------------------------------------
  const view = await page.locator('#view').boundingBox();
  const tapAt = { x: view.x + view.width * 0.45, y: view.y + view.height * 0.5 };
  const expected = await page.evaluate(([x, y]) => window.featureline.pickVertexAt(x, y), [tapAt.x, tapAt.y]);
  if (!expected) throw new Fatal('the middle of the view is not on the sample mesh');
  await page.touchscreen.tap(tapAt.x, tapAt.y);
  await until('the tap to place a key', async () => (await state()).lines[0]?.keys.length === 1, 5000).catch(() => null);
  let s = await state();
  const placed = s.lines[0]?.keys[0];
  const placedAt = placed === undefined ? null : await screenOf(placed);
  check(s.lines[0]?.keys.length === 1 && placedAt && Math.hypot(placedAt.x - tapAt.x, placedAt.y - tapAt.y) <= 12,
    `a tap places a key (vertex ${placed}, tapped near vertex ${expected.vertex})`, () => JSON.stringify(s.lines));
  const secondAt = { x: view.x + view.width * 0.6, y: view.y + view.height * 0.45 };
  await page.touchscreen.tap(secondAt.x, secondAt.y);
  await until('the second tap to place a key', async () => (await state()).lines[0]?.keys.length === 2, 5000).catch(() => null);
  s = await state();
  check(s.lines[0]?.keys.length === 2, 'a second tap places a second key', () => JSON.stringify(s.lines));

  // ---- a finger on a key's marker drags the key (not the view) ----------------------------------------
  const before = s.lines[0].keys.slice();
  const from = await screenOf(before[1]);
  const to = { x: from.x - 60, y: from.y + 50 };
  const cdp = await page.context().newCDPSession(page);
  const touch = (type, p) => cdp.send('Input.dispatchTouchEvent', { type, touchPoints: p ? [{ x: p.x, y: p.y, id: 1 }] : [] });
  const camera = await page.evaluate(() => window.featureline.sceneStats().cameraPosition ?? null);
  await touch('touchStart', from);
  for (let i = 1; i <= 8; ++i) {
    await touch('touchMove', { x: from.x + ((to.x - from.x) * i) / 8, y: from.y + ((to.y - from.y) * i) / 8 });
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => r())));
  }
  await touch('touchEnd');
  await until('the dragged key to move', async () => (await state()).lines[0].keys[1] !== before[1], 5000).catch(() => null);
  s = await state();
  const movedAt = await screenOf(s.lines[0].keys[1]);
  check(s.lines[0].keys.length === 2 && s.lines[0].keys[0] === before[0] && s.lines[0].keys[1] !== before[1] &&
    Math.hypot(movedAt.x - to.x, movedAt.y - to.y) <= 15,
    `a finger dragged from key 2's marker moves that key (vertex ${before[1]} -> ${s.lines[0].keys[1]}, ${Math.round(Math.hypot(movedAt.x - to.x, movedAt.y - to.y))} px from the finger)`,
    () => JSON.stringify(s.lines));
  const cameraAfter = await page.evaluate(() => window.featureline.sceneStats().cameraPosition ?? null);
  check(JSON.stringify(camera) === JSON.stringify(cameraAfter), 'the view did not orbit while the key was dragged');
  await page.screenshot({ path: h.artifact('web-touch.png') });

  // ---- igea: grid picking agrees with three.js, and what a hover costs ------------------------------------
  await page.setInputFiles('#file-input', IGEA);
  await until('the confirmation', () => page.isVisible('#confirm'), 5000);
  await page.click('#confirm-ok');
  await until('igea to open', async () => (await state()).mesh?.faceCount === 268686, 90000);
  await page.evaluate(() => window.featureline.idle());
  const figures = await page.evaluate(([x0, y0, w, hgt]) => {
    const f = window.featureline;
    const points = [];
    for (let i = 0; i < 12; ++i) for (let j = 0; j < 10; ++j) points.push([x0 + (w * (i + 0.5)) / 12, y0 + (hgt * (j + 0.5)) / 10]);
    f.pickVertexAt(points[0][0], points[0][1]); // builds the grid (once per mesh)
    const hover = [];
    const hoverOnMesh = [];
    const three = [];
    let hits = 0;
    const disagreements = [];
    for (const [x, y] of points) {
      let t = performance.now();
      f.hoverAt(x, y);
      hover.push(performance.now() - t);
      t = performance.now();
      const reference = f.threeRaycastAt(x, y);
      three.push(performance.now() - t);
      const mine = f.pickVertexAt(x, y);
      if (mine) hoverOnMesh.push(hover[hover.length - 1]);
      if (!!mine !== !!reference) disagreements.push({ x, y, mine, reference });
      else if (mine) {
        ++hits;
        if (mine.face !== reference.face && Math.abs(mine.distance - reference.distance) > 1e-4 * reference.distance)
          disagreements.push({ x, y, mine: { face: mine.face, distance: mine.distance }, reference });
      }
    }
    let t = performance.now();
    f.pickVertexAt(-1e4, -1e4);
    const miss = performance.now() - t;
    return { hover, hoverOnMesh, three, hits, total: points.length, disagreements, miss };
  }, [view.x, view.y, view.width, view.height]);
  check(figures.hits > 20 && figures.disagreements.length === 0,
    `on igea the page's picking finds three.js's face at three.js's distance at every one of ${figures.total} points (${figures.hits} on the mesh)`,
    () => JSON.stringify(figures.disagreements.slice(0, 3)));
  console.log(`# igea (268,686 triangles), ${figures.total} pointer positions over the view: hover (pick, snap, read-out, preview) median ${median(figures.hoverOnMesh).toFixed(2)} ms on the mesh (${figures.hits} points), ${median(figures.hover).toFixed(2)} ms over all, max ${Math.max(...figures.hover).toFixed(2)} ms; a pick that misses ${figures.miss.toFixed(2)} ms; three.js raycast of every triangle median ${median(figures.three).toFixed(2)} ms`);
  check(h.pageErrors.length === 0, 'no uncaught errors in the page', h.pageErrors.join('\n'));
});
