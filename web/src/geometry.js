// Mesh helpers that need no three.js, so they can be checked on their own: vertex
// neighbourhoods (for snapping keys to features), sharp edges (for CAD outlines), and the
// guess of a mesh's up axis.

// Vertex-to-vertex adjacency in compressed rows: the neighbours of v are
// neighbours[offsets[v] .. offsets[v + 1]). Built once per mesh (the index never changes).
export function vertexAdjacency(index, vertexCount) {
  const degree = new Uint32Array(vertexCount + 1);
  for (let c = 0; c < index.length; ++c) degree[index[c]] += 2; // two edges per corner
  const offsets = new Uint32Array(vertexCount + 1);
  for (let v = 0; v < vertexCount; ++v) offsets[v + 1] = offsets[v] + degree[v];
  const fill = offsets.slice(0, vertexCount);
  const neighbours = new Uint32Array(offsets[vertexCount]);
  for (let f = 0; f < index.length; f += 3) {
    for (let k = 0; k < 3; ++k) {
      const a = index[f + k];
      neighbours[fill[a]++] = index[f + ((k + 1) % 3)];
      neighbours[fill[a]++] = index[f + ((k + 2) % 3)];
    }
  }
  // Each neighbour appears twice (once per shared face); duplicates are harmless for ring walks.
  return { offsets, neighbours };
}

// Vertices within `rings` edges of `start` (start included), in breadth-first order.
export function ringNeighbourhood(adjacency, start, rings) {
  const seen = new Set([start]);
  let frontier = [start];
  for (let r = 0; r < rings; ++r) {
    const next = [];
    for (const v of frontier) {
      for (let i = adjacency.offsets[v]; i < adjacency.offsets[v + 1]; ++i) {
        const w = adjacency.neighbours[i];
        if (!seen.has(w)) {
          seen.add(w);
          next.push(w);
        }
      }
    }
    frontier = next;
  }
  return [...seen];
}

// The strongest feature vertex near a clicked one: among `candidates`, the one with the
// largest |field| that `accept(v)` allows (e.g. within a few pixels of the click). Keeps the
// clicked vertex unless another is clearly stronger (5%) and is a feature at all (|field| at
// least `minStrength`), so clicks on a flat area stay put instead of chasing noise.
export function strongestFeatureVertex(clicked, candidates, field, accept = () => true, minStrength = 0) {
  if (!field) return clicked;
  let best = clicked;
  let bestStrength = Math.max(Math.abs(field[clicked]) * 1.05, minStrength);
  for (const v of candidates) {
    const s = Math.abs(field[v]);
    if (Number.isFinite(s) && s > bestStrength && accept(v)) {
      best = v;
      bestStrength = s;
    }
  }
  return best;
}

// Edges whose two faces' normals differ by more than `angleDeg`, as vertex pairs (lower id
// first). The page's own guess, used only where the server marks no crease at all because the
// angle it chose from the mesh exceeds every dihedral angle (a coarse box, whose creases are
// most of its edges: see sharpEdges' caller in mesh_effects.js).
export function dihedralCreases(positions, index, angleDeg = 30) {
  const cosLimit = Math.cos((angleDeg * Math.PI) / 180);
  const pairs = [];
  visitInteriorEdges(positions, index, (a, b, cos) => {
    if (cos < cosLimit) pairs.push(Math.min(a, b), Math.max(a, b));
  });
  return Uint32Array.from(pairs);
}

// Calls visit(a, b, cos) once for every edge two faces share, with the cosine of the angle
// between their normals. Returns the edges only one face has (the boundary), as a map from
// the edge's key (lower id * 2^32 + higher id) to that face.
function visitInteriorEdges(positions, index, visit) {
  const faceCount = index.length / 3;
  const normals = faceNormals(positions, index);
  const firstFace = new Map(); // edge key -> face, until its second face is seen
  for (let f = 0; f < faceCount; ++f)
    for (let k = 0; k < 3; ++k) {
      const a = index[3 * f + k];
      const b = index[3 * f + ((k + 1) % 3)];
      const key = a < b ? a * 4294967296 + b : b * 4294967296 + a;
      const g = firstFace.get(key);
      if (g === undefined) {
        firstFace.set(key, f);
        continue;
      }
      firstFace.delete(key);
      visit(a, b, normals[3 * f] * normals[3 * g] + normals[3 * f + 1] * normals[3 * g + 1] + normals[3 * f + 2] * normals[3 * g + 2]);
    }
  return firstFace;
}

function faceNormals(positions, index) {
  const faceCount = index.length / 3;
  const normals = new Float32Array(faceCount * 3);
  for (let f = 0; f < faceCount; ++f) {
    const a = 3 * index[3 * f];
    const b = 3 * index[3 * f + 1];
    const c = 3 * index[3 * f + 2];
    const ux = positions[b] - positions[a];
    const uy = positions[b + 1] - positions[a + 1];
    const uz = positions[b + 2] - positions[a + 2];
    const vx = positions[c] - positions[a];
    const vy = positions[c + 1] - positions[a + 1];
    const vz = positions[c + 2] - positions[a + 2];
    const nx = uy * vz - uz * vy;
    const ny = uz * vx - ux * vz;
    const nz = ux * vy - uy * vx;
    const len = Math.hypot(nx, ny, nz) || 1;
    normals[3 * f] = nx / len;
    normals[3 * f + 1] = ny / len;
    normals[3 * f + 2] = nz / len;
  }
  return normals;
}

// The outline to draw: the server's crease edges (`creaseEdges`, vertex pairs from the compact
// mesh download, at the angle the server chose from the mesh's noise: the creases the lines
// follow) and the boundary edges. Returns the outline as a flat array of vertex pairs, the
// number of creases, the share of interior edges whose faces are coplanar (within 1 degree),
// and which vertices lie on the boundary.
export function sharpEdges(positions, index, creaseEdges = new Uint32Array(0)) {
  const edges = [...creaseEdges];
  let interior = 0;
  let flat = 0;
  const cosFlat = Math.cos(Math.PI / 180);
  const firstFace = visitInteriorEdges(positions, index, (a, b, cos) => {
    interior++;
    if (cos > cosFlat) flat++;
  });
  const onBoundary = new Uint8Array(positions.length / 3);
  for (const key of firstFace.keys()) {
    const a = Math.floor(key / 4294967296);
    const b = key % 4294967296;
    edges.push(a, b);
    onBoundary[a] = onBoundary[b] = 1;
  }
  return { edges: Uint32Array.from(edges), creaseCount: creaseEdges.length / 2, flatShare: interior ? flat / interior : 0, onBoundary };
}

// A CAD tessellation: many neighbouring faces are coplanar (a third of the edges, as on a cube
// whose faces are split in two) and there are sharp edges. Scans have almost no exactly flat
// neighbours.
export function looksLikeCad({ flatShare, creaseCount }, faceCount) {
  return flatShare >= 0.3 && creaseCount >= Math.max(4, faceCount * 0.005);
}

// The up axis to open a mesh with: 'y' or 'z'. OBJ, OFF, PLY, glTF and Draco files are Y-up by
// convention (the Stanford scans, glTF by its specification); STL is Z-up (3D printing). A
// mesh much thinner along z than across (a height field, a dome) is shown Z-up whatever its
// format. `size` is the bounding box's extent [x, y, z].
export function guessUpAxis(size, format) {
  const [x, y, z] = size;
  if (z < 0.5 * Math.min(x, y)) return 'z';
  if (format === 'stl') return 'z';
  return 'y';
}
