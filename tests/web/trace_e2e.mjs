#!/usr/bin/env node
// End-to-end test of one-click lines in the page (trace mode, on by default): hovering over the
// rim of a capped cylinder shows the closed rim faintly before any click, the preview goes when
// the pointer leaves the mesh, a click gives the whole rim as one closed line; on the ridge
// sample a click on the crest traces the ridge border to border; Shift+click turns a traced line
// into a keyed one (undo brings the traced line back); a click on a flat cap says there is
// nothing to trace and leaves no edit; T switches to key mode; on a cube, a traced edge stopped
// at a corner goes on along the edge clicked next. Prints the hover preview's
// latency (pointer move to preview drawn). The real server and Debian's Chromium.
//
//   node tests/web/trace_e2e.mjs
//
// Environment: as tests/web/e2e.mjs (SERVER, ARTIFACTS, CHROMIUM, WEB_ROOT); the screenshot
// goes beside ARTIFACTS as web-trace.png.
import fs from 'node:fs';
import path from 'node:path';
import { createHarness, until } from './harness.mjs';

const h = createHarness({ totalTimeoutMs: 200_000, artifactName: 'web.png' });
const { check, ok } = h;

// A capped cylinder along y (radius 1, height 1): `segments` around, `rows` rows of quads up
// the side, each cap a fan around its centre. Its two rims are closed loops of 90-degree
// creases, `segments` edges each; vertex k of the top rim is 1 + (rows)*segments + k (1-based).
function cylinderObj(segments, rows) {
  const lines = [];
  for (let r = 0; r <= rows; ++r)
    for (let k = 0; k < segments; ++k) {
      const a = (2 * Math.PI * k) / segments;
      lines.push(`v ${Math.cos(a)} ${r / rows} ${Math.sin(a)}`);
    }
  const bottom = (rows + 1) * segments + 1;
  lines.push('v 0 0 0', 'v 0 1 0');
  const id = (r, k) => r * segments + (k % segments) + 1;
  for (let r = 0; r < rows; ++r)
    for (let k = 0; k < segments; ++k) {
      lines.push(`f ${id(r, k)} ${id(r + 1, k)} ${id(r + 1, k + 1)}`);
      lines.push(`f ${id(r, k)} ${id(r + 1, k + 1)} ${id(r, k + 1)}`);
    }
  for (let k = 0; k < segments; ++k) {
    lines.push(`f ${bottom} ${id(0, k)} ${id(0, k + 1)}`);
    lines.push(`f ${bottom + 1} ${id(rows, k + 1)} ${id(rows, k)}`);
  }
  return `${lines.join('\n')}\n`;
}

// The unit cube, each face an n x n grid of quads (two triangles each), as OBJ text, and the
// 0-based id of each lattice point (i, j, k) on it. Its 12 edges are creases that meet three at
// a time at the corners.
function cubeObj(n) {
  const ids = new Map();
  const lines = [];
  const id = (p) => {
    const key = p.join(',');
    if (!ids.has(key)) {
      ids.set(key, ids.size);
      lines.push(`v ${p.map((c) => c / n).join(' ')}`);
    }
    return ids.get(key);
  };
  const faces = [];
  for (let axis = 0; axis < 3; ++axis)
    for (const side of [0, n]) {
      const u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (let i = 0; i < n; ++i)
        for (let j = 0; j < n; ++j) {
          const corner = (di, dj) => {
            const p = [0, 0, 0];
            p[axis] = side;
            p[u] = i + di;
            p[v] = j + dj;
            return id(p) + 1;
          };
          const [a, b, c, d] = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
          if (side === n) faces.push(`f ${a} ${b} ${c}`, `f ${a} ${c} ${d}`);
          else faces.push(`f ${a} ${c} ${b}`, `f ${a} ${d} ${c}`);
        }
    }
  return { text: `${[...lines, ...faces].join('\n')}\n`, at: (i, j, k) => ids.get([i, j, k].join(',')) };
}

const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.floor(s.length / 2)] : NaN;
};

await h.prepare();
await h.run(async () => {
  const base = await h.startServer();
  ok('the server starts on 127.0.0.1');
  const page = await h.launch({ width: 1280, height: 800 });
  await page.goto(`${base}/`);
  await until('the app to start', () => page.evaluate(() => !!window.featureline && window.featureline.samples.length > 0));
  check((await page.evaluate(() => window.featureline.traceMode)) && (await page.isChecked('#trace-toggle')), 'trace mode is on by default');

  const state = () =>
    page.evaluate(() => ({
      lines: window.featureline.lines.map((l) => ({ keys: l.keys, trace: l.trace, closed: l.closed, error: l.error, result: l.result && { closed: l.result.closed, vertices: l.result.initial.vertices, method: l.result.initial.method, trace: l.result.trace } })),
      message: window.featureline.message,
      history: window.featureline.history,
      previews: window.featureline.previewRequests,
    }));
  const previewPoints = async () => (await page.evaluate(() => window.featureline.sceneStats())).tracePreviewPoints;
  const screenOf = (v) => page.evaluate((vv) => window.featureline.screenPositionOfVertex(vv), v);
  const idle = () => page.evaluate(() => window.featureline.idle());

  // ---- the cylinder's rim: preview on hover, one click gives the closed loop -----------------
  const segments = 48;
  const rows = 6;
  const file = path.join(h.tmp, 'cylinder.obj');
  fs.writeFileSync(file, cylinderObj(segments, rows));
  await page.setInputFiles('#file-input', file);
  await until('the cylinder to open', () => page.evaluate(() => window.featureline.mesh?.vertexCount > 0));
  await idle();
  await page.evaluate(() => window.featureline.view && null);
  // Look from above and a little to the side, so the top rim's near half is in view.
  const rimVertex = rows * segments + 12; // 0-based: top rim, k = 12 (facing +z after framing)
  let onRim = null;
  for (const k of [12, 36, 0, 24]) {
    const v = rows * segments + k;
    const p = await screenOf(v);
    const hit = await page.evaluate(([x, y]) => window.featureline.pickVertexAt(x, y), [p.x, p.y]);
    if (hit && hit.vertex === v) {
      onRim = { v, p };
      break;
    }
  }
  check(!!onRim, `a top-rim vertex is in view and pickable (tried ${rimVertex} and three others)`);
  if (onRim) {
    for (let i = 0; i < 5; ++i) {
      await page.mouse.move(5, 5);
      await until('the preview to clear', async () => (await previewPoints()) === 0, 5000);
      await page.mouse.move(onRim.p.x, onRim.p.y);
      await until('the trace preview to show', async () => (await previewPoints()) > 0, 10000);
    }
    const points = await previewPoints();
    check(points >= segments, `hovering the rim shows the traced rim faintly (${points} preview points for a ${segments}-edge loop)`);
    const s0 = await state();
    check(s0.lines.every((l) => l.keys.length === 0), 'hovering adds no key');
    check(s0.previews === 1, `moving back to the same vertex asks the server once (${s0.previews} preview requests for 5 hovers)`);
    await page.mouse.move(5, 5);
    await until('the preview to go', async () => (await previewPoints()) === 0, 5000);
    ok('the preview goes when the pointer leaves the mesh');

    await page.mouse.click(onRim.p.x, onRim.p.y);
    await idle();
    const s1 = await state();
    const line = s1.lines[0];
    check(line?.trace && line.keys.length === 1 && line.result?.closed && line.result.vertices.length === segments,
      `one click gives the whole rim as one closed traced line (${line?.result?.vertices.length} of ${segments} vertices, closed ${line?.result?.closed})`, () => JSON.stringify(line));
    check(line?.result?.vertices.every((v) => v >= rows * segments && v < (rows + 1) * segments), 'every vertex of the traced line is on the top rim');
    check(/closed loop/.test(s1.message), `the message says what was traced ("${s1.message}")`);
    await page.screenshot({ path: h.artifact('web-trace.png') });

    // Shift+click elsewhere: the traced line becomes keyed (its route kept), plus the new key.
    const side = await screenOf(2 * segments + 12);
    await page.keyboard.down('Shift');
    await page.mouse.click(side.x, side.y);
    await page.keyboard.up('Shift');
    await idle();
    const s2 = await state();
    check(!s2.lines[0].trace && s2.lines[0].keys.length === 4 && s2.lines[0].closed,
      `Shift+click turns the traced loop into a keyed loop: three keys along the rim and the new one (${JSON.stringify(s2.lines[0].keys)})`);
    await page.keyboard.press('Control+z');
    await idle();
    const s3 = await state();
    check(s3.lines[0].trace && s3.lines[0].keys.length === 1, 'undo brings the traced line back');

    // A click half way up the side, three rings from either rim: the cylinder's curvature is
    // the same in every direction along the side (no crest), so there is nothing to trace.
    const depth = s3.history.depth;
    const middle = await screenOf((rows / 2) * segments + onRim.v - rows * segments);
    await page.mouse.click(middle.x, middle.y);
    await idle();
    const s4 = await state();
    check(/Nothing to trace/.test(s4.message) && s4.history.depth === depth && s4.lines.length === s3.lines.length,
      `a click half way up the side says there is nothing to trace and edits nothing ("${s4.message}")`);
  }

  // ---- the ridge sample: a click on the crest traces the ridge across the field ------------------
  await page.selectOption('#sample-select', 'samples/ridge_field.off');
  await page.click('#sample-open');
  await until('the confirmation', () => page.isVisible('#confirm'), 5000);
  await page.click('#confirm-ok');
  await until('the sample to open', async () => (await page.evaluate(() => window.featureline.mesh?.faceCount)) === 3200);
  await idle();
  const crest = await screenOf(963); // the sample's middle key, on the crest
  await page.mouse.click(crest.x, crest.y);
  await idle();
  const r = (await state()).lines.at(-1);
  const ends = r?.result?.trace?.ends?.map((e) => e.reason) ?? [];
  check(r?.trace && r.result?.trace?.sign === 'ridge' && ends.join() === 'boundary,boundary',
    `a click on the ridge's crest traces the ridge from border to border (${r?.result?.vertices.length} vertices, ends ${ends.join(', ')})`, () => JSON.stringify(r?.result?.trace));

  // Hover latency on vertices not asked before, as the page measures it: from the pointer
  // reaching a vertex to its preview drawn (the page waits 40 ms for the pointer to rest, then
  // asks the server).
  const along = r?.result?.vertices ?? [];
  const latencies = [];
  const keyOnScreen = await screenOf(963); // the traced line's key: hovering its marker shows no preview
  for (let i = 1; latencies.length < 7 && i < along.length; i += Math.max(1, Math.floor(along.length / 12))) {
    const p = await screenOf(along[i]);
    if (Math.hypot(p.x - keyOnScreen.x, p.y - keyOnScreen.y) < 30) continue;
    await page.mouse.move(5, 5);
    await until('the preview to clear', async () => (await previewPoints()) === 0, 5000, 5);
    await page.mouse.move(p.x, p.y);
    await until('the trace preview to show', async () => (await previewPoints()) > 0, 10000, 5);
    latencies.push(await page.evaluate(() => window.featureline.previewLatencyMs));
  }
  check(latencies.length === 7, 'seven hovers along the ridge each show a preview');
  console.log(`# hover preview latency on the ridge sample (3,200 triangles), 7 vertices not asked before: median ${median(latencies).toFixed(1)} ms (${latencies.map((x) => x.toFixed(1)).join(', ')})`);

  // ---- key mode: T, and a click adds a key --------------------------------------------------------
  await page.keyboard.press('t');
  check(!(await page.evaluate(() => window.featureline.traceMode)) && !(await page.isChecked('#trace-toggle')), 'T switches trace mode off');
  await page.click('#add-line');
  const other = await screenOf(701); // another vertex of the crest (963 carries the traced line's key)
  await page.mouse.click(other.x, other.y);
  await idle();
  const lines = (await state()).lines;
  const k = lines.at(-1);
  check(!k.trace && k.keys.length === 1, 'in key mode a click adds a key to the active line', () => JSON.stringify({ keys: k.keys, trace: k.trace, lines: lines.length }));
  // ---- a traced line stopped at a junction goes on along the branch clicked next -----------------
  await page.keyboard.press('t'); // trace mode again
  const cube = cubeObj(4);
  const cubeFile = path.join(h.tmp, 'cube.obj');
  fs.writeFileSync(cubeFile, cube.text);
  await page.setInputFiles('#file-input', cubeFile);
  await until('the confirmation', () => page.isVisible('#confirm'), 5000);
  await page.click('#confirm-ok');
  await until('the cube to open', async () => (await page.evaluate(() => window.featureline.mesh?.faceCount)) === 192);
  await idle();
  // Seen from the front (+z): the top front edge (y = 1, z = 1) and the right front edge (x = 1,
  // z = 1) meet at the corner (1, 1, 1), where the top right edge meets them too.
  const corner = cube.at(4, 4, 4);
  const topEdge = await screenOf(cube.at(2, 4, 4));
  await page.mouse.click(topEdge.x, topEdge.y);
  await idle();
  let c = (await state()).lines.at(-1);
  check(c?.trace && c.result?.trace.ends.every((e) => e.reason === 'junction') && c.result.trace.ends.some((e) => e.vertex === corner),
    `a click on the cube's top front edge traces it to the two corners (${JSON.stringify(c?.result?.trace.ends)})`);
  const rightEdge = await screenOf(cube.at(4, 2, 4));
  await page.mouse.click(rightEdge.x, rightEdge.y);
  await idle();
  const lines2 = (await state()).lines;
  c = lines2.at(-1);
  check(!c.trace && c.keys.length === 5 && c.keys[2] === corner && Math.abs((await page.evaluate(() => window.featureline.lines.at(-1).result?.refined.length)) - 2) < 1e-9,
    `a click on the right front edge continues the line through the corner: two edges, length 2 (${JSON.stringify(c.keys)})`);
  check(/through the junction at vertex/.test((await state()).message), 'the message says the line went on through the junction');
});
