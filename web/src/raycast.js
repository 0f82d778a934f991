// Picking without scanning every triangle: a uniform grid over the mesh's bounding box, each
// cell listing the triangles whose bounding box overlaps it, walked cell by cell along the ray
// (Amanatides and Woo, "A fast voxel traversal algorithm for ray tracing", Eurographics 1987).
// three.js's Mesh.raycast tests every triangle (about 26 ms per pointer move on igea's 269k);
// here a move tests the few dozen triangles in the cells the ray crosses. No three.js, so the
// module is checked on its own (tests/web/modules_test.mjs).

// About this many cells per triangle over the box (a surface fills few of them), at most this
// many per axis; a flat axis gets one cell.
const CELLS_PER_TRIANGLE = 4;
const MAX_CELLS_PER_AXIS = 256;

// positions: flat [x, y, z, ...]; index: flat corner ids, three per triangle.
export function buildTriangleGrid(positions, index) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3)
    for (let k = 0; k < 3; ++k) {
      lo[k] = Math.min(lo[k], positions[i + k]);
      hi[k] = Math.max(hi[k], positions[i + k]);
    }
  const extent = hi.map((h, k) => h - lo[k]);
  const largest = Math.max(...extent, 1e-30);
  // Pad by a little so hits on the box's faces fall inside a cell.
  for (let k = 0; k < 3; ++k) (lo[k] -= largest * 1e-6), (hi[k] += largest * 1e-6), (extent[k] = hi[k] - lo[k]);
  const faceCount = index.length / 3;
  const volume = extent.reduce((v, e) => v * Math.max(e, largest / MAX_CELLS_PER_AXIS), 1);
  const cellSize = Math.cbrt(volume / Math.max(1, CELLS_PER_TRIANGLE * faceCount));
  const dims = extent.map((e) => Math.max(1, Math.min(MAX_CELLS_PER_AXIS, Math.ceil(e / cellSize))));
  const grid = { lo, hi, dims, size: extent.map((e, k) => e / dims[k]), positions, index };
  fillCells(grid, faceCount);
  return grid;
}

// The cell range [a, b] along each axis that a triangle's bounding box overlaps.
function cellRange(grid, f, out) {
  const { positions, index, lo, size, dims } = grid;
  for (let k = 0; k < 3; ++k) {
    let mn = Infinity;
    let mx = -Infinity;
    for (let c = 0; c < 3; ++c) {
      const x = positions[3 * index[3 * f + c] + k];
      mn = Math.min(mn, x);
      mx = Math.max(mx, x);
    }
    out[2 * k] = clampCell(Math.floor((mn - lo[k]) / size[k]), dims[k]);
    out[2 * k + 1] = clampCell(Math.floor((mx - lo[k]) / size[k]), dims[k]);
  }
}

const clampCell = (i, n) => Math.max(0, Math.min(n - 1, i));

// Compressed rows: the triangles of cell c are faces[offsets[c] .. offsets[c + 1]).
function fillCells(grid, faceCount) {
  const [nx, ny, nz] = grid.dims;
  const offsets = new Uint32Array(nx * ny * nz + 1);
  const r = new Int32Array(6);
  const visit = (f, each) => {
    cellRange(grid, f, r);
    for (let z = r[4]; z <= r[5]; ++z)
      for (let y = r[2]; y <= r[3]; ++y) for (let x = r[0]; x <= r[1]; ++x) each(x + nx * (y + ny * z));
  };
  for (let f = 0; f < faceCount; ++f) visit(f, (c) => ++offsets[c + 1]);
  for (let c = 0; c < nx * ny * nz; ++c) offsets[c + 1] += offsets[c];
  const fill = offsets.slice(0, nx * ny * nz);
  const faces = new Uint32Array(offsets[nx * ny * nz]);
  for (let f = 0; f < faceCount; ++f) visit(f, (c) => (faces[fill[c]++] = f));
  grid.offsets = offsets;
  grid.faces = faces;
}

// Möller-Trumbore ray/triangle test, both sides: the ray parameter t of the hit, or Infinity.
function intersectTriangle(grid, f, o, d) {
  const { positions: p, index } = grid;
  const a = 3 * index[3 * f];
  const b = 3 * index[3 * f + 1];
  const c = 3 * index[3 * f + 2];
  const e1x = p[b] - p[a], e1y = p[b + 1] - p[a + 1], e1z = p[b + 2] - p[a + 2];
  const e2x = p[c] - p[a], e2y = p[c + 1] - p[a + 1], e2z = p[c + 2] - p[a + 2];
  const qx = d[1] * e2z - d[2] * e2y, qy = d[2] * e2x - d[0] * e2z, qz = d[0] * e2y - d[1] * e2x;
  const det = e1x * qx + e1y * qy + e1z * qz;
  if (Math.abs(det) < 1e-300) return Infinity;
  const inv = 1 / det;
  const sx = o[0] - p[a], sy = o[1] - p[a + 1], sz = o[2] - p[a + 2];
  const u = (sx * qx + sy * qy + sz * qz) * inv;
  if (u < 0 || u > 1) return Infinity;
  const rx = sy * e1z - sz * e1y, ry = sz * e1x - sx * e1z, rz = sx * e1y - sy * e1x;
  const v = (d[0] * rx + d[1] * ry + d[2] * rz) * inv;
  if (v < 0 || u + v > 1) return Infinity;
  const t = (e2x * rx + e2y * ry + e2z * rz) * inv;
  return t >= 0 ? t : Infinity;
}

// Where the ray o + t d (t >= 0) enters and leaves the grid's box, or null when it misses.
function clipToBox(grid, o, d) {
  let t0 = 0;
  let t1 = Infinity;
  for (let k = 0; k < 3; ++k) {
    if (d[k] === 0) {
      if (o[k] < grid.lo[k] || o[k] > grid.hi[k]) return null;
      continue;
    }
    let a = (grid.lo[k] - o[k]) / d[k];
    let b = (grid.hi[k] - o[k]) / d[k];
    if (a > b) [a, b] = [b, a];
    t0 = Math.max(t0, a);
    t1 = Math.min(t1, b);
  }
  return t0 <= t1 ? [t0, t1] : null;
}

// The nearest triangle the ray o + t d (t >= 0) hits: {face, t, point} or null. Each cell's
// triangles are tested; a hit no further than where the ray leaves the cell is the nearest.
export function raycastGrid(grid, o, d) {
  const span = clipToBox(grid, o, d);
  if (!span) return null;
  const { dims, lo, size, offsets, faces } = grid;
  const cell = [0, 0, 0];
  const step = [0, 0, 0];
  const tMax = [0, 0, 0];
  const tDelta = [0, 0, 0];
  for (let k = 0; k < 3; ++k) {
    cell[k] = clampCell(Math.floor((o[k] + d[k] * span[0] - lo[k]) / size[k]), dims[k]);
    step[k] = d[k] > 0 ? 1 : d[k] < 0 ? -1 : 0;
    const boundary = lo[k] + (cell[k] + (step[k] > 0 ? 1 : 0)) * size[k];
    tMax[k] = step[k] === 0 ? Infinity : (boundary - o[k]) / d[k];
    tDelta[k] = step[k] === 0 ? Infinity : size[k] / Math.abs(d[k]);
  }
  let best = Infinity;
  let bestFace = -1;
  for (;;) {
    const c = cell[0] + dims[0] * (cell[1] + dims[1] * cell[2]);
    for (let i = offsets[c]; i < offsets[c + 1]; ++i) {
      const t = intersectTriangle(grid, faces[i], o, d);
      if (t < best) (best = t), (bestFace = faces[i]);
    }
    const k = tMax[0] < tMax[1] ? (tMax[0] < tMax[2] ? 0 : 2) : tMax[1] < tMax[2] ? 1 : 2;
    if (best <= tMax[k] || tMax[k] > span[1]) break;
    cell[k] += step[k];
    if (cell[k] < 0 || cell[k] >= dims[k]) break;
    tMax[k] += tDelta[k];
  }
  if (bestFace < 0) return null;
  return { face: bestFace, t: best, point: [o[0] + best * d[0], o[1] + best * d[1], o[2] + best * d[2]] };
}

// The same answer by testing every triangle (for tests, and the reference the grid must match).
export function raycastAll(grid, o, d) {
  let best = Infinity;
  let bestFace = -1;
  for (let f = 0; f < grid.index.length / 3; ++f) {
    const t = intersectTriangle(grid, f, o, d);
    if (t < best) (best = t), (bestFace = f);
  }
  return bestFace < 0 ? null : { face: bestFace, t: best, point: [o[0] + best * d[0], o[1] + best * d[1], o[2] + best * d[2]] };
}
