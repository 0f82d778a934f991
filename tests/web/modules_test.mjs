#!/usr/bin/env node
// The page's modules that need no browser, with known answers: 1-based numbering of server
// text, the undo history, session files, vertex rings, snapping, the outline (the server's
// creases and the boundary) and the CAD and
// up-axis guesses on real meshes from ../shared/data/meshes, grid picking against testing
// every triangle, typed vertex ids, and the page's line names put into the server's files.
//   node --test tests/web/modules_test.mjs
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import test from 'node:test';
import { fileURLToPath } from 'node:url';
import { dihedralCreases, guessUpAxis, looksLikeCad, ringNeighbourhood, sharpEdges, strongestFeatureVertex, vertexAdjacency } from '../../web/src/geometry.js';
import { History } from '../../web/src/history.js';
import { nameCsvLines, nameGlbLines, nameObjLines, namePlyLines, objName } from '../../web/src/line_files.js';
import { buildTriangleGrid, raycastAll, raycastGrid } from '../../web/src/raycast.js';
import { parseSession, sessionDocument } from '../../web/src/session.js';
import { oneBasedNumbers, vertexIdProblem } from '../../web/src/text.js';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
function sharedMesh(name) {
  const p = path.join(repo, '..', 'shared', 'data', 'meshes', name);
  assert.ok(fs.existsSync(p), `test mesh missing: ../shared/data/meshes/${name}`);
  return p;
}

// A minimal OFF reader (triangles and fan-triangulated polygons), enough for these meshes.
function readOff(file) {
  const tokens = fs.readFileSync(file, 'utf8').replace(/#.*$/gm, '').split(/\s+/).filter(Boolean);
  let i = tokens[0] === 'OFF' ? 1 : 0;
  const nv = Number(tokens[i++]);
  const nf = Number(tokens[i++]);
  i++;
  const positions = new Float32Array(nv * 3);
  for (let k = 0; k < nv * 3; ++k) positions[k] = Number(tokens[i++]);
  const index = [];
  for (let f = 0; f < nf; ++f) {
    const n = Number(tokens[i++]);
    const v = tokens.slice(i, i + n).map(Number);
    i += n;
    for (let k = 1; k + 1 < n; ++k) index.push(v[0], v[k], v[k + 1]);
  }
  return { positions, index: Uint32Array.from(index), vertexCount: nv };
}

function extent(positions) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3)
    for (let k = 0; k < 3; ++k) (min[k] = Math.min(min[k], positions[i + k])), (max[k] = Math.max(max[k], positions[i + k]));
  return max.map((m, k) => m - min[k]);
}

test('server text reads 1-based, vertex ids stay', () => {
  assert.equal(oneBasedNumbers('keys 0 and 1 are the same vertex 12'), 'keys 1 and 2 are the same vertex 12');
  assert.equal(oneBasedNumbers('marching search failed between keys 3 and 0: x'), 'marching search failed between keys 4 and 1: x');
  assert.equal(oneBasedNumbers('line 0 ends at vertex 701, on neither'), 'line 1 ends at vertex 701, on neither');
  assert.equal(oneBasedNumbers('lines[2].keys: must be'), 'line 3.keys: must be');
  assert.equal(oneBasedNumbers('segment 0 had to cross'), 'segment 1 had to cross');
  assert.equal(oneBasedNumbers('no edge path joins vertices 3 and 4'), 'no edge path joins vertices 3 and 4');
  assert.equal(oneBasedNumbers('and 1 more loose end(s)'), 'and 1 more loose end(s)');
});

test('history: undo, redo, a new edit forgets redo, discardLast', () => {
  const h = new History();
  h.record({ v: 1 }, 'a');
  h.record({ v: 2 }, 'b');
  assert.equal(h.undoLabel, 'b');
  assert.deepEqual(h.undo({ v: 3 }).snapshot, { v: 2 });
  assert.equal(h.redoLabel, 'b');
  assert.deepEqual(h.redo({ v: 2 }).snapshot, { v: 3 });
  h.undo({ v: 3 });
  h.record({ v: 2 }, 'c');
  assert.equal(h.canRedo, false);
  assert.equal(h.discardLast().label, 'c');
  assert.equal(h.undoLabel, 'a');
  assert.equal(new History().undo({}), null);
});

test('a session round-trips and a wrong one is refused with the reason', () => {
  const doc = sessionDocument({
    mesh: { name: 'm.off', id: 'abc', vertexCount: 10, faceCount: 16, description: { format: 'off' } },
    lines: [{ name: 'Line 1', keys: [1, 2, 3], closed: true }],
    options: { snake: { max_iterations: 5 } },
    upAxis: 'z',
  });
  const back = parseSession(JSON.stringify(doc));
  assert.deepEqual(back.lines, [{ name: 'Line 1', keys: [1, 2, 3], closed: true }]);
  assert.deepEqual(back.options, { snake: { max_iterations: 5 } });
  assert.equal(back.up_axis, 'z');
  assert.throws(() => parseSession('{'), /not JSON/);
  assert.throws(() => parseSession('{"format": "other"}'), /not a Featureline session/);
  const bad = { ...doc, lines: [{ keys: [1, 10] }] };
  assert.throws(() => parseSession(JSON.stringify(bad)), /line 1: keys must be vertex ids from 0 to 9/);
});

test('rings and snapping: the strongest feature within the accepted candidates', () => {
  // A strip of 4 triangles: vertices 0..5, 0-1-2-3-4-5 zig-zag.
  const index = Uint32Array.from([0, 1, 2, 1, 3, 2, 2, 3, 4, 3, 5, 4]);
  const adjacency = vertexAdjacency(index, 6);
  assert.deepEqual(new Set(ringNeighbourhood(adjacency, 0, 1)), new Set([0, 1, 2]));
  assert.deepEqual(new Set(ringNeighbourhood(adjacency, 0, 2)), new Set([0, 1, 2, 3, 4]));
  const field = Float32Array.from([0.1, -0.2, 0.15, 3, 0.5, 9]);
  const ring = ringNeighbourhood(adjacency, 0, 2);
  assert.equal(strongestFeatureVertex(0, ring, field), 3); // |-3| beats the rest; 5 is 3 rings away
  assert.equal(strongestFeatureVertex(0, ring, field, (v) => v !== 3), 4);
  assert.equal(strongestFeatureVertex(0, ring, field, () => true, 5), 0); // nothing is a feature: stay
  assert.equal(strongestFeatureVertex(0, ring, null), 0);
});

test('sharp edges: the server\'s creases and the boundary; flat pairs counted', () => {
  const square = new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0]);
  const flat = sharpEdges(square, Uint32Array.from([0, 1, 2, 1, 3, 2]));
  assert.equal(flat.creaseCount, 0);
  assert.equal(flat.flatShare, 1);
  assert.equal(flat.edges.length / 2, 4); // the four boundary edges
  assert.deepEqual([...flat.onBoundary], [1, 1, 1, 1]);
  // Vertex 3 lifted out of the plane: the faces meet at 90 degrees along 1-2, which the
  // server marks as a crease; the page draws what the server sends, not an angle of its own.
  const lifted = new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0, 0.5, 0.5, 0.7071]);
  const folded = sharpEdges(lifted, Uint32Array.from([0, 1, 2, 1, 3, 2]), Uint32Array.from([1, 2]));
  assert.equal(folded.creaseCount, 1);
  assert.deepEqual([...folded.edges.slice(0, 2)], [1, 2]);
  assert.equal(folded.edges.length / 2, 5);
  assert.equal(folded.flatShare, 0);
  assert.equal(sharpEdges(lifted, Uint32Array.from([0, 1, 2, 1, 3, 2])).creaseCount, 0); // none sent, none drawn
  // The page's own guess (only where the server marks none): past 30 degrees, not past 100.
  assert.deepEqual([...dihedralCreases(lifted, Uint32Array.from([0, 1, 2, 1, 3, 2]), 30)], [1, 2]);
  assert.deepEqual([...dihedralCreases(lifted, Uint32Array.from([0, 1, 2, 1, 3, 2]), 100)], []);
});

test('CAD and up axis on real meshes', () => {
  const fandisk = readOff(sharedMesh('fandisk.off'));
  const bunny = readOff(sharedMesh('bunny_closed.off'));
  const ridge = readOff(path.join(repo, 'samples', 'ridge_field.off'));
  const cad = (m) => looksLikeCad(sharpEdges(m.positions, m.index, dihedralCreases(m.positions, m.index, 30)), m.index.length / 3);
  assert.equal(cad(fandisk), true);
  assert.equal(cad(bunny), false);
  assert.equal(cad(ridge), false);
  assert.equal(guessUpAxis(extent(bunny.positions), 'off'), 'y'); // the Stanford scan is Y-up
  assert.equal(guessUpAxis(extent(ridge.positions), 'off'), 'z'); // a height field z = f(x, y)
  assert.equal(guessUpAxis(extent(readOff(sharedMesh('hemisphere.off')).positions), 'off'), 'z');
  assert.equal(guessUpAxis([1, 1, 1], 'stl'), 'z');
  assert.equal(guessUpAxis([1, 1, 1], 'glb'), 'y');
});

// A deterministic pseudo-random sequence (so a failure repeats).
function lcg(seed) {
  let x = seed >>> 0;
  return () => ((x = (Math.imul(x, 1664525) + 1013904223) >>> 0) / 2 ** 32);
}

test('grid picking hits the same triangle at the same distance as testing every triangle (bunny)', () => {
  const mesh = readOff(sharedMesh('bunny_closed.off'));
  const grid = buildTriangleGrid(mesh.positions, mesh.index);
  const random = lcg(12);
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < mesh.positions.length; i += 3)
    for (let k = 0; k < 3; ++k) (lo[k] = Math.min(lo[k], mesh.positions[i + k])), (hi[k] = Math.max(hi[k], mesh.positions[i + k]));
  const centre = lo.map((l, k) => (l + hi[k]) / 2);
  const radius = Math.hypot(...hi.map((h, k) => h - lo[k]));
  let hits = 0;
  for (let r = 0; r < 300; ++r) {
    // From a point on a sphere around the mesh toward a random point inside its box (some
    // rays miss: toward a box corner), and a few from inside the mesh.
    const inside = r % 10 === 0;
    const dir = [random() - 0.5, random() - 0.5, random() - 0.5];
    const len = Math.hypot(...dir);
    const o = inside ? centre.slice() : centre.map((c, k) => c + (radius * dir[k]) / len);
    const target = lo.map((l, k) => l + random() * (hi[k] - l));
    const d = inside ? dir.map((x) => x / len) : target.map((t, k) => t - o[k]);
    const a = raycastGrid(grid, o, d);
    const b = raycastAll(grid, o, d);
    assert.equal(a === null, b === null, `ray ${r}: hit and miss agree`);
    if (!a) continue;
    ++hits;
    assert.ok(Math.abs(a.t - b.t) <= 1e-9 * Math.max(1, b.t), `ray ${r}: distance ${a.t} vs ${b.t}`);
    if (a.face !== b.face) assert.ok(Math.abs(a.t - b.t) <= 1e-12, `ray ${r}: face ${a.face} vs ${b.face} at another distance`);
  }
  assert.ok(hits > 150, `enough rays hit to mean something (${hits} of 300)`);
});

test('grid picking on a flat square: the known triangle and point, a miss beside it', () => {
  // Two triangles over [0,1]^2 at z = 0 (the grid has one cell along z).
  const positions = new Float32Array([0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]);
  const index = new Uint32Array([0, 1, 2, 0, 2, 3]);
  const grid = buildTriangleGrid(positions, index);
  const below = raycastGrid(grid, [0.75, 0.25, 5], [0, 0, -1]);
  assert.equal(below.face, 0);
  assert.deepEqual(below.point.map((x) => Math.round(x * 1e9) / 1e9), [0.75, 0.25, 0]);
  assert.equal(raycastGrid(grid, [0.25, 0.75, -2], [0, 0, 1]).face, 1, 'seen from below too (double-sided)');
  assert.equal(raycastGrid(grid, [1.5, 0.5, 5], [0, 0, -1]), null);
  assert.equal(raycastGrid(grid, [0.5, 0.5, 5], [0, 0, 1]), null, 'pointing away');
});

test('typed vertex ids: whole numbers in range, not the last key again', () => {
  const line = { name: 'Line 1', keys: [4, 7] };
  assert.equal(vertexIdProblem('12', 100, line), '');
  assert.equal(vertexIdProblem(' 0 ', 100, line), '');
  assert.equal(vertexIdProblem('100', 100, line), 'vertex 100 is out of range: this mesh has vertices 0 to 99');
  assert.equal(vertexIdProblem('-1', 100, line), '"-1" is not a vertex id: type a whole number from 0 to 99');
  assert.equal(vertexIdProblem('2.5', 100, line), '"2.5" is not a vertex id: type a whole number from 0 to 99');
  assert.equal(vertexIdProblem('', 100, line), '"" is not a vertex id: type a whole number from 0 to 99');
  assert.equal(vertexIdProblem('7', 100, line), 'vertex 7 is already the last key of Line 1');
});

// The server's files as api/export_formats.cpp writes them for two lines (the second closed).
const SERVER_OBJ = '# Featureline: 2 feature lines\no line_0\nv 0 0 0\nv 1 0 0\nl 1 2\no line_1\nv 0 1 0\nv 1 1 0\nv 1 2 0\nl 3 4 5 3\n';
const SERVER_PLY = [
  'ply', 'format ascii 1.0', 'comment Featureline: 2 feature lines', 'element vertex 5',
  'property double x', 'property double y', 'property double z', 'element edge 4',
  'property int vertex1', 'property int vertex2', 'property int line', 'end_header',
  '0 0 0', '1 0 0', '0 1 0', '1 1 0', '1 2 0', '0 1 0', '2 3 1', '3 4 1', '4 2 1', '',
].join('\n');

test('OBJ and PLY line files get the page\'s names and 1-based line numbers, nothing else changes', () => {
  assert.equal(objName('rim edge '), 'rim_edge');
  assert.equal(objName('  '), 'line');
  assert.equal(nameObjLines(SERVER_OBJ, ['rim edge', 'Line 2']), SERVER_OBJ.replace('o line_0\n', 'o rim_edge\n').replace('o line_1\n', 'o Line_2\n'));
  const ply = namePlyLines(SERVER_PLY, ['rim edge', 'Line 2']).split('\n');
  assert.deepEqual(ply.slice(0, 7), ['ply', 'format ascii 1.0', 'comment Featureline: 2 feature lines',
    'comment the edges\' "line" counts from 1, as the page does:', 'comment line 1: rim edge', 'comment line 2: Line 2', 'element vertex 5']);
  assert.deepEqual(ply.slice(-10), ['0 0 0', '1 0 0', '0 1 0', '1 1 0', '1 2 0', '0 1 1', '2 3 2', '3 4 2', '4 2 2', '']);
});

// The CSV api/export_formats.cpp writes for the same two lines (points shortened to two each).
const SERVER_CSV = 'line,closed,point,x,y,z,face,b0,b1,b2\n0,false,0,0,0,0,3,1,0,0\n0,false,1,1,0,0,4,0,1,0\n1,true,0,0,1,0,5,0,0,1\n1,true,1,1,1,0,6,1,0,0\n';

test('CSV rows name their line as the page does (quoted), nothing else changes', () => {
  assert.equal(nameCsvLines(SERVER_CSV, ['rim "top" edge', 'Line 2']),
    'line,closed,point,x,y,z,face,b0,b1,b2\n"rim ""top"" edge",false,0,0,0,0,3,1,0,0\n"rim ""top"" edge",false,1,1,0,0,4,0,1,0\n' +
    '"Line 2",true,0,0,1,0,5,0,0,1\n"Line 2",true,1,1,1,0,6,1,0,0\n');
});

// A GLB of two line nodes and a binary chunk, as the server lays it out (JSON chunk padded
// with spaces to 4 bytes, then the BIN chunk).
function glbOf(json, bin) {
  const text = Buffer.from(JSON.stringify(json));
  const padded = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const header = Buffer.alloc(20);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + padded.length + 8 + bin.length, 8);
  header.writeUInt32LE(padded.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);
  const binHeader = Buffer.alloc(8);
  binHeader.writeUInt32LE(bin.length, 0);
  binHeader.writeUInt32LE(0x004e4942, 4);
  const all = Buffer.concat([header, padded, binHeader, bin]);
  return all.buffer.slice(all.byteOffset, all.byteOffset + all.length);
}

test('GLB line files: nodes and meshes renamed, the binary chunk byte for byte', () => {
  const json = { asset: { version: '2.0' }, nodes: [{ name: 'feature_line_0', mesh: 0 }, { name: 'feature_line_1', mesh: 1 }, { name: 'surface' }], meshes: [{ name: 'feature_line_0' }, { name: 'feature_line_1' }] };
  const bin = Buffer.from([1, 2, 3, 4, 5, 6, 7, 8]);
  const out = Buffer.from(nameGlbLines(glbOf(json, bin), ['rim édge', 'Line 2']));
  assert.equal(out.readUInt32LE(0), 0x46546c67);
  assert.equal(out.readUInt32LE(8), out.length);
  const jsonLength = out.readUInt32LE(12);
  assert.equal(jsonLength % 4, 0);
  const renamed = JSON.parse(out.subarray(20, 20 + jsonLength).toString('utf8'));
  assert.deepEqual(renamed.nodes.map((n) => n.name), ['rim édge', 'Line 2', 'surface']);
  assert.deepEqual(renamed.meshes.map((m) => m.name), ['rim édge', 'Line 2']);
  assert.deepEqual(out.subarray(20 + jsonLength), Buffer.concat([Buffer.from([8, 0, 0, 0, 0x42, 0x49, 0x4e, 0]), bin]));
});

test('a session keeps the view; a malformed view is refused', () => {
  const mesh = { name: 'm.off', id: 'x', vertexCount: 3, faceCount: 1 };
  const view = { position: [1, 2, 3], target: [0, 0, 0], orthographic: true, zoom: 2 };
  const doc = parseSession(JSON.stringify(sessionDocument({ mesh, lines: [], options: {}, upAxis: 'y', view })));
  assert.deepEqual(doc.view, view);
  const bad = (v) => JSON.stringify({ ...sessionDocument({ mesh, lines: [], options: {}, upAxis: 'y' }), view: v });
  assert.throws(() => parseSession(bad({ ...view, position: [1, 2] })), /"view" needs a "position" and a "target"/);
  assert.throws(() => parseSession(bad({ ...view, zoom: 0 })), /positive "zoom"/);
});
