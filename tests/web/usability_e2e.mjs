#!/usr/bin/env node
// End-to-end test of the page's usability: a tall narrow window (the panel a drawer, the mesh
// framed by both fields of view), key markers hidden behind a CAD part (faint, not pickable),
// the status line in view however the panel scrolls, keys typed by vertex id, renamed lines,
// camera presets and the orthographic view saved with the session, "+ Line" without a mesh,
// what Delete and C say, the line downloads the server writes (OBJ, PLY, polylines, GLB)
// with the page's 1-based names, and a .gltf opened with its .bin. The real server and
// Debian's Chromium.
//
//   node tests/web/usability_e2e.mjs
//
// Environment: as tests/web/e2e.mjs (SERVER, ARTIFACTS, CHROMIUM, WEB_ROOT); screenshots go
// beside ARTIFACTS: web-800x1000.png, web-hidden-keys.png.
import fs from 'node:fs';
import path from 'node:path';
import { createHarness, sharedMesh, sleep, until, Fatal } from './harness.mjs';

const h = createHarness({ totalTimeoutMs: 200_000, artifactName: 'web.png' });
const { check, ok } = h;

await h.prepare();
let FANDISK;
try {
  FANDISK = sharedMesh('fandisk.off');
} catch (e) {
  h.fail('the test mesh is there', e.message);
  await h.cleanup();
  h.finish(1);
}

const api = (page) => ({
  state: () =>
    page.evaluate(() => {
      const f = window.featureline;
      return {
        meshId: f.meshId,
        mesh: f.mesh,
        lines: f.lines.map((l) => ({ id: l.id, name: l.name, keys: l.keys, closed: l.closed, error: l.error, length: l.result?.refined?.length ?? null })),
        activeLineId: f.activeLineId,
        message: f.message,
        history: f.history,
        upAxis: f.upAxis,
        decomposeMessage: f.decomposeMessage,
        selectedKey: f.selectedKey,
      };
    }),
  idle: () => page.evaluate(() => window.featureline.idle()),
  screenOf: (v) => page.evaluate((vv) => window.featureline.screenPositionOfVertex(vv), v),
  stats: () => page.evaluate(() => window.featureline.sceneStats()),
  pick: (p) => page.evaluate(([x, y]) => window.featureline.pickVertexAt(x, y), [p.x, p.y]),
});

// Points spread evenly over the unit sphere (a Fibonacci lattice).
function sphereDirections(n) {
  const golden = Math.PI * (3 - Math.sqrt(5));
  return Array.from({ length: n }, (_, i) => {
    const y = 1 - (2 * (i + 0.5)) / n;
    const r = Math.sqrt(1 - y * y);
    return [r * Math.cos(golden * i), y, r * Math.sin(golden * i)];
  });
}

// Whether the element's box lies inside the window and it is drawn.
const inWindow = (page, selector) =>
  page.evaluate((sel) => {
    const el = document.querySelector(sel);
    const r = el.getBoundingClientRect();
    return { shown: el.checkVisibility() && r.height > 0 && r.top >= 0 && r.bottom <= innerHeight && r.left >= 0 && r.right <= innerWidth, top: r.top, bottom: r.bottom };
  }, selector);

const normalised = (v) => {
  const n = Math.hypot(...v);
  return v.map((x) => x / n);
};
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

await h.run(async () => {
  const base = await h.startServer();
  ok('the server starts on 127.0.0.1');

  // ---- a tall narrow window: the panel is a drawer, the sample is framed whole ---------------
  const page = await h.launch({ width: 800, height: 1000 });
  const a = api(page);
  await page.goto(`${base}/?trace=0`);
  await until('the app to start', () => page.evaluate(() => !!window.featureline && window.featureline.samples.length > 0));

  // "+ Line" before any mesh: a message, no undo step.
  await page.click('#panel-toggle');
  await page.click('#toolbar-add-line');
  let s = await a.state();
  check(s.history.depth === 0 && !s.history.canUndo && (await page.isDisabled('#undo')) && /Open a mesh first/.test(s.message),
    `"+ Line" with no mesh open leaves no undo step and says why ("${s.message}")`, () => JSON.stringify(s.history));

  let canvas = await page.locator('#canvas-host canvas').boundingBox();
  check(await page.isVisible('#toolbar-decompose'), 'at 800x1000 the ☰ button opens the panel as a drawer');
  await page.selectOption('#sample-select', 'samples/ridge_field.off');
  await page.click('#sample-open');
  await until('the sample to open', async () => (await a.state()).mesh?.faceCount === 3200);
  await a.idle();
  await page.click('#panel-close');
  check(!(await page.isVisible('#panel')) && (await page.getAttribute('#panel-toggle', 'aria-expanded')) === 'false', 'the drawer closes again');
  canvas = await page.locator('#canvas-host canvas').boundingBox();
  check(canvas.width === 800 && canvas.height === 1000, `with the drawer closed the view gets the whole window (${canvas.width}x${canvas.height})`);
  const sphere = await page.evaluate(() => window.featureline.boundingSphere());
  const onSphere = sphereDirections(600).map((d) => d.map((x, k) => sphere.center[k] + sphere.radius * x));
  const projected = await page.evaluate((points) => window.featureline.toClient(points), onSphere);
  const xs = projected.map((p) => p.x);
  const ys = projected.map((p) => p.y);
  const box = { left: Math.min(...xs), right: Math.max(...xs), top: Math.min(...ys), bottom: Math.max(...ys) };
  check(box.left >= canvas.x && box.right <= canvas.x + canvas.width && box.top >= canvas.y && box.bottom <= canvas.y + canvas.height,
    `at 800x1000 the whole bounding sphere projects inside the canvas (x ${box.left.toFixed(0)}..${box.right.toFixed(0)} of 0..800, y ${box.top.toFixed(0)}..${box.bottom.toFixed(0)} of 0..1000)`);
  check(box.right - box.left > 0.8 * canvas.width, `... and fills most of its width (${(box.right - box.left).toFixed(0)} px)`);
  await page.screenshot({ path: h.artifact('web-800x1000.png') });
  await page.keyboard.press('p');
  check(await page.isVisible('#panel'), 'P opens the drawer');
  await page.keyboard.press('Escape');
  check(!(await page.isVisible('#panel')), 'Esc closes it');

  // ---- 1280x800: keys behind a CAD part are faint and cannot be picked ----------------------------
  await page.setViewportSize({ width: 1280, height: 800 });
  await sleep(200);
  await page.setInputFiles('#file-input', FANDISK);
  await until('fandisk to open', async () => (await a.state()).mesh?.name === 'fandisk.off', 30000);
  await a.idle();
  s = await a.state();
  check((await a.stats()).flatShading, 'fandisk opens as a CAD part');
  await page.keyboard.press('s'); // snapping off: a key lands on the vertex clicked
  canvas = await page.locator('#canvas-host canvas').boundingBox();
  const centre = { x: canvas.x + canvas.width / 2, y: canvas.y + canvas.height / 2 };
  const front = await a.pick(centre);
  if (!front) throw new Fatal('the centre of the view misses fandisk');
  await page.mouse.click(centre.x, centre.y);
  await a.idle();
  s = await a.state();
  const frontKey = s.lines[0].keys[0];
  check(frontKey === front.vertex, `a click on the front places a key on vertex ${front.vertex}`, () => JSON.stringify(s.lines[0]));
  // Orbit half a turn: OrbitControls turns 2π per canvas height of horizontal drag.
  const start = { x: canvas.x + 150, y: canvas.y + canvas.height - 150 };
  await page.mouse.move(start.x, start.y);
  await page.mouse.down();
  for (let i = 1; i <= 20; ++i) await page.mouse.move(start.x + (i * canvas.height) / 2 / 20, start.y);
  await page.mouse.up();
  await a.idle();
  s = await a.state();
  let st = await a.stats();
  const behind = await a.screenOf(frontKey);
  const under = await a.pick(behind);
  check(s.lines[0].keys.length === 1 && under && under.vertex !== frontKey,
    `after half a turn the key (vertex ${frontKey}) projects onto the surface in front of it (vertex ${under?.vertex} there)`, () => JSON.stringify({ keys: s.lines[0].keys, under }));
  const marker = st.keys.find((k) => k.vertex === frontKey);
  check(marker?.hidden === true && marker.opacity < 0.5, `the hidden key's marker is drawn faint (opacity ${marker?.opacity})`, () => JSON.stringify(st.keys));
  await page.mouse.move(behind.x, behind.y);
  await sleep(150);
  const readout = await page.textContent('#readout');
  check(!/key 1/.test(readout), `hovering where the hidden key projects reads the surface, not the key ("${readout}")`);
  // A press-and-drag there turns the view; the hidden key stays where it is.
  const cameraBefore = st.cameraPosition;
  await page.mouse.down();
  for (let i = 1; i <= 6; ++i) await page.mouse.move(behind.x + 5 * i, behind.y + 2 * i);
  await page.mouse.up();
  await a.idle();
  s = await a.state();
  st = await a.stats();
  check(JSON.stringify(s.lines[0].keys) === JSON.stringify([frontKey]) && st.cameraPosition.some((x, k) => Math.abs(x - cameraBefore[k]) > 1e-6),
    'a drag starting on the hidden key\'s marker turns the view and leaves the key alone', () => JSON.stringify({ keys: s.lines[0].keys, cameraBefore, after: st.cameraPosition }));
  const stillBehind = await a.screenOf(frontKey);
  const front2 = await a.pick(stillBehind);
  check(st.keys[0].hidden && front2 && front2.vertex !== frontKey, 'the key is still behind the surface after the small turn', () => JSON.stringify({ keys: st.keys, front2 }));
  await page.mouse.click(stillBehind.x, stillBehind.y);
  await a.idle();
  s = await a.state();
  check(s.lines[0].keys.length === 2 && s.lines[0].keys[0] === frontKey && s.lines[0].keys[1] === front2.vertex,
    `a click there places a key on the front surface (vertex ${front2.vertex}) and leaves the hidden key alone`, () => JSON.stringify(s.lines[0].keys));
  const clear = { x: stillBehind.x + 30, y: stillBehind.y + 30 };
  if ((await a.pick(clear)) === null) throw new Fatal('no surface 30 px beside the hidden key');
  await page.mouse.click(clear.x, clear.y); // a third key, away from both markers
  await a.idle();
  st = await a.stats();
  const seen = st.keys.find((k) => k.keyIndex === 1);
  const pSeen = await a.screenOf(seen.vertex);
  await page.mouse.move(pSeen.x, pSeen.y);
  await sleep(150);
  check(!seen.hidden && /key 2/.test(await page.textContent('#readout')), 'a key in front can still be grabbed (the read-out names it)');
  await page.mouse.move(5, 5);
  await page.screenshot({ path: h.artifact('web-hidden-keys.png') });

  // ---- the status line stays in view wherever the panel is scrolled ----------------------------
  check((await page.getAttribute('#message', 'role')) === 'status' && (await page.getAttribute('#message', 'aria-live')) === 'polite' &&
    !(await page.evaluate(() => document.getElementById('panel').contains(document.getElementById('message')))),
    'messages go to a status line (role=status, aria-live=polite) outside the scrolling panel');
  await page.evaluate(() => (document.getElementById('panel').scrollTop = 0));
  await page.click('#toolbar-decompose');
  await until('the decomposition to answer', async () => (await a.state()).decomposeMessage, 20000);
  s = await a.state();
  const statusText = await page.textContent('#message');
  const where = await inWindow(page, '#message');
  const decomposeSeen = await inWindow(page, '#decompose-status');
  check(statusText.includes(s.decomposeMessage.split('\n')[0].replace(/^Decomposition failed: /, '')) && where.shown,
    `with the panel at its top the Decompose result shows in the status line ("${statusText.split('\n')[0]}"; the panel's own copy ${decomposeSeen.shown ? 'is' : 'is not'} in view)`,
    () => JSON.stringify({ statusText, decompose: s.decomposeMessage, where }));
  await page.evaluate(() => (document.getElementById('panel').scrollTop = 1e6));
  await page.mouse.click(canvas.x + canvas.width - 15, canvas.y + 15);
  s = await a.state();
  const scrolled = await inWindow(page, '#message');
  check(/missed the mesh/.test(await page.textContent('#message')) && scrolled.shown, 'with the panel scrolled to its end a message shows in the status line');
  await page.evaluate(() => (document.getElementById('panel').scrollTop = 0));

  // ---- Delete and C say what they did ----------------------------------------------------------------
  s = await a.state();
  const lastKey = s.lines[0].keys[2];
  check(s.selectedKey?.keyIndex === 2, 'the key placed last is selected');
  await page.keyboard.press('Delete');
  s = await a.state();
  check(new RegExp(`^Deleted key 3 of Line 1 \\(vertex ${lastKey}\\)\\. Undo brings it back`).test(s.message), `Delete says which key it removed ("${s.message}")`);
  await page.keyboard.press('c');
  s = await a.state();
  check(s.lines[0].closed && /^Closed Line 1 into a loop.*at least 3 keys; it has 2/.test(s.message), `C says it closed the loop ("${s.message}")`);
  await page.keyboard.press('c');
  s = await a.state();
  check(!s.lines[0].closed && /^Opened Line 1's loop/.test(s.message), `C again says it opened it ("${s.message}")`);

  // ---- a key by its vertex id: validated -------------------------------------------------------------
  const depth = s.history.depth;
  const n = s.mesh.vertexCount;
  await page.fill('#key-vertex', String(n));
  await page.press('#key-vertex', 'Enter');
  const rangeError = await page.textContent('#key-vertex-error');
  s = await a.state();
  check((await page.isVisible('#key-vertex-error')) && rangeError === `Vertex ${n} is out of range: this mesh has vertices 0 to ${n - 1}.` && s.history.depth === depth && s.lines[0].keys.length === 2,
    `an out-of-range vertex id is refused with a message ("${rangeError}")`);
  await page.fill('#key-vertex', '-3');
  await page.click('#key-vertex-add');
  check(/is not a vertex id/.test(await page.textContent('#key-vertex-error')), 'a negative id is refused too');
  const typed = (lastKey + 1) % n;
  await page.fill('#key-vertex', String(typed));
  check(await page.isHidden('#key-vertex-error'), 'typing again clears the error');
  await page.press('#key-vertex', 'Enter');
  await a.idle();
  s = await a.state();
  check(s.lines[0].keys.length === 3 && s.lines[0].keys[2] === typed && s.history.depth === depth + 1 && /Key 3 of Line 1: vertex/.test(s.message),
    `a typed vertex id ${typed} becomes key 3, one undo step`, () => JSON.stringify({ keys: s.lines[0].keys, depth: s.history.depth, message: s.message }));

  // ---- renaming a line: undoable, and saved --------------------------------------------------------
  await page.click('#line-list li:first-child button.rename-line');
  await page.fill('#line-list input.rename', 'rim edge');
  await page.press('#line-list input.rename', 'Enter');
  s = await a.state();
  check(s.lines[0].name === 'rim edge' && /rim edge/.test(await page.textContent('#line-list li:first-child .name')), 'a line can be renamed in the list');
  await page.keyboard.press('Control+z');
  s = await a.state();
  check(s.lines[0].name === 'Line 1', 'Ctrl+Z takes the new name back');
  await page.keyboard.press('Control+Shift+Z');
  await page.keyboard.press('n');
  await page.fill('#key-vertex', '10');
  await page.press('#key-vertex', 'Enter');
  await page.fill('#key-vertex', '200');
  await page.press('#key-vertex', 'Enter');
  s = await a.state();
  await a.idle();
  s = await a.state();
  check(s.lines.length === 2 && s.lines[0].name === 'rim edge' && s.lines.every((l) => l.length > 0), 'two named lines, both detected', () => JSON.stringify(s.lines));

  // ---- downloads: the server's files with the page's names --------------------------------------------
  const request = { lines: s.lines.map((l) => ({ keys: l.keys, closed: l.closed })) };
  const serverFile = async (format) =>
    (await fetch(`${base}/v1/meshes/${s.meshId}/feature-lines?format=${format}`, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(request) })).text();
  const downloaded = async (id) => {
    const [d] = await Promise.all([page.waitForEvent('download'), page.click(id)]);
    const file = path.join(h.tmp, d.suggestedFilename());
    await d.saveAs(file);
    return { name: d.suggestedFilename(), text: fs.readFileSync(file, 'latin1'), bytes: fs.readFileSync(file) };
  };
  const obj = await downloaded('#download-obj');
  const serverObj = await serverFile('obj');
  check(obj.name === 'fandisk-lines.obj' && obj.text === serverObj.replace('o line_0\n', 'o rim_edge\n').replace('o line_1\n', 'o Line_2\n'),
    `the OBJ download is the server's OBJ with the page's names (o rim_edge, o Line_2; ${obj.name})`, () => obj.text.split('\n').filter((l) => l.startsWith('o')).join(' '));
  const ply = await downloaded('#download-ply');
  const serverPly = (await serverFile('ply')).split('\n');
  const plyRows = ply.text.split('\n');
  const edgeRows = (rows) => {
    const end = rows.indexOf('end_header');
    const vertices = Number(rows.find((r) => r.startsWith('element vertex ')).split(' ')[2]);
    return rows.slice(end + 1 + vertices).filter((r) => r);
  };
  const shifted = edgeRows(serverPly).map((r) => r.split(' ').map((x, i) => (i === 2 ? Number(x) + 1 : x)).join(' '));
  check(ply.name === 'fandisk-lines.ply' && JSON.stringify(edgeRows(plyRows)) === JSON.stringify(shifted) && plyRows.includes('comment line 1: rim edge') && plyRows.includes('comment line 2: Line 2'),
    `the PLY download counts its edges' lines from 1 and names them (${shifted.length} edges)`);
  const polylines = await downloaded('#download-polylines');
  check(polylines.name === 'fandisk-lines.polylines.txt' && polylines.text === (await serverFile('polylines')) && polylines.text.trim().split('\n').length === 2,
    'the polylines download is the server\'s, one text line per line');
  const csv = await downloaded('#download-csv');
  const serverCsv = await serverFile('csv');
  check(csv.name === 'fandisk-lines.csv' && csv.text === serverCsv.replace(/^0,/gm, '"rim edge",').replace(/^1,/gm, '"Line 2",'),
    `the CSV download is the server's with the page's names in its line column (${csv.text.split('\n').length - 2} points)`);
  const glb = await downloaded('#download-glb');
  const jsonLength = glb.bytes.readUInt32LE(12);
  const gltf = JSON.parse(glb.bytes.subarray(20, 20 + jsonLength).toString('utf8'));
  check(glb.bytes.readUInt32LE(8) === glb.bytes.length && JSON.stringify(gltf.nodes.map((x) => x.name)) === '["rim edge","Line 2"]',
    `the GLB download names its nodes as the page does (${gltf.nodes.map((x) => x.name)})`);
  check(/Downloaded 2 line\(s\) as GLB, named as here/.test((await a.state()).message), 'the download says what it saved');

  // ---- camera presets and the orthographic view, saved with the session ----------------------------
  const up = s.upAxis === 'z' ? [0, 0, 1] : [0, 1, 0];
  const frontDir = s.upAxis === 'z' ? [0, -1, 0] : [0, 0, 1];
  const viewDir = async () => {
    const v = await page.evaluate(() => window.featureline.view);
    return normalised(v.position.map((x, k) => x - v.target[k]));
  };
  await page.click('#view-top');
  const topDir = await viewDir();
  await page.click('#view-side');
  const sideDir = await viewDir();
  await page.keyboard.press('1');
  const frontSeen = await viewDir();
  check(dot(topDir, up) > 0.999 && dot(sideDir, [1, 0, 0]) > 0.999 && dot(frontSeen, frontDir) > 0.999,
    `Top, Side and 1 (front) look along the up axis, +x and the front (${[topDir, sideDir, frontSeen].map((d) => d.map((x) => x.toFixed(2)).join(',')).join(' / ')})`);
  await page.check('#ortho-toggle');
  st = await a.stats();
  check(st.orthographic && /Orthographic/.test((await a.state()).message), 'the Orthographic box switches the projection');
  const keyOnScreen = await a.screenOf(s.lines[0].keys[2]);
  const pickedOrtho = await a.pick(keyOnScreen);
  check(pickedOrtho?.vertex === s.lines[0].keys[2] || (await page.evaluate(() => window.featureline.sceneStats().keys)).find((k) => k.vertex === s.lines[0].keys[2])?.hidden,
    'picking follows the orthographic projection (a visible key\'s vertex is under its marker)');
  const savedView = await page.evaluate(() => window.featureline.view);
  const [sessionDownload] = await Promise.all([page.waitForEvent('download'), page.click('#save-session')]);
  const sessionPath = path.join(h.tmp, 'session.json');
  await sessionDownload.saveAs(sessionPath);
  const session = JSON.parse(fs.readFileSync(sessionPath, 'utf8'));
  check(session.view?.orthographic === true && JSON.stringify(session.view.position) === JSON.stringify(savedView.position) && session.lines[0].name === 'rim edge',
    'the session saves the view (orthographic, camera, orbit centre) and the line names', () => JSON.stringify(session.view));
  const page2 = await h.context.newPage();
  h.watch(page2);
  await page2.setViewportSize({ width: 1280, height: 800 });
  await page2.goto(`${base}/?trace=0`);
  await until('the second page to start', () => page2.evaluate(() => !!window.featureline && window.featureline.samples.length > 0));
  await page2.setInputFiles('#session-input', sessionPath);
  await until('the session to load', async () => (await api(page2).state()).lines.length === 2, 20000);
  const view2 = await page2.evaluate(() => window.featureline.view);
  const close = (p, q) => p.every((x, k) => Math.abs(x - q[k]) < 1e-9);
  check(view2.orthographic && close(view2.position, savedView.position) && close(view2.target, savedView.target) && (await page2.isChecked('#ortho-toggle')),
    'loading the session in a fresh page restores the orthographic view');
  check((await api(page2).state()).lines[0].name === 'rim edge', 'and the line names');
  await page2.close();

  // ---- a .gltf chosen with its .bin opens (the server packs the two into one GLB) --------------
  {
    const boxGlb = fs.readFileSync(sharedMesh('Box.glb'));
    const jsonLength = boxGlb.readUInt32LE(12);
    const doc = JSON.parse(boxGlb.subarray(20, 20 + jsonLength).toString('utf8'));
    const binLength = boxGlb.readUInt32LE(20 + jsonLength);
    doc.buffers[0].uri = 'Box%200.bin';
    const gltfPath = path.join(h.tmp, 'Box.gltf');
    const binPath = path.join(h.tmp, 'Box 0.bin');
    fs.writeFileSync(gltfPath, JSON.stringify(doc));
    fs.writeFileSync(binPath, boxGlb.subarray(28 + jsonLength, 28 + jsonLength + binLength));
    const page3 = await h.context.newPage();
    h.watch(page3);
    await page3.goto(`${base}/?trace=0`);
    await until('the third page to start', () => page3.evaluate(() => !!window.featureline && window.featureline.samples.length > 0));
    await page3.setInputFiles('#file-input', [binPath, gltfPath]);
    await until('the .gltf with its .bin to open', async () => (await api(page3).state()).mesh?.faceCount === 12, 20000);
    const opened = await api(page3).state();
    check(opened.mesh.name === 'Box.gltf' && opened.mesh.vertexCount === 8 && /Opened Box\.gltf/.test(opened.message),
      `a .gltf chosen with its .bin opens as one mesh (${opened.mesh.vertexCount} vertices, "${opened.message}")`);
    await page3.setInputFiles('#file-input', [gltfPath]);
    await until('the lone .gltf to be refused', async () => /upload the \.gltf together with the files it names/.test((await api(page3).state()).message), 20000);
    ok('the .gltf alone is refused, saying to send it with the files it names');
    await page3.close();
  }

  check(h.pageErrors.length === 0, 'no uncaught errors in the pages', h.pageErrors.join('\n'));
  const unexpected = h.consoleErrors.filter((t) => !/Failed to load resource/.test(t));
  check(unexpected.length === 0, 'no errors logged in the console', unexpected.join('\n'));
});
