// The 3D view of the state: the mesh and its outline, colours (plain, curvature, segments),
// the segmented surface, lines and key markers, the trace preview, up axis, shading and a
// loaded session's camera. It subscribes to the store and tells the viewer (viewer.js) only
// what changed, so dragging a key never draws the surface again.
import { diverging } from './colors.js';
import { colorMode, isStale, segmentColor } from './model.js';
import { parseGlb, segmentedObject } from './viewer.js';

// onError(text): a segmented surface that could not be read.
export function createViewerView(store, viewer, { onError = () => {} } = {}) {
  const shown = { lines: '', linesGeometry: null, geometry: null, upAxis: null, flat: null, edges: null, colors: '', segmentation: null, preview: null, sessionView: null, orthographic: null };
  let colorKey = 0;
  const ids = new WeakMap(); // objects -> a number, for the colour signature
  const idOf = (o) => {
    if (!o) return 0;
    if (!ids.has(o)) ids.set(o, ++colorKey);
    return ids.get(o);
  };

  // The remeshed surface of a decomposition (remesh mode): from the answer, or read from the GLB
  // an older server answered with (then shown once read).
  function showSegmentSurface(seg) {
    viewer.setSegmentScene(null);
    if (!seg || seg.faceColored || !seg.sceneLoaded) return;
    const surface = segmentedObject(seg, viewer.mesh);
    if (surface) return viewer.setSegmentScene(surface);
    if (!seg.surfaceGlb) return;
    parseGlb(seg.surfaceGlb).then(
      (gltf) => {
        if (store.state.segmentation !== seg) return;
        viewer.setSegmentScene(gltf.scene);
        shown.colors = ''; // shown again with the surface in place
        render(store.state);
      },
      (e) => onError(`the segmented surface could not be shown (${e.message})`),
    );
  }

  function applyColors(state) {
    const mode = colorMode(state);
    const seg = state.segmentation;
    const signature = `${mode}:${idOf(state.geometry)}:${idOf(state.curvature)}:${mode === 'segments' ? idOf(seg) : 0}`;
    if (signature === shown.colors) return;
    shown.colors = signature;
    if (mode === 'segments') {
      if (seg.faceColored) viewer.setFaceColors((f) => segmentColor(seg, seg.answer.labels[f]));
      else viewer.showSegmentScene(true);
    } else if (mode === 'curvature') {
      const h = state.curvature;
      const r = state.curvatureRange;
      viewer.setVertexColors((v) => diverging(h[v] / r));
    } else {
      viewer.setPlainColors();
    }
  }

  function render(state) {
    if (state.geometry !== shown.geometry) {
      shown.geometry = state.geometry;
      if (!state.geometry) return;
      viewer.setMesh(state.geometry, { upAxis: state.upAxis, flat: state.flatShading, sharpEdges: state.sharp.edges, showEdges: state.edgesShown });
      Object.assign(shown, { upAxis: state.upAxis, flat: state.flatShading, edges: state.edgesShown, colors: '', segmentation: null, preview: null });
    }
    if (!state.geometry) return;
    if (state.upAxis !== shown.upAxis) viewer.setUpAxis((shown.upAxis = state.upAxis));
    if (state.flatShading !== shown.flat) viewer.setFlatShading((shown.flat = state.flatShading));
    if (state.edgesShown !== shown.edges) viewer.showEdges((shown.edges = state.edgesShown));
    if (state.segmentation !== shown.segmentation) {
      shown.segmentation = state.segmentation;
      showSegmentSurface(state.segmentation);
    }
    applyColors(state);
    if (state.sessionView !== shown.sessionView) {
      shown.sessionView = state.sessionView;
      if (state.sessionView) viewer.setViewState(state.sessionView);
      shown.orthographic = viewer.orthographic;
    }
    if (state.orthographic !== shown.orthographic && state.orthographic !== undefined) {
      viewer.setOrthographic(state.orthographic);
      shown.orthographic = state.orthographic;
    }
    if (state.tracePreview !== shown.preview) {
      shown.preview = state.tracePreview;
      viewer.setTracePreview(state.tracePreview?.points ?? null, state.tracePreview?.closed);
    }
    // Lines and markers: drawn again only when a line, its answer, the active line or the
    // selected or hovered key changed (not for messages, progress or a request sent).
    const lines = state.lines.map((l) => ({ ...l, stale: isStale(l, state.options) }));
    const signature = JSON.stringify([state.activeLineId, state.selectedKey, state.hoverKey, lines.map((l) => [l.id, l.keys, l.closed, l.stale, idOf(l.result)])]);
    if (signature === shown.lines && state.geometry === shown.linesGeometry) return;
    shown.lines = signature;
    shown.linesGeometry = state.geometry;
    viewer.selectedKey = state.selectedKey;
    viewer.hoverKey = state.hoverKey;
    viewer.setLines(lines, state.activeLineId);
  }

  store.subscribe(render);
  return { render: () => render(store.state) };
}
