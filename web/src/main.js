// The Featureline page: open a mesh, place keys, see the initial and refined lines,
// tune options, decompose the mesh along the lines, download the results; undo and redo every
// edit, save and load the work as a session file.
import * as THREE from 'three';
import { $, history, showMessage, state, viewer } from './app.js';
import { divergingCss } from './colors.js';
import { ringNeighbourhood } from './geometry.js';
import { lookFrom, onKeyDown, setOrthographic, setSnapping, toggleDrawer, toggleEdges, toggleHelp } from './keyboard.js';
import { addKeyById, addLine, clearKeys, idleWaiters, isStale, redo, setClosed, settleIdle, undo } from './lines.js';
import { downloadLines, downloadSegmented, loadSamples, loadSessionFile, openFiles, openSample, renderMeshInfo, saveSession } from './open_mesh.js';
import { loadOptionTables, optionsChanged } from './options_panel.js';
import { applyColors, refresh, setUpAxis } from './panel.js';
import { hoverFeedback, onDoubleClick, onPointerDown, onPointerMove, onPointerUp, pointer } from './picking.js';
import { decompose, segmentationStale } from './segmentation_panel.js';
import { clearTracePreview, setTraceMode } from './trace.js';

// ---- wiring ------------------------------------------------------------------------------------------------
function wire() {
  const host = $('canvas-host');
  host.addEventListener('pointerdown', onPointerDown, { capture: true });
  host.addEventListener('pointermove', onPointerMove);
  host.addEventListener('dblclick', onDoubleClick);
  host.addEventListener('pointerleave', () => {
    $('readout').hidden = true;
    viewer.setSnapPreview(null);
    clearTracePreview();
    if (pointer.drag || !viewer.hoverKey) return;
    viewer.hoverKey = null;
    viewer.canvas.style.cursor = '';
    refresh();
  });
  window.addEventListener('pointerup', onPointerUp);
  window.addEventListener('keydown', onKeyDown);
  host.addEventListener('contextmenu', (e) => e.preventDefault());

  $('file-input').addEventListener('change', (e) => {
    openFiles(e.target.files);
    e.target.value = '';
  });
  $('session-input').addEventListener('change', (e) => {
    const file = e.target.files?.[0];
    if (file) loadSessionFile(file);
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
    openFiles(e.dataTransfer?.files);
  });

  $('sample-open').addEventListener('click', () => openSample($('sample-select').value));
  $('curvature-toggle').addEventListener('change', () => {
    if ($('curvature-toggle').checked) $('segments-toggle').checked = false;
    applyColors();
  });
  $('segments-toggle').addEventListener('change', () => {
    if ($('segments-toggle').checked) $('curvature-toggle').checked = false;
    applyColors();
  });
  for (const el of document.querySelectorAll('input[name="up-axis"]')) el.addEventListener('change', () => setUpAxis(el.value));
  $('flat-toggle').addEventListener('change', (e) => viewer.setFlatShading(e.target.checked));
  $('edges-toggle').addEventListener('change', (e) => toggleEdges(e.target.checked));
  $('snap-toggle').addEventListener('change', (e) => setSnapping(e.target.checked));
  $('trace-toggle').addEventListener('change', (e) => setTraceMode(e.target.checked));
  $('reset-view').addEventListener('click', () => viewer.fitView());
  for (const name of ['front', 'top', 'side']) $(`view-${name}`).addEventListener('click', () => lookFrom(name));
  $('ortho-toggle').addEventListener('change', (e) => setOrthographic(e.target.checked));
  $('panel-toggle').addEventListener('click', () => toggleDrawer());
  $('panel-close').addEventListener('click', () => toggleDrawer(false));
  $('key-by-id').addEventListener('submit', (e) => {
    e.preventDefault();
    showKeyIdError(addKeyById($('key-vertex').value));
  });
  $('key-vertex').addEventListener('input', () => showKeyIdError(''));
  $('add-line').addEventListener('click', addLine);
  $('toolbar-add-line').addEventListener('click', addLine);
  $('clear-keys').addEventListener('click', clearKeys);
  $('closed-toggle').addEventListener('change', (e) => setClosed(e.target.checked));
  $('undo').addEventListener('click', undo);
  $('redo').addEventListener('click', redo);
  $('save-session').addEventListener('click', saveSession);
  $('load-session').addEventListener('click', () => $('session-input').click());
  $('help-button').addEventListener('click', () => toggleHelp());
  $('help-close').addEventListener('click', () => toggleHelp(false));
  $('options-form').addEventListener('input', optionsChanged);
  $('options-form').addEventListener('change', optionsChanged);
  $('options-form').addEventListener('submit', (e) => e.preventDefault());
  $('decompose').addEventListener('click', decompose);
  $('toolbar-decompose').addEventListener('click', decompose);
  $('download-json').addEventListener('click', () => downloadLines('json'));
  for (const format of ['glb', 'obj', 'ply', 'polylines', 'csv']) $(`download-${format}`).addEventListener('click', () => downloadLines(format));
  $('download-segmented').addEventListener('click', downloadSegmented);
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
    return state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed, trace: l.trace, result: l.result, error: l.error, stale: isStale(l) }));
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
    return state.segmentation ? { faceColored: state.segmentation.faceColored, stale: segmentationStale(), ...state.segmentation.answer } : null;
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
    return state.colorMode;
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
    return state.previewRequests ?? 0;
  },
  get previewLatencyMs() {
    return state.previewLatencyMs ?? null;
  },
  get selectedKey() {
    return state.selectedKey;
  },
  get history() {
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
  idle() {
    return new Promise((resolve) => {
      idleWaiters.push(resolve);
      settleIdle();
    });
  },
  // Client coordinates of a vertex on screen (to click or drag it in tests).
  screenPositionOfVertex(v) {
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
    hoverFeedback(x, y);
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
    viewer.render();
    return points.map((p) => {
      const c = viewer.toClient(new THREE.Vector3(...p));
      return { x: c.x, y: c.y };
    });
  },
  get view() {
    return viewer.viewState();
  },
  sceneStats: () => viewer.sceneStats(),
  surfaceLayerDifference: () => viewer.surfaceLayerDifference(),
  probe: () => viewer.probe(),
};

wire();
loadOptionTables();
renderMeshInfo();
refresh();
showMessage('Open a bundled sample, or drop a mesh file anywhere on the page (? for help).');
loadSamples();
