#!/usr/bin/env node
// The page's store, actions and request effects without a browser: a fake API answers when the
// test says so, so opening a mesh, editing keys, the one-request-in-flight line updates (and
// answers that arrive for keys changed since), undo/redo with cached answers, a failed line,
// a forgotten mesh, a decomposition and a traced line are checked against the state they leave.
//   node --test tests/web/store_test.mjs
import assert from 'node:assert/strict';
import test from 'node:test';
import { ApiError } from '../../web/src/api.js';
import { createActions } from '../../web/src/actions.js';
import { createLineRequests } from '../../web/src/line_requests.js';
import { createMeshEffects, outlineCreases } from '../../web/src/mesh_effects.js';
import { activeLine, colorMode, createPageStore, isStale, segmentationStale } from '../../web/src/model.js';
import { createSegmentation } from '../../web/src/segmentation.js';
import { createTracing } from '../../web/src/trace.js';

// Lets queued microtasks and timers of zero delay run (the store tells its subscribers in a microtask).
const settle = async () => {
  for (let i = 0; i < 5; ++i) await new Promise((r) => setImmediate(r));
};

// A unit square of two triangles folded along the diagonal 1-2: vertices 0..3, the diagonal a crease.
const SQUARE = {
  positions: new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.2]),
  index: Uint32Array.from([0, 1, 2, 1, 3, 2]),
  vertexCount: 4,
  faceCount: 2,
  curvature: new Float32Array([0, 1, 1, 0]),
  creaseEdges: Uint32Array.from([1, 2]),
  creaseAngle: 30,
};
const DESCRIPTION = { mesh_id: 'm1', format: 'off', vertices: 4, faces: 2 };

function lineAnswer(body, tag = '') {
  const keys = body.keys;
  return {
    keys,
    closed: !!body.closed,
    tag,
    initial: { method: 'feature-path', vertices: keys, points: keys.map((k) => [k, 0, 0]), length: keys.length },
    refined: { points: keys.map((k) => [k, 0.5, 0]), length: keys.length, faces: [0, 1], barycentric: [[1, 0, 0], [0, 1, 0]] },
    stats: { timings_ms: {}, warnings: [] },
  };
}

// A fake of api.js: each call is recorded and answered when the test resolves or rejects it.
function fakeApi() {
  const calls = [];
  const call = (name) => (...args) =>
    new Promise((resolve, reject) => calls.push({ name, args, resolve, reject }));
  return {
    calls,
    pending: (name) => calls.filter((c) => c.name === name && !c.done),
    answer(name, value) {
      const c = calls.find((x) => x.name === name && !x.done);
      assert.ok(c, `a pending ${name} call`);
      c.done = true;
      c.resolve(typeof value === 'function' ? value(...c.args) : value);
      return c;
    },
    fail(name, error) {
      const c = calls.find((x) => x.name === name && !x.done);
      c.done = true;
      c.reject(error);
      return c;
    },
    uploadMesh: call('uploadMesh'),
    meshGlb: call('meshGlb'),
    curvature: call('curvature'),
    describeMesh: call('describeMesh'),
    detectFeatureLines: call('detectFeatureLines'),
    segmentation: call('segmentation'),
    segmentationGlb: call('segmentationGlb'),
    sampleList: async () => [],
    sampleBytes: async () => new ArrayBuffer(0),
  };
}

// A page without a browser: the store, its actions, the line requests and the mesh effects.
function page() {
  const store = createPageStore();
  const api = fakeApi();
  const actions = createActions(store);
  const gone = [];
  const lines = createLineRequests(store, api, { onMeshGone: async (reason) => gone.push(reason) });
  const mesh = createMeshEffects(store, api, { readMesh: async () => SQUARE, lineRequests: lines, now: () => 0 });
  return { store, state: store.state, api, actions, lines, mesh, gone };
}

async function openedPage() {
  const p = page();
  const opening = p.mesh.openMesh('square.off', new ArrayBuffer(8), 'off');
  await settle();
  p.api.answer('uploadMesh', DESCRIPTION);
  await settle();
  p.api.answer('meshGlb', { bytes: new ArrayBuffer(64), wireBytes: 40, encoding: 'gzip' });
  assert.equal(await opening, true);
  await settle();
  return p;
}

test('open mesh: the state holds the mesh, its tables, the server creases and one empty line', async () => {
  const { state, store, api } = await openedPage();
  assert.deepEqual(api.calls.map((c) => c.name), ['uploadMesh', 'meshGlb']); // the curvature came in the GLB
  assert.equal(state.mesh.id, 'm1');
  assert.equal(state.mesh.vertexCount, 4);
  assert.equal(state.loading, false);
  assert.equal(state.progress, null);
  assert.deepEqual(state.lines.map((l) => [l.id, l.name, l.keys.length]), [[1, 'Line 1', 0]]);
  assert.equal(state.activeLineId, 1);
  // The outline is the server's crease (1-2) and the four boundary edges, nothing guessed.
  assert.equal(state.sharp.creaseCount, 1);
  assert.deepEqual([...state.sharp.edges.slice(0, 2)], [1, 2]);
  assert.equal(state.sharp.edges.length / 2, 5);
  assert.deepEqual([...state.sharp.onBoundary], [1, 1, 1, 1]);
  assert.equal(state.upAxis, 'z'); // flat along z
  assert.match(state.message, /^Opened square\.off/);
  assert.equal(store.history.canUndo, false);
  assert.equal(state.download.wireBytes, 40);
});

test('the outline is the server\'s creases; the page guesses only where the server marks none at any angle', () => {
  // Folded 90 degrees along 1-2: a server at 40 degrees sends that edge, one at 100 none.
  const folded = { ...SQUARE, positions: new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0, 0.5, 0.5, 0.7071]) };
  assert.deepEqual([...outlineCreases({ ...folded, creaseAngle: 40 })], [1, 2]);
  assert.deepEqual([...outlineCreases({ ...folded, creaseAngle: 100, creaseEdges: new Uint32Array(0) })], []);
  // 360 degrees: nothing can be a crease on the server (creases were most of the edges).
  assert.deepEqual([...outlineCreases({ ...folded, creaseAngle: 360, creaseEdges: new Uint32Array(0) })], [1, 2]);
  assert.deepEqual([...outlineCreases({ ...folded, creaseAngle: null, creaseEdges: new Uint32Array(0) })], [1, 2]);
});

test('opening over placed keys asks first, and keeps the work when the answer is no', async () => {
  const p = await openedPage();
  p.actions.addKey(0);
  const asked = [];
  const mesh = createMeshEffects(p.store, p.api, { readMesh: async () => SQUARE, confirm: async (text) => (asked.push(text), false) });
  assert.equal(await mesh.openMesh('other.off', new ArrayBuffer(8), 'off'), false);
  assert.equal(asked.length, 1);
  assert.deepEqual(p.state.lines[0].keys, [0]);
  assert.match(p.state.message, /^Kept square\.off/);
});

test('keys: add, move (a drag is one undo step), delete; each line request sends the latest keys', async () => {
  const { state, store, api, actions } = await openedPage();
  assert.equal(actions.addKey(0), true);
  assert.equal(actions.addKey(0), false); // the same vertex again is no edit
  actions.addKey(3);
  assert.deepEqual(state.lines[0].keys, [0, 3]);
  assert.deepEqual(state.selectedKey, { lineId: 1, keyIndex: 1 });
  assert.equal(store.history.undoStack.length, 2);
  await settle();
  assert.equal(api.pending('detectFeatureLines').length, 1);
  assert.deepEqual(api.pending('detectFeatureLines')[0].args, ['m1', { keys: [0, 3], closed: false }]);
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body));
  await settle();
  const line = state.lines[0];
  assert.deepEqual(line.result.keys, [0, 3]);
  assert.equal(isStale(line, state.options), false);
  assert.equal(state.requestCount, 1);
  assert.equal(state.responseCount, 1);

  // A drag: unrecorded moves, then one recorded step.
  const before = store.snapshot();
  actions.moveKeyUnrecorded(line, 1, 2);
  actions.moveKeyUnrecorded(line, 1, 1);
  assert.equal(actions.moveKeyUnrecorded(line, 1, 0), false); // next to key 1 on vertex 0: refused
  store.record(before, 'move key 2 of Line 1');
  assert.deepEqual(line.keys, [0, 1]);
  assert.equal(store.history.undoLabel, 'move key 2 of Line 1');
  assert.equal(isStale(line, state.options), true);

  actions.deleteKey(line, 0);
  assert.deepEqual(state.lines[0].keys, [1]);
  assert.match(state.message, /^Deleted key 1 of Line 1 \(vertex 0\)/);
  await settle();
  // One key is not a line: no request for it, and no result to be out of date against.
  assert.equal(state.lines[0].result, null);
  assert.equal(api.pending('detectFeatureLines').length, 0);
});

test('an answer for keys changed meanwhile stays drawn as out of date; the latest keys go next', async () => {
  const { state, api, actions, lines } = await openedPage();
  actions.addKey(0);
  actions.addKey(3);
  await settle();
  actions.addKey(1); // while [0, 3] is being detected
  await settle();
  assert.equal(api.pending('detectFeatureLines').length, 1, 'one request in flight');
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body, 'first'));
  await settle();
  const line = state.lines[0];
  assert.equal(line.result.tag, 'first');
  assert.equal(isStale(line, state.options), true);
  assert.deepEqual(api.pending('detectFeatureLines')[0].args[1].keys, [0, 3, 1]);
  let idle = false;
  lines.idle().then(() => (idle = true));
  await settle();
  assert.equal(idle, false);
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body, 'second'));
  await settle();
  assert.equal(line.result.tag, 'second');
  assert.equal(isStale(line, state.options), false);
  assert.equal(idle, true);
});

test('undo and redo restore keys and take cached answers without asking the server again', async () => {
  const { state, store, api, actions } = await openedPage();
  actions.addKey(0);
  actions.addKey(3);
  await settle();
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body, 'two'));
  await settle();
  actions.addKey(1);
  await settle();
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body, 'three'));
  await settle();
  const sent = api.calls.length;
  actions.undo();
  assert.match(state.message, /^Undid: add key\./);
  assert.deepEqual(state.lines[0].keys, [0, 3]);
  await settle();
  assert.equal(state.lines[0].result.tag, 'two');
  assert.equal(api.calls.length, sent, 'the answer came from the cache');
  actions.redo();
  assert.match(state.message, /^Redid: add key\./);
  await settle();
  assert.equal(state.lines[0].result.tag, 'three');
  assert.equal(api.calls.length, sent);
  for (let i = 0; i < 4; ++i) actions.undo();
  assert.equal(state.message, 'Nothing to undo.');
  assert.deepEqual(state.lines[0].keys, []);
  assert.equal(store.history.canRedo, true);
  // Lines and options are undone too.
  actions.addLine();
  assert.equal(state.lines.length, 2);
  actions.undo();
  assert.equal(state.lines.length, 1);
  actions.setOptions({ snake: { max_iterations: 5 } });
  assert.equal(store.history.undoLabel, 'change options');
  actions.undo();
  assert.deepEqual(state.options, {});
});

test('a failed line keeps its last answer, counts from 1, and is not sent again until it changes', async () => {
  const { state, api, actions } = await openedPage();
  actions.addKey(0);
  actions.addKey(3);
  await settle();
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body));
  await settle();
  actions.addKey(1);
  await settle();
  api.fail('detectFeatureLines', new ApiError(422, 'no_line', 'keys 1 and 2 are not connected'));
  await settle();
  const line = state.lines[0];
  assert.equal(line.error, 'keys 2 and 3 are not connected (HTTP 422 no_line)');
  assert.deepEqual(line.result.keys, [0, 3]);
  assert.equal(api.pending('detectFeatureLines').length, 0);
  actions.setClosed(true);
  await settle();
  assert.equal(api.pending('detectFeatureLines').length, 1);
});

test('a forgotten mesh (404) is handed to recovery; answers for another mesh are dropped', async () => {
  const p = await openedPage();
  const { state, api, actions, gone } = p;
  actions.addKey(0);
  actions.addKey(3);
  await settle();
  api.fail('detectFeatureLines', new ApiError(404, 'not_found', 'mesh m1 expired'));
  await settle();
  assert.deepEqual(gone, ['mesh m1 expired']);
  assert.equal(state.lines[0].error, '');

  // A request of m1 still running when another mesh opens: its answer changes nothing.
  actions.setClosed(true);
  actions.addKey(1);
  await settle();
  assert.equal(api.pending('detectFeatureLines').length, 1);
  const opening = p.mesh.openMesh('other.off', new ArrayBuffer(8), 'off');
  await settle();
  api.answer('uploadMesh', { ...DESCRIPTION, mesh_id: 'm2' });
  await settle();
  api.answer('meshGlb', { bytes: new ArrayBuffer(64), wireBytes: 40, encoding: 'identity' });
  assert.equal(await opening, true);
  assert.equal(state.mesh.id, 'm2');
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body, 'old mesh'));
  await settle();
  assert.deepEqual(state.lines.map((l) => [l.keys, l.result]), [[[], null]]);
  assert.equal(state.lastResult, null);
  assert.equal(state.inFlight, null);
});

test('segmentation request: current lines go as computed lines, the answer is kept and goes out of date', async () => {
  const p = await openedPage();
  const { state, api, actions, store } = p;
  const segmentation = createSegmentation(store, api);
  await segmentation.decompose('snap');
  assert.match(state.decomposeStatus, /at least two keys/);
  assert.equal(state.decomposeMessage, ''); // no decomposition: no result
  actions.addKey(0);
  actions.addKey(3);
  actions.addLine();
  actions.addKey(1);
  actions.addKey(2);
  await settle();
  api.answer('detectFeatureLines', (id, body) => lineAnswer(body));
  await settle();
  // The active line went first: its answer is in and it goes as computed; the first line's is
  // not, so it goes as a request (the server detects it).
  const running = segmentation.decompose('snap');
  await settle();
  assert.equal(state.decomposing, true);
  assert.equal(state.decomposeStatus, 'Decomposing…');
  assert.equal(state.decomposeMessage, ''); // the result is not in yet
  const [meshId, request] = api.pending('segmentation')[0].args;
  assert.equal(meshId, 'm1');
  assert.equal(request.mode, 'snap');
  assert.deepEqual(request.lines[0], { keys: [0, 3], closed: false });
  assert.deepEqual(request.lines[1], { keys: [1, 2], closed: false, refined: { faces: [0, 1], barycentric: [[1, 0, 0], [0, 1, 0]] } });
  api.answer('segmentation', { labels: [0, 1], segments: [{ label: 0, faces: 1, area: 0.5, color: [1, 0, 0] }, { label: 1, faces: 1, area: 0.5, color: [0, 0, 1] }], warnings: ['segment 0 is small'] });
  await running;
  assert.equal(state.decomposing, false);
  assert.equal(state.segmentation.faceColored, true);
  assert.equal(colorMode(state), 'segments');
  assert.equal(state.decomposeMessage, '2 segment(s)\nwarning: segment 1 is small');
  assert.equal(segmentationStale(state), false);
  actions.addKey(0);
  assert.equal(segmentationStale(state), true);
});

test('the active line and the store tell subscribers once per task', async () => {
  const { store, actions, state } = await openedPage();
  let calls = 0;
  store.subscribe(() => calls++);
  actions.addKey(0);
  actions.addKey(1);
  actions.addKey(2);
  assert.equal(calls, 0);
  await settle();
  assert.ok(calls >= 1 && calls <= 3, `${calls} notifications`);
  assert.equal(activeLine(state).keys.length, 3);
});

test('trace mode: a click traces a line into the empty active line; nothing to trace edits nothing', async () => {
  const { state, store, api } = await openedPage();
  const tracing = createTracing(store, api, { now: () => 0 });
  const clicked = tracing.traceClick(2);
  await settle();
  const [, body] = api.pending('detectFeatureLines')[0].args;
  assert.deepEqual(body, { keys: [2], trace: true, options: { refine: false } }); // the preview's request
  api.answer('detectFeatureLines', (id, b) => ({ ...lineAnswer({ keys: [2, 1, 0] }), closed: false, trace: { sign: 'ridge', ends: [{ reason: 'boundary', vertex: 2 }, { reason: 'boundary', vertex: 0 }] } }));
  await clicked;
  assert.deepEqual(state.lines.map((l) => [l.id, l.keys, l.trace]), [[1, [2], true]]);
  assert.equal(store.history.undoLabel, 'trace a line from vertex 2');
  assert.match(state.message, /^Line 1: the ridge through vertex 2, 2 edges, both ends at the boundary/);
  await settle();
  // The traced line's own request (refined), sent by the line requests.
  assert.deepEqual(api.pending('detectFeatureLines')[0].args[1], { keys: [2], trace: true });
  api.answer('detectFeatureLines', (id, b) => ({ ...lineAnswer({ keys: [2, 1, 0] }), trace: { sign: 'ridge', ends: [] } }));
  await settle();
  assert.equal(isStale(state.lines[0], state.options), false);
  const missed = tracing.traceClick(3);
  await settle();
  api.fail('detectFeatureLines', new ApiError(422, 'no_feature', 'vertex 3 is on no feature'));
  await missed;
  assert.equal(state.lines.length, 1);
  assert.match(state.message, /^Nothing to trace at vertex 3: vertex 3 is on no feature/);
  assert.equal(state.pendingTraces, 0);
});
