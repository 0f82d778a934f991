// The 3D view: the server's indexed mesh, lit and shaded, with per-vertex or per-face
// colours, key markers, and the initial and refined lines. Rendering is on demand, in two
// layers: the surface is drawn again only when it changes (surface_layer.js).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { GLTFExporter } from 'three/addons/exporters/GLTFExporter.js';
import { Line2 } from 'three/addons/lines/Line2.js';
import { LineMaterial } from 'three/addons/lines/LineMaterial.js';
import { LineGeometry } from 'three/addons/lines/LineGeometry.js';
import { segmentColor } from './model.js';
import { buildTriangleGrid, raycastGrid } from './raycast.js';
import { SurfaceLayer } from './surface_layer.js';

// sRGB hex colours (the CSS legend uses the same ones).
export const COLORS = {
  initial: 0xff8c1a,
  refined: 0x00d0ff,
  fitted: 0xff33cc,
  surface: 0xc9ccd2,
  key: 0xffe14d,
  firstKey: 0x5cff8a,
  otherKey: 0xc58cff,
  hoverKey: 0xffffff,
  selectedKey: 0xff4df0,
  snapPreview: 0x5cff8a,
  tracePreview: 0xfff3a0,
  edges: 0x1d2330,
};
const KEY_PIXELS = 7; // key marker radius on screen
// A key hidden behind the surface is drawn faint and smaller, and cannot be grabbed.
const HIDDEN_KEY_OPACITY = 0.3;
const HIDDEN_KEY_SCALE = 0.7;
// Framing leaves this share of the view around the mesh's bounding sphere.
const FRAME_MARGIN = 1.04;
// A top view looks down the up axis; OrbitControls needs the view a hair off it.
const TOP_VIEW_TILT = 1e-3;
// A press within this many pixels of a key's centre is on its marker (grab or select it);
// anywhere else places a new key, so keys can sit close together.
export const KEY_HIT_PIXELS = KEY_PIXELS + 2;

// A labelled surface as three.js objects: one mesh per label (named segment_<label>, like the
// server's GLB), sharing the positions. vertices: flat [x, y, z, ...]; faces: flat corner ids;
// labels: one per face; colorOf(label) -> sRGB triple (the server's palette, from its answer).
export function segmentedSurface(vertices, faces, labels, colorOf) {
  const group = new THREE.Group();
  group.name = 'segments';
  const position = new THREE.Float32BufferAttribute(vertices, 3);
  const byLabel = new Map();
  for (let f = 0; f < labels.length; ++f) {
    if (!byLabel.has(labels[f])) byLabel.set(labels[f], []);
    byLabel.get(labels[f]).push(faces[3 * f], faces[3 * f + 1], faces[3 * f + 2]);
  }
  for (const label of [...byLabel.keys()].sort((a, b) => a - b)) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', position);
    geometry.setIndex(byLabel.get(label));
    geometry.computeVertexNormals();
    const [r, g, b] = colorOf(label);
    const material = new THREE.MeshStandardMaterial({ roughness: 0.8, metalness: 0 });
    material.color.setRGB(r, g, b, THREE.SRGBColorSpace);
    const mesh = new THREE.Mesh(geometry, material);
    mesh.name = `segment_${label}`;
    group.add(mesh);
  }
  return group;
}

// The segmented surface of an answer as three.js objects: the remeshed surface it carries
// (remesh mode), or the mesh with the answer's labels (snap mode); null when it carries neither.
export function segmentedObject(seg, mesh) {
  const { answer } = seg;
  const colorOf = (label) => segmentColor(seg, label);
  const remeshed = answer.remeshed;
  if (Array.isArray(remeshed?.vertices) && Array.isArray(remeshed?.faces))
    return segmentedSurface(remeshed.vertices.flat(), remeshed.faces.flat(), answer.labels, colorOf);
  if (seg.faceColored && mesh) return segmentedSurface(mesh.positions, mesh.index, answer.labels, colorOf);
  return null;
}

// The object as a GLB (ArrayBuffer), written in the page: what is shown is what is saved.
export function exportGlb(object) {
  return new GLTFExporter().parseAsync(object, { binary: true });
}

export function parseGlb(arrayBuffer) {
  return new Promise((resolve, reject) => {
    new GLTFLoader().parse(arrayBuffer, '', resolve, (e) => reject(new Error(`the GLB could not be read: ${e?.message ?? e}`)));
  });
}

// The first triangle mesh of a parsed glTF as flat arrays (transforms applied). The server's
// mesh.glb is indexed in the session's vertex order, so vertex i here is the server's vertex i.
// Quantised positions (KHR_mesh_quantization: integers the node's transform maps back) are
// read as numbers and transformed here: three.js would write a transformed float back into
// the integer array. Normals are computed (the compact GLB has none); a `_CURVATURE`
// attribute with `curvature_offset`/`curvature_scale` extras comes back as `curvature`, the
// server's crease edges as `creaseEdges` (vertex pairs) and the angle it marked them at as
// `creaseAngle` (null from a server that sends none).
export function indexedMeshFromGltf(gltf) {
  let found = null;
  gltf.scene.updateMatrixWorld(true);
  gltf.scene.traverse((o) => {
    if (!found && o.isMesh && o.geometry?.attributes?.position) found = o;
  });
  if (!found) throw new Error('the GLB holds no triangle mesh');
  const source = found.geometry;
  const attribute = source.attributes.position;
  const n = attribute.count;
  const positions = new Float32Array(3 * n);
  const p = new THREE.Vector3();
  for (let v = 0; v < n; ++v) {
    p.fromBufferAttribute(attribute, v).applyMatrix4(found.matrixWorld);
    positions[3 * v] = p.x;
    positions[3 * v + 1] = p.y;
    positions[3 * v + 2] = p.z;
  }
  const index = source.index ? Uint32Array.from(source.index.array) : Uint32Array.from({ length: n }, (_, i) => i);
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setIndex(new THREE.BufferAttribute(index, 1));
  g.computeVertexNormals();
  const normals = new Float32Array(g.attributes.normal.array);
  g.dispose();
  return { positions, normals, index, vertexCount: n, faceCount: index.length / 3, curvature: quantisedCurvature(source), creaseEdges: creaseEdges(gltf.scene), creaseAngle: source.userData?.crease_angle ?? null };
}

// The server's crease edges as vertex pairs: the compact GLB's LINES primitives whose extras
// say `crease` (api/gltf_export.h), over the surface's vertices.
function creaseEdges(scene) {
  const pairs = [];
  scene.traverse((o) => {
    if (o.isLineSegments && o.geometry?.userData?.crease && o.geometry.index) pairs.push(...o.geometry.index.array);
  });
  return Uint32Array.from(pairs);
}

// value = offset + scale * u for the normalised u in [0, 1], the w of the compact GLB's VEC4
// (api/gltf_export.h); null when the GLB carries no such field.
function quantisedCurvature(geometry) {
  const attribute = geometry.attributes._curvature;
  const { curvature_offset: offset, curvature_scale: scale } = geometry.userData ?? {};
  if (!attribute || !Number.isFinite(offset) || !Number.isFinite(scale)) return null;
  const out = new Float32Array(attribute.count);
  const component = attribute.itemSize - 1; // w of a VEC4, or the scalar
  for (let v = 0; v < attribute.count; ++v) out[v] = offset + scale * attribute.getComponent(v, component);
  return out;
}

// The mean length of the triangles' edges (each shared edge counted twice, which does not
// change the mean much): the mesh's own scale for "close to the surface".
export function meanEdgeLength(positions, index) {
  let sum = 0;
  const length = (a, b) => Math.hypot(positions[3 * a] - positions[3 * b], positions[3 * a + 1] - positions[3 * b + 1], positions[3 * a + 2] - positions[3 * b + 2]);
  for (let c = 0; c < index.length; c += 3) sum += length(index[c], index[c + 1]) + length(index[c + 1], index[c + 2]) + length(index[c + 2], index[c]);
  return index.length ? sum / index.length : 0;
}

// What a Line2 draws (for tests): its line and kind, segment count, first and last points.
function drawnPolyline(line) {
  const start = line.geometry.attributes.instanceStart;
  const end = line.geometry.attributes.instanceEnd;
  const n = start.count;
  return {
    lineId: line.userData.lineId,
    kind: line.userData.kind,
    stale: line.userData.stale,
    segments: n,
    first: n ? [start.getX(0), start.getY(0), start.getZ(0)] : null,
    last: n ? [end.getX(n - 1), end.getY(n - 1), end.getZ(n - 1)] : null,
  };
}

// A polyline's geometry for Line2 (a loop repeats its first point).
function lineGeometry(points, closed) {
  const flat = [];
  for (const p of points) flat.push(p[0], p[1], p[2]);
  if (closed && points.length > 2) {
    const a = points[0];
    const b = points[points.length - 1];
    if (a[0] !== b[0] || a[1] !== b[1] || a[2] !== b[2]) flat.push(a[0], a[1], a[2]);
  }
  const geometry = new LineGeometry();
  geometry.setPositions(flat);
  return geometry;
}

export class Viewer {
  constructor(host) {
    this.host = host;
    this.renderer = new THREE.WebGLRenderer({ antialias: true });
    this.renderer.setPixelRatio(Math.min(2, window.devicePixelRatio || 1));
    this.renderer.setClearColor(0x20242c, 1);
    host.appendChild(this.renderer.domElement);
    this.canvas = this.renderer.domElement;

    this.scene = new THREE.Scene();
    this.perspectiveCamera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
    this.orthographicCamera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.01, 100);
    this.camera = this.perspectiveCamera;
    this.scene.add(this.perspectiveCamera, this.orthographicCamera);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x404858, 0.9));
    this.headlight = new THREE.DirectionalLight(0xffffff, 2.2);
    this.headlight.position.set(-0.6, 0.9, 0.5); // relative to the camera: from the viewer's upper left
    this.camera.add(this.headlight);

    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.enableDamping = false;
    this.controls.addEventListener('change', () => this.requestRender());

    this.meshGroup = new THREE.Group();
    this.segmentGroup = new THREE.Group();
    this.lineGroup = new THREE.Group();
    this.keyGroup = new THREE.Group();
    this.edgeGroup = new THREE.Group();
    this.hoverGroup = new THREE.Group();
    this.previewGroup = new THREE.Group(); // the line a click would trace
    this.scene.add(this.meshGroup, this.edgeGroup, this.segmentGroup, this.lineGroup, this.previewGroup, this.keyGroup, this.hoverGroup);
    this.layers = new SurfaceLayer(this.renderer, [this.meshGroup, this.edgeGroup, this.segmentGroup], [this.lineGroup, this.previewGroup, this.keyGroup, this.hoverGroup]);
    this.upAxis = 'y';

    this.raycaster = new THREE.Raycaster();
    this.mesh = null; // the indexed data {positions, normals, index, ...}
    this.displayMesh = null; // un-indexed copy (per-corner colours), same triangle order
    this.keyMarkerGeometry = new THREE.SphereGeometry(1, 16, 12);
    this.materials = new Map(); // shared line and marker materials by look
    this.lineEntries = new Map(); // drawn lines by "lineId:kind": {points, closed, geometry, objects}
    this.hoverKey = null;
    this.selectedKey = null; // {lineId, keyIndex}
    this.renderPending = false;
    this.frames = 0;

    new ResizeObserver(() => this.resize()).observe(host);
    this.resize();
  }

  resize() {
    const w = Math.max(1, this.host.clientWidth);
    const h = Math.max(1, this.host.clientHeight);
    this.renderer.setSize(w, h, false);
    this.perspectiveCamera.aspect = w / h;
    this.perspectiveCamera.updateProjectionMatrix();
    this.setOrthographicHalfHeight(this.orthographicCamera.top);
    this.render();
  }

  get aspect() {
    return Math.max(1, this.host.clientWidth) / Math.max(1, this.host.clientHeight);
  }

  setOrthographicHalfHeight(halfHeight) {
    const o = this.orthographicCamera;
    o.top = halfHeight;
    o.bottom = -halfHeight;
    o.right = halfHeight * this.aspect;
    o.left = -o.right;
    o.updateProjectionMatrix();
  }

  get orthographic() {
    return this.camera === this.orthographicCamera;
  }

  // Switches between perspective and orthographic projection, keeping what is seen at the orbit
  // centre the same size.
  setOrthographic(on) {
    if (on === this.orthographic) return;
    const from = this.camera;
    const to = on ? this.orthographicCamera : this.perspectiveCamera;
    const target = this.controls.target;
    const distance = from.position.distanceTo(target);
    const tanHalf = Math.tan(THREE.MathUtils.degToRad(this.perspectiveCamera.fov / 2));
    to.position.copy(from.position);
    to.up.copy(from.up);
    if (on) {
      to.zoom = 1;
      this.setOrthographicHalfHeight(distance * tanHalf);
    } else {
      const halfHeight = from.top / from.zoom;
      to.position.copy(target).addScaledVector(from.position.clone().sub(target).normalize(), halfHeight / tanHalf);
    }
    to.near = from.near;
    to.far = from.far;
    to.updateProjectionMatrix();
    to.add(this.headlight);
    this.camera = to;
    this.controls.object = to;
    this.controls.update();
    this.requestRender();
  }

  requestRender() {
    if (this.renderPending) return;
    this.renderPending = true;
    requestAnimationFrame(() => {
      this.renderPending = false;
      this.render();
    });
  }

  render() {
    this.scaleKeyMarkers();
    this.dimHiddenKeys();
    this.layers.render(this.scene, this.camera);
    this.frames++;
  }

  // ---- the mesh -----------------------------------------------------------------------
  // mesh: {positions, normals, index, ...}; upAxis 'y' | 'z'; flat: flat shading (CAD);
  // sharpEdges: vertex pairs to outline (shown when flat or asked for).
  setMesh(mesh, { upAxis = 'y', flat = false, sharpEdges = null, showEdges = flat } = {}) {
    this.clearGroup(this.meshGroup);
    this.clearGroup(this.segmentGroup);
    this.clearGroup(this.lineGroup);
    this.clearGroup(this.keyGroup);
    this.clearGroup(this.edgeGroup);
    this.clearGroup(this.hoverGroup);
    this.clearGroup(this.previewGroup);
    this.disposeSharedMaterials(); // dash lengths follow the mesh's size
    this.lineEntries = new Map();
    this.hoverKey = null;
    this.selectedKey = null;
    this.mesh = mesh;
    this.upAxis = upAxis;
    const { positions, normals, index, faceCount } = mesh;
    const pos = new Float32Array(faceCount * 9);
    const nor = new Float32Array(faceCount * 9);
    for (let c = 0; c < faceCount * 3; ++c) {
      const v = index[c];
      for (let k = 0; k < 3; ++k) {
        pos[3 * c + k] = positions[3 * v + k];
        nor[3 * c + k] = normals[3 * v + k];
      }
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    geometry.setAttribute('normal', new THREE.BufferAttribute(nor, 3));
    geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(faceCount * 9), 3));
    geometry.computeBoundingBox();
    geometry.computeBoundingSphere();
    const material = new THREE.MeshStandardMaterial({
      vertexColors: true,
      flatShading: flat,
      roughness: 0.8,
      metalness: 0,
      side: THREE.DoubleSide,
      // Pushed back a little in depth, so lines lying on the surface are never hidden by it.
      polygonOffset: true,
      polygonOffsetFactor: 1,
      polygonOffsetUnits: 2,
    });
    this.displayMesh = new THREE.Mesh(geometry, material);
    this.displayMesh.name = 'mesh';
    this.meshGroup.add(this.displayMesh);
    this.setEdges(sharpEdges);
    this.showEdges(showEdges);
    this.setPlainColors();
    this.fitView();
  }

  setFlatShading(flat) {
    if (!this.displayMesh) return;
    this.displayMesh.material.flatShading = flat;
    this.displayMesh.material.needsUpdate = true;
    this.requestRender();
  }

  get flatShading() {
    return !!this.displayMesh?.material.flatShading;
  }

  // Sharp-edge outlines: thin dark segments on the surface (the mesh is offset back in depth).
  setEdges(pairs) {
    this.clearGroup(this.edgeGroup);
    if (!pairs || !pairs.length || !this.mesh) return;
    const p = this.mesh.positions;
    const flat = new Float32Array(pairs.length * 3);
    for (let i = 0; i < pairs.length; ++i) flat.set(p.subarray(3 * pairs[i], 3 * pairs[i] + 3), 3 * i);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(flat, 3));
    const edges = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color: COLORS.edges }));
    edges.name = 'sharp-edges';
    this.edgeGroup.add(edges);
    this.requestRender();
  }

  showEdges(on) {
    this.edgeGroup.visible = on;
    this.requestRender();
  }

  get edgesShown() {
    return this.edgeGroup.visible && this.edgeGroup.children.length > 0;
  }

  setUpAxis(axis) {
    this.upAxis = axis;
    this.fitView();
  }

  // Orbit around a point on the surface (double-click), keeping the camera where it is.
  setOrbitCenter(point) {
    this.controls.target.set(point[0], point[1], point[2]);
    this.controls.update();
    this.requestRender();
  }

  // The camera distance at which a sphere of this radius fills the view without being cut,
  // by the narrower of the vertical and horizontal fields of view (a tall window is narrow).
  fitDistance(radius) {
    const halfVertical = THREE.MathUtils.degToRad(this.perspectiveCamera.fov / 2);
    const halfHorizontal = Math.atan(Math.tan(halfVertical) * this.aspect);
    return (radius * FRAME_MARGIN) / Math.sin(Math.min(halfVertical, halfHorizontal));
  }

  // Seen from the front (+z for Y-up, -y for Z-up), a little from the right and from above
  // (more from above for Z-up meshes, which are mostly height fields and parts lying flat).
  defaultViewDirection() {
    return this.upAxis === 'z' ? new THREE.Vector3(0.25, -1.0, 0.95) : new THREE.Vector3(0.3, 0.45, 1.0);
  }

  // The direction from the orbit centre to the camera for a named view, by the up axis.
  presetDirection(name) {
    const zUp = this.upAxis === 'z';
    const directions = {
      front: zUp ? [0, -1, 0] : [0, 0, 1],
      top: zUp ? [0, -TOP_VIEW_TILT, 1] : [0, 1, TOP_VIEW_TILT],
      side: [1, 0, 0],
    };
    return directions[name] ? new THREE.Vector3(...directions[name]) : null;
  }

  fitView(direction = this.defaultViewDirection()) {
    if (!this.displayMesh) return;
    const center = this.displayMesh.geometry.boundingSphere.center.clone();
    const radius = Math.max(1e-9, this.displayMesh.geometry.boundingSphere.radius);
    this.radius = radius;
    const zUp = this.upAxis === 'z';
    const distance = this.fitDistance(radius);
    for (const camera of [this.perspectiveCamera, this.orthographicCamera]) {
      camera.up.set(0, zUp ? 0 : 1, zUp ? 1 : 0);
      camera.position.copy(center).addScaledVector(direction.clone().normalize(), distance);
      camera.near = distance / 100;
      camera.far = distance * 20;
      camera.zoom = 1;
      camera.updateProjectionMatrix();
    }
    this.setOrthographicHalfHeight((radius * FRAME_MARGIN) / Math.min(1, this.aspect));
    this.controls.target.copy(center);
    this.controls.update();
    this.requestRender();
  }

  // Front, top or side, framing the whole mesh.
  viewFrom(name) {
    const direction = this.presetDirection(name);
    if (direction) this.fitView(direction);
    return !!direction;
  }

  // What a session keeps of the view: camera, orbit centre, projection and zoom.
  viewState() {
    return {
      position: this.camera.position.toArray(),
      target: this.controls.target.toArray(),
      orthographic: this.orthographic,
      zoom: this.camera.zoom,
    };
  }

  setViewState({ position, target, orthographic = false, zoom = 1 }) {
    if (!this.displayMesh) return;
    this.setOrthographic(!!orthographic);
    this.camera.position.fromArray(position);
    this.controls.target.fromArray(target);
    this.camera.zoom = zoom;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.requestRender();
  }

  get faceCount() {
    return this.mesh ? this.mesh.faceCount : 0;
  }

  // Colours are sRGB triples; they are stored linear, as three.js expects.
  colorAttribute() {
    return this.displayMesh.geometry.attributes.color;
  }

  setPlainColors() {
    if (!this.displayMesh) return;
    const c = new THREE.Color(COLORS.surface); // hex is sRGB; c holds linear components
    const attr = this.colorAttribute();
    for (let i = 0; i < attr.array.length; i += 3) {
      attr.array[i] = c.r;
      attr.array[i + 1] = c.g;
      attr.array[i + 2] = c.b;
    }
    attr.needsUpdate = true;
    this.showSegmentScene(false);
  }

  // rgbOfVertex(v) -> sRGB triple.
  setVertexColors(rgbOfVertex) {
    if (!this.displayMesh) return;
    const { vertexCount, index } = this.mesh;
    const linear = new Float32Array(vertexCount * 3);
    const c = new THREE.Color();
    for (let v = 0; v < vertexCount; ++v) {
      const [r, g, b] = rgbOfVertex(v);
      c.setRGB(r, g, b, THREE.SRGBColorSpace);
      linear[3 * v] = c.r;
      linear[3 * v + 1] = c.g;
      linear[3 * v + 2] = c.b;
    }
    const attr = this.colorAttribute();
    const a = attr.array;
    for (let corner = 0; corner < index.length; ++corner) {
      const v = index[corner];
      a[3 * corner] = linear[3 * v];
      a[3 * corner + 1] = linear[3 * v + 1];
      a[3 * corner + 2] = linear[3 * v + 2];
    }
    attr.needsUpdate = true;
    this.showSegmentScene(false);
  }

  // rgbOfFace(f) -> sRGB triple (flat colour per face; the display copy is un-indexed).
  setFaceColors(rgbOfFace) {
    if (!this.displayMesh) return;
    const attr = this.colorAttribute();
    const a = attr.array;
    const c = new THREE.Color();
    for (let f = 0; f < this.mesh.faceCount; ++f) {
      const [r, g, b] = rgbOfFace(f);
      c.setRGB(r, g, b, THREE.SRGBColorSpace);
      for (let k = 0; k < 3; ++k) {
        a[9 * f + 3 * k] = c.r;
        a[9 * f + 3 * k + 1] = c.g;
        a[9 * f + 3 * k + 2] = c.b;
      }
    }
    attr.needsUpdate = true;
    this.showSegmentScene(false);
  }

  // A separate segmented surface (remesh mode: built from the server's answer, or its GLB's
  // scene), shown instead of the mesh; picking still uses the mesh.
  setSegmentScene(object) {
    this.clearGroup(this.segmentGroup);
    if (!object) return;
    object.traverse((o) => {
      if (o.isMesh) {
        const materials = Array.isArray(o.material) ? o.material : [o.material];
        for (const m of materials) {
          m.side = THREE.DoubleSide;
          m.polygonOffset = true;
          m.polygonOffsetFactor = 1;
          m.polygonOffsetUnits = 2;
        }
      }
    });
    this.segmentGroup.add(object);
  }

  showSegmentScene(on) {
    const has = this.segmentGroup.children.length > 0;
    this.segmentGroup.visible = on && has;
    this.meshGroup.visible = !(on && has);
    this.requestRender();
  }

  // ---- picking ------------------------------------------------------------------------
  ndc(clientX, clientY) {
    const r = this.canvas.getBoundingClientRect();
    return new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
  }

  // The grid is built on the first pick, not before the first frame (igea: about 0.2 s).
  pickingGrid() {
    if (!this.triangleGrid || this.triangleGrid.positions !== this.mesh.positions)
      this.triangleGrid = buildTriangleGrid(this.mesh.positions, this.mesh.index);
    return this.triangleGrid;
  }

  // The mesh vertex under the pointer: the corner of the hit triangle nearest to the hit.
  pickVertex(clientX, clientY) {
    if (!this.displayMesh) return null;
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    this.pickingGrid();
    // The mesh is drawn untransformed (the up axis turns the camera), so the world ray is the
    // mesh's own.
    const { origin, direction } = this.raycaster.ray;
    const hit = raycastGrid(this.triangleGrid, origin.toArray(), direction.toArray());
    if (!hit) return null;
    hit.point = new THREE.Vector3(...hit.point);
    const f = hit.face;
    const { index, positions } = this.mesh;
    let best = -1;
    let bestD = Infinity;
    for (let k = 0; k < 3; ++k) {
      const v = index[3 * f + k];
      const dx = positions[3 * v] - hit.point.x;
      const dy = positions[3 * v + 1] - hit.point.y;
      const dz = positions[3 * v + 2] - hit.point.z;
      const d = dx * dx + dy * dy + dz * dz;
      if (d < bestD) (bestD = d), (best = v);
    }
    return { vertex: best, face: f, point: hit.point.toArray(), distance: hit.t };
  }

  // three.js's raycast of the drawn mesh (tests every triangle): {face, distance} or null. The
  // reference that pickVertex's grid must agree with.
  pickFaceWithThree(clientX, clientY) {
    if (!this.displayMesh) return null;
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    const hit = this.raycaster.intersectObject(this.displayMesh, false)[0];
    return hit ? { face: hit.faceIndex, distance: hit.distance } : null;
  }

  // The vertex with the smallest or largest coordinate along an axis (0, 1, 2).
  extremeVertex(axis, largest) {
    const p = this.mesh.positions;
    let best = 0;
    for (let v = 1; v < this.mesh.vertexCount; ++v)
      if (largest ? p[3 * v + axis] > p[3 * best + axis] : p[3 * v + axis] < p[3 * best + axis]) best = v;
    return best;
  }

  vertexPosition(v) {
    const p = this.mesh.positions;
    return new THREE.Vector3(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
  }

  // Client (CSS pixel) coordinates of a world point.
  toClient(point) {
    const r = this.canvas.getBoundingClientRect();
    const p = point.clone().project(this.camera);
    return { x: r.left + ((p.x + 1) / 2) * r.width, y: r.top + ((1 - p.y) / 2) * r.height, inFront: p.z < 1 && p.z > -1 };
  }

  // Whether the mesh hides a point of its surface from the camera: the ray from the camera to
  // the point meets the surface clearly before reaching it. "Clearly": further than an edge's
  // length, so a key in a shallow valley seen at a slant still counts as seen.
  isOccluded(point) {
    if (!this.mesh) return false;
    const origin = this.orthographic
      ? point.clone().addScaledVector(this.camera.getWorldDirection(new THREE.Vector3()), -this.camera.far)
      : this.camera.position.clone();
    const toPoint = point.clone().sub(origin);
    const distance = toPoint.length();
    if (distance === 0) return false;
    const hit = raycastGrid(this.pickingGrid(), origin.toArray(), toPoint.divideScalar(distance).toArray());
    return !!hit && hit.t < distance - this.occlusionTolerance();
  }

  occlusionTolerance() {
    if (this.meanEdge === undefined || this.meanEdgeOf !== this.mesh) {
      this.meanEdge = meanEdgeLength(this.mesh.positions, this.mesh.index);
      this.meanEdgeOf = this.mesh;
    }
    return Math.max(this.meanEdge, (this.radius || 1) * 1e-3);
  }

  // Markers of keys behind the surface: faint and smaller (they are drawn over the surface,
  // so the key stays findable, but must not look like the one in front).
  dimHiddenKeys() {
    for (const marker of this.keyGroup.children) {
      const hidden = this.isOccluded(marker.position);
      marker.userData.hidden = hidden;
      marker.userData.scale = hidden ? HIDDEN_KEY_SCALE : 1;
      marker.material = this.markerMaterial(marker.userData.color, hidden ? HIDDEN_KEY_OPACITY : marker.userData.opacity);
    }
  }

  // The key marker nearest to the pointer within a few pixels: {lineId, keyIndex}; keys of
  // the active line win over others. Keys hidden behind the surface are not picked: the press
  // is on the surface in front of them.
  pickKey(clientX, clientY, radiusPx = KEY_HIT_PIXELS) {
    let best = null;
    let bestScore = Infinity;
    for (const marker of this.keyGroup.children) {
      const s = this.toClient(marker.position);
      if (!s.inFront) continue;
      const d = Math.hypot(s.x - clientX, s.y - clientY);
      if (d > radiusPx || this.isOccluded(marker.position)) continue;
      const score = d - (marker.userData.active ? 1000 : 0);
      if (score < bestScore) {
        bestScore = score;
        best = { lineId: marker.userData.lineId, keyIndex: marker.userData.keyIndex };
      }
    }
    return best;
  }

  // Where a click would place a key (after snapping): a small ring-less dot, or nothing.
  setSnapPreview(vertex) {
    this.clearGroup(this.hoverGroup);
    if (vertex != null && this.mesh) {
      const marker = new THREE.Mesh(this.keyMarkerGeometry, this.markerMaterial(COLORS.snapPreview, 0.55));
      marker.position.copy(this.vertexPosition(vertex));
      marker.renderOrder = 3;
      marker.userData = { preview: true, vertex, scale: 0.6 };
      marker.name = 'snap-preview';
      this.hoverGroup.add(marker);
    }
    this.requestRender();
  }

  // The line a click here would trace (trace mode), drawn faintly; null draws none.
  setTracePreview(points, closed = false) {
    this.clearGroup(this.previewGroup);
    if (this.mesh && points?.length >= 2) {
      const geometry = lineGeometry(points, closed);
      for (const o of this.lineObjects(geometry, COLORS.tracePreview, 2.5, { active: false, kind: 'preview' })) this.previewGroup.add(o);
    }
    this.requestRender();
  }

  // ---- lines and keys -------------------------------------------------------------------
  // Removes a group's objects, disposing what is theirs alone (not the shared materials and
  // marker geometry).
  clearGroup(group) {
    for (const child of [...group.children]) {
      group.remove(child);
      child.traverse((o) => {
        if (o.geometry && o.geometry !== this.keyMarkerGeometry) o.geometry.dispose();
        if (o.material) (Array.isArray(o.material) ? o.material : [o.material]).forEach((m) => m.userData.shared || m.dispose());
      });
    }
  }

  // One material per look, kept while the mesh is open: three.js frees a shader program with
  // the last material using it, so a new material per object and refresh would compile the
  // line and marker shaders again on every refresh (0.1-0.3 s a time with software WebGL).
  sharedMaterial(key, create) {
    let material = this.materials.get(key);
    if (!material) {
      material = create();
      material.userData.shared = true;
      this.materials.set(key, material);
    }
    return material;
  }

  disposeSharedMaterials() {
    for (const m of this.materials.values()) m.dispose();
    this.materials.clear();
  }

  markerMaterial(color, opacity) {
    return this.sharedMaterial(`marker:${color}:${opacity}`, () => new THREE.MeshBasicMaterial({ color, depthTest: false, transparent: true, opacity }));
  }

  // An out-of-date line (its keys changed, the new answer is not in) is drawn dashed; the
  // ghost is the faint copy drawn over everything.
  lineMaterial(color, width, { ghost, active, stale }) {
    return this.sharedMaterial(`line:${color}:${width}:${ghost}:${active}:${stale}`, () => new LineMaterial({
      color,
      linewidth: ghost ? width * 0.75 : width,
      worldUnits: false,
      transparent: ghost || !active || stale,
      opacity: ghost ? (active ? 0.35 : 0.2) : stale ? 0.55 : active ? 1 : 0.6,
      depthTest: !ghost,
      depthWrite: !ghost,
      dashed: stale,
      // Dashes are measured along the line in world units: a fixed share of the mesh's size.
      dashSize: (this.radius || 1) * 0.025,
      gapSize: (this.radius || 1) * 0.02,
    }));
  }

  // A line is drawn twice from one geometry: faintly on top of everything (so a line behind a
  // fold still shows), and fully where it is visible.
  lineObjects(geometry, color, width, { active, kind, lineId, stale = false }) {
    const objects = [true, false].map((ghost) => {
      const line = new Line2(geometry, this.lineMaterial(color, width, { ghost, active, stale }));
      line.renderOrder = ghost ? 1 : 2;
      line.userData = { kind, ghost, lineId, active, stale };
      line.name = `${kind}-line`;
      return line;
    });
    objects[0].computeLineDistances(); // on the shared geometry: what dashes are measured by
    return objects;
  }

  // The drawn objects of one line's initial or refined polyline: those of the last refresh when
  // its points are the same (the same answer), else new ones.
  lineEntry(previous, lineId, kind, points, closed) {
    const key = `${lineId}:${kind}`;
    const old = previous.get(key);
    if (old && old.points === points && old.closed === closed) {
      previous.delete(key);
      return [key, old];
    }
    return [key, { points, closed, geometry: lineGeometry(points, closed), objects: null }];
  }

  // lines: [{id, keys, closed, result, stale}], activeId: the active line's id. Only lines
  // with a new answer get new geometry; the others keep theirs and change look.
  setLines(lines, activeId) {
    if (!this.mesh) return;
    const previous = this.lineEntries;
    this.lineEntries = new Map();
    this.lineGroup.clear();
    for (const line of lines) {
      const active = line.id === activeId;
      const r = line.result;
      // The fitted curve (options.fitted.enabled) is always dashed: it may leave the surface.
      for (const [kind, color, width] of [['initial', COLORS.initial, 2], ['refined', COLORS.refined, 3.5], ['fitted', COLORS.fitted, 2.5]]) {
        const points = r?.[kind]?.points;
        if (!(points?.length >= 2)) continue;
        const closed = kind === 'fitted' ? r.fitted.closed : r.closed;
        const [key, entry] = this.lineEntry(previous, line.id, kind, points, closed);
        const look = { active, kind, lineId: line.id, stale: line.stale };
        const dashed = line.stale || kind === 'fitted';
        if (!entry.objects) entry.objects = this.lineObjects(entry.geometry, color, width, { ...look, stale: dashed });
        for (const o of entry.objects) {
          o.material = this.lineMaterial(color, width, { ghost: o.userData.ghost, active, stale: dashed });
          Object.assign(o.userData, look);
          this.lineGroup.add(o);
        }
        this.lineEntries.set(key, entry);
      }
    }
    for (const gone of previous.values()) gone.geometry.dispose();
    this.setKeyMarkers(lines, activeId);
    this.requestRender();
  }

  // One marker per key, the marker objects reused between refreshes.
  setKeyMarkers(lines, activeId) {
    const markers = this.keyGroup.children;
    let n = 0;
    for (const line of lines) {
      const active = line.id === activeId;
      line.keys.forEach((v, i) => {
        const hover = this.hoverKey && this.hoverKey.lineId === line.id && this.hoverKey.keyIndex === i;
        const selected = this.selectedKey && this.selectedKey.lineId === line.id && this.selectedKey.keyIndex === i;
        const color = hover ? COLORS.hoverKey : selected ? COLORS.selectedKey : !active ? COLORS.otherKey : i === 0 ? COLORS.firstKey : COLORS.key;
        const opacity = active ? 1 : 0.85;
        if (n === markers.length) this.keyGroup.add(new THREE.Mesh(this.keyMarkerGeometry));
        const marker = markers[n++];
        marker.material = this.markerMaterial(color, opacity);
        marker.position.copy(this.vertexPosition(v));
        marker.renderOrder = 3;
        marker.userData = { lineId: line.id, keyIndex: i, active, vertex: v, color, opacity };
        marker.name = 'key';
      });
    }
    while (markers.length > n) this.keyGroup.remove(markers[markers.length - 1]);
  }

  // Key markers keep a constant size on screen.
  scaleKeyMarkers() {
    const h = this.canvas.clientHeight || 1;
    const c = this.camera;
    // World units per pixel: at the marker's distance in perspective, everywhere the same in
    // orthographic projection.
    const perPixel = this.orthographic
      ? () => (c.top - c.bottom) / c.zoom / h
      : (m) => (m.position.distanceTo(c.position) * 2 * Math.tan(THREE.MathUtils.degToRad(c.fov / 2))) / h;
    for (const m of [...this.keyGroup.children, ...this.hoverGroup.children])
      m.scale.setScalar(Math.max(1e-9, perPixel(m) * KEY_PIXELS * (m.userData.scale ?? 1)));
  }

  // ---- for tests ----------------------------------------------------------------------
  sceneStats() {
    const count = (pred) => {
      let n = 0;
      this.lineGroup.traverse((o) => {
        if (o.isLine2 && pred(o.userData)) n++;
      });
      return n;
    };
    return {
      frames: this.frames,
      triangles: this.faceCount,
      initialLines: count((u) => u.kind === 'initial' && !u.ghost),
      refinedLines: count((u) => u.kind === 'refined' && !u.ghost),
      fittedLines: count((u) => u.kind === 'fitted' && !u.ghost),
      lineObjects: this.lineGroup.children.length,
      keyMarkers: this.keyGroup.children.length,
      keys: this.keyGroup.children.map((m) => ({ lineId: m.userData.lineId, keyIndex: m.userData.keyIndex, vertex: m.userData.vertex, hidden: this.isOccluded(m.position), opacity: m.material.opacity })),
      orthographic: this.orthographic,
      segmentSceneShown: this.segmentGroup.visible && this.segmentGroup.children.length > 0,
      staleLines: count((u) => u.kind === 'refined' && !u.ghost && u.stale),
      flatShading: this.flatShading,
      edgesShown: this.edgesShown,
      upAxis: this.upAxis,
      cameraUp: this.camera.up.toArray(),
      cameraPosition: this.camera.position.toArray(),
      orbitCenter: this.controls.target.toArray(),
      snapPreview: this.hoverGroup.children[0]?.userData.vertex ?? null,
      tracePreviewPoints: this.previewGroup.children.length ? this.previewGroup.children[1].geometry.attributes.instanceStart.count + 1 : 0,
      // The lines as drawn: their segments' first and last points (x, y, z), per line and kind.
      drawnLines: this.lineGroup.children.filter((o) => !o.userData.ghost).map((o) => drawnPolyline(o)),
      surfaceDraws: this.layers.surfaceDraws,
    };
  }

  // The frame drawn through the surface layer against the scene drawn directly, without the
  // overlays: the number of pixels that differ (0: the layer shows the surface as it is).
  surfaceLayerDifference() {
    const overlays = [this.lineGroup, this.previewGroup, this.keyGroup, this.hoverGroup];
    const shown = overlays.map((g) => g.visible);
    overlays.forEach((g) => (g.visible = false));
    this.render();
    const layered = this.readFrame();
    this.renderer.render(this.scene, this.camera);
    const direct = this.readFrame();
    overlays.forEach((g, i) => (g.visible = shown[i]));
    this.render();
    let differing = 0;
    for (let i = 0; i < direct.length; i += 4)
      if (direct[i] !== layered[i] || direct[i + 1] !== layered[i + 1] || direct[i + 2] !== layered[i + 2]) differing++;
    return { differing, pixels: direct.length / 4 };
  }

  readFrame() {
    const gl = this.renderer.getContext();
    const px = new Uint8Array(gl.drawingBufferWidth * gl.drawingBufferHeight * 4);
    gl.readPixels(0, 0, gl.drawingBufferWidth, gl.drawingBufferHeight, gl.RGBA, gl.UNSIGNED_BYTE, px);
    return px;
  }

  // Renders now and counts pixels of the line colours (and of the background) in the frame.
  probe() {
    this.render();
    const gl = this.renderer.getContext();
    const w = gl.drawingBufferWidth;
    const h = gl.drawingBufferHeight;
    const px = this.readFrame();
    const target = (hex) => [(hex >> 16) & 255, (hex >> 8) & 255, hex & 255];
    const initial = target(COLORS.initial);
    const refined = target(COLORS.refined);
    const near = (i, t) => Math.abs(px[i] - t[0]) + Math.abs(px[i + 1] - t[1]) + Math.abs(px[i + 2] - t[2]) < 60;
    let nInitial = 0;
    let nRefined = 0;
    let nBackground = 0;
    for (let i = 0; i < px.length; i += 4) {
      if (near(i, initial)) nInitial++;
      else if (near(i, refined)) nRefined++;
      else if (near(i, [0x20, 0x24, 0x2c])) nBackground++;
    }
    return { width: w, height: h, initial: nInitial, refined: nRefined, background: nBackground, total: w * h };
  }
}
