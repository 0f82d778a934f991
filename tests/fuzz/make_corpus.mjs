// Writes the hand-made seeds and regression inputs of tests/fuzz/corpus/<format>/ (regression_*:
// reproducers of bugs the fuzzers found, fixed since). The files are kept in the repository; this script documents
// how they were made and remakes them (box.drc is cut out of ../shared/data/meshes/Box_Draco.glb):
//   node tests/fuzz/make_corpus.mjs
import { mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const corpus = join(dirname(fileURLToPath(import.meta.url)), 'corpus');
const write = (folder, name, bytes) => {
  mkdirSync(join(corpus, folder), { recursive: true });
  writeFileSync(join(corpus, folder, name), bytes);
};

// A GLB container around a JSON document and a BIN chunk (both padded to 4 bytes).
function glb(json, bin) {
  const pad = (buf, fill) => Buffer.concat([buf, Buffer.alloc((4 - (buf.length % 4)) % 4, fill)]);
  const jsonChunk = pad(Buffer.from(JSON.stringify(json)), 0x20);
  const binChunk = pad(bin, 0);
  const header = Buffer.alloc(12);
  const total = 12 + 8 + jsonChunk.length + 8 + binChunk.length;
  header.write('glTF', 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(total, 8);
  const chunkHeader = (length, type) => {
    const h = Buffer.alloc(8);
    h.writeUInt32LE(length, 0);
    h.writeUInt32LE(type, 4);
    return h;
  };
  return Buffer.concat([header, chunkHeader(jsonChunk.length, 0x4e4f534a), jsonChunk, chunkHeader(binChunk.length, 0x004e4942), binChunk]);
}

// Amplification: one 24x24 grid (576 vertices, 1058 triangles) listed as 100 primitives of one
// mesh that 300 nodes instance: about 32 million triangles from a file of about 22 KB.
function amplifiedGlb({ grid = 24, primitives = 100, nodes = 300, spread = false } = {}) {
  const positions = Buffer.alloc(grid * grid * 12);
  for (let j = 0; j < grid; ++j)
    for (let i = 0; i < grid; ++i) {
      const o = (j * grid + i) * 12;
      positions.writeFloatLE(i, o);
      positions.writeFloatLE(j, o + 4);
      positions.writeFloatLE(0, o + 8);
    }
  const triangles = [];
  for (let j = 0; j + 1 < grid; ++j)
    for (let i = 0; i + 1 < grid; ++i) {
      const a = j * grid + i;
      triangles.push(a, a + 1, a + grid, a + 1, a + grid + 1, a + grid);
    }
  const indices = Buffer.alloc(triangles.length * 2);
  triangles.forEach((v, k) => indices.writeUInt16LE(v, 2 * k));
  const json = {
    asset: { version: '2.0' },
    buffers: [{ byteLength: positions.length + indices.length }],
    bufferViews: [
      { buffer: 0, byteOffset: 0, byteLength: positions.length },
      { buffer: 0, byteOffset: positions.length, byteLength: indices.length },
    ],
    accessors: [
      { bufferView: 0, componentType: 5126, count: grid * grid, type: 'VEC3', min: [0, 0, 0], max: [grid - 1, grid - 1, 0] },
      { bufferView: 1, componentType: 5123, count: triangles.length, type: 'SCALAR' },
    ],
    meshes: [{ primitives: Array.from({ length: primitives }, () => ({ attributes: { POSITION: 0 }, indices: 1 })) }],
    nodes: Array.from({ length: nodes }, (_, k) => (spread ? { mesh: 0, translation: [k * grid, 0, 0] } : { mesh: 0 })),
    scenes: [{ nodes: Array.from({ length: nodes }, (_, k) => k) }],
    scene: 0,
  };
  return glb(json, Buffer.concat([positions, indices]));
}

write('glb', 'regression_amplified_instances.glb', amplifiedGlb());
// The same trick at a size the limits accept, so fuzzing mutates around it: 4 translated
// instances of a 4x4 grid (72 triangles, 64 vertices).
write('glb', 'regression_small_instances.glb', amplifiedGlb({ grid: 4, primitives: 1, nodes: 4, spread: true }));
// OBJ relative index INT64_MIN: negating it overflowed (undefined behaviour).
write('obj', 'regression_relative_int64_min.obj', 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n');
write('obj', 'regression_relative_int64_max.obj', 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9223372036854775807\n');

// ---- small seeds for the formats the shared meshes lack at small sizes ----------------------
const tetra = { v: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], f: [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]] };
write('off', 'tetra.off', `OFF\n4 4 0\n${tetra.v.map((p) => p.join(' ')).join('\n')}\n${tetra.f.map((f) => '3 ' + f.join(' ')).join('\n')}\n`);
write('off', 'quad_and_colour.off', 'OFF\n# a quad with a face colour\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n');
const plyHeader = (format, faceElement = 'face', list = 'vertex_indices') =>
  `ply\nformat ${format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n` +
  `element ${faceElement} ${faceElement === 'face' ? 4 : 1}\nproperty list uchar int ${list}\nend_header\n`;
write('ply', 'tetra_ascii.ply', plyHeader('ascii') + tetra.v.map((p) => p.join(' ')).join('\n') + '\n' + tetra.f.map((f) => '3 ' + f.join(' ')).join('\n') + '\n');
{
  const body = Buffer.alloc(4 * 12 + 4 * 13);
  tetra.v.forEach((p, i) => p.forEach((c, k) => body.writeFloatLE(c, 12 * i + 4 * k)));
  tetra.f.forEach((f, i) => {
    body.writeUInt8(3, 48 + 13 * i);
    f.forEach((v, k) => body.writeInt32LE(v, 48 + 13 * i + 1 + 4 * k));
  });
  write('ply', 'tetra_binary.ply', Buffer.concat([Buffer.from(plyHeader('binary_little_endian')), body]));
}
write('ply', 'strip_ascii.ply', plyHeader('ascii', 'tristrips', 'vertex_indices') + tetra.v.map((p) => p.join(' ')).join('\n') + '\n6 0 1 2 3 -1 0\n');
{
  // What the one-pass PLY reader must handle: big-endian doubles (one needing all 52 mantissa bits), a
  // skipped vertex property, ushort list lengths with uint indices, a list property skipped after
  // the indices and an element after the faces that is never read.
  const header =
    'ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\nproperty uchar flags\nproperty double y\n' +
    'property double z\nelement face 4\nproperty list ushort uint vertex_indices\nproperty list uchar float uv\n' +
    'element edge 1\nproperty int a\nproperty int b\nend_header\n';
  const body = Buffer.alloc(4 * 25 + 4 * (2 + 12 + 1 + 8) + 8);
  let at = 0;
  tetra.v.forEach((p, i) => {
    body.writeDoubleBE(p[0] + (i === 1 ? 1e-12 : 0), at);
    body.writeUInt8(7, at + 8);
    body.writeDoubleBE(p[1], at + 9);
    body.writeDoubleBE(p[2], at + 17);
    at += 25;
  });
  tetra.f.forEach((f) => {
    body.writeUInt16BE(3, at);
    f.forEach((v, k) => body.writeUInt32BE(v, at + 2 + 4 * k));
    body.writeUInt8(2, at + 14);
    body.writeFloatBE(0.5, at + 15);
    body.writeFloatBE(0.25, at + 19);
    at += 23;
  });
  body.writeInt32BE(0, at);
  body.writeInt32BE(1, at + 4);
  write('ply', 'tetra_binary_be_doubles.ply', Buffer.concat([Buffer.from(header), body]));
}
// Strips with uchar indices restart at 255 as well as -1; the winding starts afresh after each.
write('ply', 'strip_uchar_restart.ply', plyHeader('ascii', 'tristrips', 'vertex_indices').replace('list uchar int', 'list uchar uchar') +
  tetra.v.map((p) => p.join(' ')).join('\n') + '\n9 0 1 2 3 255 3 2 1 0\n');
write('off', 'fine_coordinates.off', 'OFF # counts follow\n4 4 0\n' + tetra.v.map((p, i) => p.map((c) => (i === 1 ? c + 1e-12 : c)).join(' ')).join('\n') +
  '\n' + tetra.f.map((f) => '3 ' + f.join(' ')).join('\n') + '\n');
// The edges of the coordinate range the readers accept (|x| <= 1e15, at least 1e-30 across):
// 1e300 had given lines whose lengths were NaN, and the snake converted NaN to int.
write('off', 'regression_huge_coordinates.off', 'OFF\n4 4 0\n' + tetra.v.map((p) => p.map((c) => c * 1e300).join(' ')).join('\n') +
  '\n' + tetra.f.map((f) => '3 ' + f.join(' ')).join('\n') + '\n');
write('off', 'range_edges.off', 'OFF\n4 4 0\n' + tetra.v.map((p, i) => p.map((c) => (i === 1 ? c * 1e15 : c * 1e-20)).join(' ')).join('\n') +
  '\n' + tetra.f.map((f) => '3 ' + f.join(' ')).join('\n') + '\n');
{
  // Repeated triangles: dropped, never given vertex copies.
  const body = Buffer.alloc(12 * 4 + 13 * 200);
  tetra.v.forEach((p, i) => p.forEach((c, k) => body.writeFloatLE(c, 12 * i + 4 * k)));
  for (let f = 0; f < 200; ++f) {
    const at = 48 + 13 * f;
    body.writeUInt8(3, at);
    [0, 1, 2].forEach((v, k) => body.writeInt32LE(f % 2 ? 2 - v : v, at + 1 + 4 * k));
  }
  write('ply', 'regression_repeated_faces.ply', Buffer.concat([Buffer.from(plyHeader('binary_little_endian').replace('element face 4', 'element face 200')), body]));
}
const facets = tetra.f.map((f) => f.map((i) => tetra.v[i]));
write('stl', 'tetra_ascii.stl', 'solid tetra\n' + facets.map((t) =>
  ' facet normal 0 0 0\n  outer loop\n' + t.map((p) => `   vertex ${p.join(' ')}\n`).join('') + '  endloop\n endfacet\n').join('') + 'endsolid tetra\n');
{
  const stl = Buffer.alloc(84 + 50 * facets.length);
  stl.write('binary tetra', 0);
  stl.writeUInt32LE(facets.length, 80);
  facets.forEach((t, i) => t.forEach((p, k) => p.forEach((c, j) => stl.writeFloatLE(c, 84 + 50 * i + 12 + 12 * k + 4 * j))));
  write('stl', 'tetra_binary.stl', stl);
}
{
  // glTF with its buffer as a data: URI, two nodes (one mirrored) instancing the tetrahedron.
  const positions = Buffer.alloc(48);
  tetra.v.forEach((p, i) => p.forEach((c, k) => positions.writeFloatLE(c, 12 * i + 4 * k)));
  const indices = Buffer.alloc(24);
  tetra.f.flat().forEach((v, k) => indices.writeUInt16LE(v, 2 * k));
  const buffer = Buffer.concat([positions, indices]);
  const gltf = {
    asset: { version: '2.0' },
    buffers: [{ byteLength: buffer.length, uri: 'data:application/octet-stream;base64,' + buffer.toString('base64') }],
    bufferViews: [{ buffer: 0, byteOffset: 0, byteLength: 48 }, { buffer: 0, byteOffset: 48, byteLength: 24 }],
    accessors: [
      { bufferView: 0, componentType: 5126, count: 4, type: 'VEC3', min: [0, 0, 0], max: [1, 1, 1] },
      { bufferView: 1, componentType: 5123, count: 12, type: 'SCALAR' },
    ],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1 }] }],
    nodes: [{ mesh: 0 }, { mesh: 0, translation: [3, 0, 0], scale: [-1, 1, 1] }],
    scenes: [{ nodes: [0, 1] }],
    scene: 0,
  };
  write('gltf', 'tetra_two_instances.gltf', JSON.stringify(gltf));
  // Declared counts near SIZE_MAX: the expansion sums saturate instead of wrapping.
  gltf.accessors[1].count = 0;
  write('gltf', 'regression_huge_accessor_count.gltf', JSON.stringify(gltf).replace('"count":0', '"count":18446744073709551615'));
}
{
  // The Draco bitstream of Box_Draco.glb's primitive is a valid .drc file.
  const shared = join(dirname(fileURLToPath(import.meta.url)), '..', '..', '..', 'shared', 'data', 'meshes', 'Box_Draco.glb');
  const glbBytes = readFileSync(shared);
  const jsonLength = glbBytes.readUInt32LE(12);
  const doc = JSON.parse(glbBytes.subarray(20, 20 + jsonLength).toString());
  const binStart = 20 + jsonLength + 8;
  const view = doc.bufferViews[doc.meshes[0].primitives[0].extensions.KHR_draco_mesh_compression.bufferView];
  write('drc', 'box.drc', glbBytes.subarray(binStart + (view.byteOffset || 0), binStart + (view.byteOffset || 0) + view.byteLength));
}
// Feature-line options as a request's "options" carries them.
write('json', 'defaults.json', '{}');
write('json', 'initial_marching.json', '{"initial": "marching", "weights": [1, 1, 1, 2], "curvature_term": "similar-to-end", "fallback": true}');
write('json', 'snake.json', '{"rings": 3, "refine": true, "snake": {"alpha": 0.5, "beta": 0.5, "tau": 0.1, "kappa": 1, "iterations": 200, "spacing": 1, "force": "smooth", "tolerance": 0.001}}');
write('json', 'wrong_type.json', '{"rings": "three", "snake": []}');
write('json', 'regression_expensive_snake.json', '{"snake": {"iterations": 100000, "tolerance": 0, "spacing": 0.05}}');
// The same options by their member paths, and one option by its old and new names (refused).
write('json', 'member_paths.json', '{"initial": {"method": "marching", "marching_delta": 3, "max_edges": 500}, "strip": {"rings": 3, "flattening": "conformal"}, "snake": {"max_iterations": 200}}');
write('json', 'old_and_new_name.json', '{"rings": 3, "strip": {"rings": 4}}');
