// The Featureline page: open a mesh, place keys, see the initial and refined lines,
// tune options, decompose the mesh along the lines, download the results; undo and redo every
// edit, save and load the work as a session file.
//
// Wiring, and the only module that knows every other: one store (model.js, store.js), the
// actions that edit it (actions.js), the effects that send requests from it (line_requests.js,
// mesh_effects.js, segmentation.js, trace.js), the views that draw it (panel.js,
// options_panel.js, segmentation_panel.js, viewer_view.js) and the controls that call the
// actions (picking.js, keyboard.js, the listeners below).
import * as THREE from 'three';
import * as httpApi from './api.js';
import { createActions } from './actions.js';
import { divergingCss } from './colors.js';
import { $, confirmAction } from './dom.js';
import { createDownloads } from './downloads.js';
import { ringNeighbourhood } from './geometry.js';
import { createKeyboard, toggleDrawer, toggleHelp } from './keyboard.js';
import { createLineRequests } from './line_requests.js';
import { createMeshEffects } from './mesh_effects.js';
import { colorMode, createPageStore, isStale, segmentationStale } from './model.js';
import { createOptionsView } from './options_panel.js';
import { createPanelView } from './panel.js';
import { createPicking } from './picking.js';
import { createSegmentation } from './segmentation.js';
import { createSegmentationView } from './segmentation_panel.js';
import { createTracing } from './trace.js';
import { indexedMeshFromGltf, parseGlb, Viewer } from './viewer.js';
import { createViewerView } from './viewer_view.js';

const store = createPageStore({ search: location.search });
const state = store.state;
const actions = createActions(store);
const viewer = new Viewer($('canvas-host'));
const api = httpApi;

let meshEffects = null;
const lineRequests = createLineRequests(store, api, { onMeshGone: (reason) => meshEffects.recoverMesh(reason) });
meshEffects = createMeshEffects(store, api, {
  readMesh: async (bytes) => indexedMeshFromGltf(await parseGlb(bytes)),
  confirm: confirmAction,
  viewState: () => viewer.viewState(),
  lineRequests,
  afterFrame: (f) => requestAnimationFrame(f),
});
const segmentation = createSegmentation(store, api);
const tracing = createTracing(store, api);
const downloads = createDownloads(store, api, viewer, { recoverMesh: meshEffects.recoverMesh });

createViewerView(store, viewer, { onError: (text) => actions.showMessage(text, { error: true }) });
const panel = createPanelView(store, actions);
createOptionsView(store, actions, api);
const segmentsView = createSegmentationView(store);
const picking = createPicking(store, actions, viewer, tracing);

function setTraceMode(on) {
  if (!on) tracing.clearPreview();
  actions.setTraceMode(on);
}

const VIEW_NAMES = { front: 'the front', top: 'above', side: 'the right side' };
function lookFrom(name) {
  if (!state.mesh) return actions.showMessage('Open a mesh first.', { error: true });
  if (viewer.viewFrom(name)) actions.showMessage(`Looking from ${VIEW_NAMES[name]} (${state.upAxis === 'z' ? '+Z' : '+Y'} up); F frames the mesh as it opened.`);
}

const onKeyDown = createKeyboard(store, actions, {
  saveSession: downloads.saveSession,
  openFileChooser: () => $('file-input').click(),
  cancelDrag: picking.cancelDrag,
  fitView: () => viewer.fitView(),
  lookFrom,
  setTraceMode,
});

function decompose() {
  $('decompose-section').open = true;
  segmentation.decompose($('decompose-mode').value);
}

// ---- wiring ------------------------------------------------------------------------------------------------
function wire() {
  const host = $('canvas-host');
  host.addEventListener('pointerdown', picking.onPointerDown, { capture: true });
  host.addEventListener('pointermove', picking.onPointerMove);
  host.addEventListener('dblclick', picking.onDoubleClick);
  host.addEventListener('pointerleave', picking.onPointerLeave);
  window.addEventListener('pointerup', picking.onPointerUp);
  window.addEventListener('keydown', onKeyDown);
  host.addEventListener('contextmenu', (e) => e.preventDefault());

  $('file-input').addEventListener('change', (e) => {
    meshEffects.openFiles(e.target.files);
    e.target.value = '';
  });
  $('session-input').addEventListener('change', (e) => {
    const file = e.target.files?.[0];
    if (file) meshEffects.loadSessionFile(file);
    e.target.value = '';
  });
  // The drop zone is a keyboard control too: Enter or Space opens the file chooser.
  $('drop-zone').addEventListener('keydown', (e) => {
    if (e.key === 'Enter' || e.key === ' ') {
      e.preventDefault();
      $('file-input').click();
    }
  });
  $('choose-file').addEventListener('click', () => $('file-input').click());
  $('toolbar-open').addEventListener('click', () => $('file-input').click());
  // Drop anywhere on the page.
  let dragDepth = 0;
  window.addEventListener('dragenter', (e) => {
    e.preventDefault();
    if (++dragDepth === 1) document.body.classList.add('dragging');
  });
  window.addEventListener('dragleave', () => {
    if (--dragDepth <= 0) (dragDepth = 0), document.body.classList.remove('dragging');
  });
  window.addEventListener('dragover', (e) => e.preventDefault());
  window.addEventListener('drop', (e) => {
    e.preventDefault();
    dragDepth = 0;
    document.body.classList.remove('dragging');
    meshEffects.openFiles(e.dataTransfer?.files);
  });

  $('sample-open').addEventListener('click', () => meshEffects.openSample($('sample-select').value));
  $('curvature-toggle').addEventListener('change', (e) => actions.setColorChoice(e.target.checked ? 'curvature' : 'plain'));
  $('segments-toggle').addEventListener('change', (e) => actions.setColorChoice(e.target.checked ? 'segments' : 'plain'));
  for (const el of document.querySelectorAll('input[name="up-axis"]')) el.addEventListener('change', () => actions.setUpAxis(el.value));
  $('flat-toggle').addEventListener('change', (e) => actions.setFlatShading(e.target.checked));
  $('edges-toggle').addEventListener('change', (e) => actions.setEdgesShown(e.target.checked));
  $('snap-toggle').addEventListener('change', (e) => actions.setSnapping(e.target.checked));
  $('trace-toggle').addEventListener('change', (e) => setTraceMode(e.target.checked));
  $('reset-view').addEventListener('click', () => viewer.fitView());
  for (const name of ['front', 'top', 'side']) $(`view-${name}`).addEventListener('click', () => lookFrom(name));
  $('ortho-toggle').addEventListener('change', (e) => actions.setOrthographic(e.target.checked));
  $('panel-toggle').addEventListener('click', () => toggleDrawer());
  $('panel-close').addEventListener('click', () => toggleDrawer(false));
  $('key-by-id').addEventListener('submit', (e) => {
    e.preventDefault();
    showKeyIdError(actions.addKeyById($('key-vertex').value));
  });
  $('key-vertex').addEventListener('input', () => showKeyIdError(''));
  $('add-line').addEventListener('click', actions.addLine);
  $('toolbar-add-line').addEventListener('click', actions.addLine);
  $('clear-keys').addEventListener('click', actions.clearKeys);
  $('closed-toggle').addEventListener('change', (e) => actions.setClosed(e.target.checked));
  $('undo').addEventListener('click', actions.undo);
  $('redo').addEventListener('click', actions.redo);
  $('save-session').addEventListener('click', downloads.saveSession);
  $('load-session').addEventListener('click', () => $('session-input').click());
  $('help-button').addEventListener('click', () => toggleHelp());
  $('help-close').addEventListener('click', () => toggleHelp(false));
  $('decompose').addEventListener('click', decompose);
  $('toolbar-decompose').addEventListener('click', decompose);
  $('download-json').addEventListener('click', () => downloads.downloadLines('json'));
  for (const format of ['glb', 'obj', 'ply', 'polylines', 'csv']) $(`download-${format}`).addEventListener('click', () => downloads.downloadLines(format));
  $('download-segmented').addEventListener('click', downloads.downloadSegmented);
  document.querySelector('#legend .legend-bar').style.background = divergingCss();
  // Small windows start with the long sections folded, so the lines stay in view.
  if (window.innerHeight < 800) $('options-section').open = false;
}

function showKeyIdError(text) {
  $('key-vertex-error').textContent = text ? `${text[0].toUpperCase()}${text.slice(1)}.` : '';
  $('key-vertex-error').hidden = !text;
  $('key-vertex').setAttribute('aria-invalid', String(!!text));
  if (!text) return;
  $('key-vertex').focus();
}

// ---- for tests (and the curious): the app's state, read-only copies ------------------------------------
window.featureline = {
  get meshId() {
    return state.mesh?.id ?? null;
  },
  get mesh() {
    return state.mesh ? { ...state.mesh } : null;
  },
  get lines() {
    return state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed, trace: l.trace, result: l.result, error: l.error, stale: isStale(l, state.options) }));
  },
  get activeLineId() {
    return state.activeLineId;
  },
  get lastResult() {
    return state.lastResult;
  },
  get requestCount() {
    return state.requestCount;
  },
  get responseCount() {
    return state.responseCount;
  },
  get retryCount() {
    return state.retryCount;
  },
  get options() {
    return structuredClone(state.options);
  },
  get segmentation() {
    return state.segmentation ? { faceColored: state.segmentation.faceColored, stale: segmentationStale(state), ...state.segmentation.answer } : null;
  },
  get decomposeMessage() {
    return state.decomposeMessage;
  },
  get message() {
    return state.message;
  },
  get samples() {
    return state.samples;
  },
  get colorMode() {
    return colorMode(state);
  },
  get uploadProgress() {
    return state.uploadProgress;
  },
  get download() {
    return state.download;
  },
  get curvatureRange() {
    return state.curvatureRange;
  },
  get openTimings() {
    return state.openTimings ?? null;
  },
  get upAxis() {
    return state.upAxis;
  },
  get cad() {
    return state.cad;
  },
  get snapping() {
    return state.snapping;
  },
  get traceMode() {
    return state.traceMode;
  },
  // Trace previews asked of the server so far (hovering), and whether one is drawn.
  get previewRequests() {
    return state.previewRequests;
  },
  get previewLatencyMs() {
    return state.previewLatencyMs;
  },
  get selectedKey() {
    return state.selectedKey;
  },
  get history() {
    const { history } = store;
    return { canUndo: history.canUndo, canRedo: history.canRedo, undo: history.undoLabel, redo: history.redoLabel, depth: history.undoStack.length };
  },
  get pendingSession() {
    return !!state.pendingSession;
  },
  curvatureAt(v) {
    return state.curvature ? state.curvature[v] : null;
  },
  neighbours(v) {
    return state.adjacency ? [...new Set(ringNeighbourhood(state.adjacency, v, 1))].filter((w) => w !== v) : [];
  },
  // Resolves when no request is running or waiting.
  idle: () => lineRequests.idle(),
  // Client coordinates of a vertex on screen (to click or drag it in tests).
  screenPositionOfVertex(v) {
    store.flush();
    viewer.render();
    const p = viewer.toClient(viewer.vertexPosition(v));
    return { x: p.x, y: p.y };
  },
  pickVertexAt(x, y) {
    return viewer.pickVertex(x, y);
  },
  // What one pointer move over the mesh does (pick, snap, read-out, preview), and the face
  // three.js's own raycast (every triangle) finds there: tests time both and compare.
  hoverAt(x, y) {
    picking.hoverFeedback(x, y);
    store.flush();
    return $('readout').hidden ? null : $('readout').textContent;
  },
  threeRaycastAt: (x, y) => viewer.pickFaceWithThree(x, y),
  extremeVertex: (axis, largest) => viewer.extremeVertex(axis, largest),
  // The mesh's bounding sphere ({center, radius}), and where points land in client pixels.
  boundingSphere() {
    const sphere = viewer.displayMesh?.geometry.boundingSphere;
    return sphere ? { center: sphere.center.toArray(), radius: sphere.radius } : null;
  },
  toClient(points) {
    store.flush();
    viewer.render();
    return points.map((p) => {
      const c = viewer.toClient(new THREE.Vector3(...p));
      return { x: c.x, y: c.y };
    });
  },
  get view() {
    return viewer.viewState();
  },
  sceneStats: () => (store.flush(), viewer.sceneStats()),
  surfaceLayerDifference: () => viewer.surfaceLayerDifference(),
  probe: () => viewer.probe(),
};

wire();
panel.render();
segmentsView.render();
actions.showMessage('Open a bundled sample, or drop a mesh file anywhere on the page (? for help).');
meshEffects.loadSamples();
