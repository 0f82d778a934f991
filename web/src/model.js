// The page's state and what can be asked of it, without a browser: the initial state, the
// lines and their keys, the requests they make, and the part of the state undo restores.
import { createStore } from './store.js';

export function initialState({ search = '' } = {}) {
  return {
    mesh: null, // {id, name, description, vertexCount, faceCount}
    geometry: null, // the mesh as arrays {positions, normals, index, vertexCount, faceCount, creaseEdges}
    source: null, // {name, bytes, format}: the file the mesh came from, to upload again if the server forgets it
    curvature: null, // Float32Array per vertex (the server's signed field)
    curvatureRange: 0,
    adjacency: null,
    sharp: null, // {edges, creaseCount, flatShare, onBoundary}: the server's creases and the boundary
    cad: false,
    upAxis: 'y',
    flatShading: false,
    edgesShown: false,
    orthographic: false,
    lines: [],
    activeLineId: 0,
    nextLineId: 1,
    options: {},
    optionsValid: true,
    optionsProblems: [],
    inFlight: null, // {line, key}: the request running (at most one at a time)
    requestCount: 0,
    responseCount: 0,
    retryCount: 0,
    lastResult: null,
    segmentation: null, // {request, linesKey, answer, faceColored, surfaceGlb}
    decomposing: false,
    decomposeStatus: '', // what the Decompose section says (running, the result, a failure)
    decomposeMessage: '', // the last decomposition's result or failure
    decomposeError: false,
    colorChoice: 'plain', // what is asked for: plain | curvature | segments
    message: '',
    messageIsError: false,
    samples: [],
    loading: false,
    loadingName: '',
    recovering: false,
    progress: null, // {fraction (null: unknown), text} while a mesh opens
    uploadProgress: null, // the last upload progress event {loaded, total}
    download: null, // {received, total, wireBytes, encoding} of the last mesh download
    openTimings: null,
    snapping: true,
    // A click traces the whole feature (trace.js); ?trace=0 opens the page in key mode.
    traceMode: new URLSearchParams(search).get('trace') !== '0',
    pendingTraces: 0,
    tracePreview: null, // {points, closed}: the line a click would trace, drawn faintly
    previewRequests: 0,
    previewLatencyMs: null,
    selectedKey: null, // {lineId, keyIndex}
    hoverKey: null, // {lineId, keyIndex}: the key under the pointer
    renaming: null, // {lineId, draft}: a line's name being edited
    pendingSession: null, // a loaded session waiting for its mesh file
    sessionView: null, // the camera of a loaded session, for the view to take
  };
}

// ---- what undo restores: the lines with their keys, which one is active, and the options ----
export function snapshot(state) {
  return {
    lines: state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed, trace: l.trace })),
    activeLineId: state.activeLineId,
    nextLineId: state.nextLineId,
    options: structuredClone(state.options),
  };
}

export function restore(state, snap) {
  const old = new Map(state.lines.map((l) => [l.id, l]));
  state.lines = snap.lines.map((s) => {
    const line = newLine(s.id, s.name);
    line.keys = [...s.keys];
    line.closed = s.closed;
    line.trace = !!s.trace;
    const before = old.get(s.id);
    if (before?.result) {
      line.result = before.result; // drawn as out of date until the answer for these keys is in
      line.resultKey = before.resultKey;
    }
    return line;
  });
  state.activeLineId = snap.activeLineId;
  state.nextLineId = snap.nextLineId;
  state.selectedKey = null;
  if (JSON.stringify(snap.options) !== JSON.stringify(state.options)) {
    state.options = structuredClone(snap.options);
    state.optionsValid = true;
    state.optionsProblems = [];
  }
}

export function createPageStore(options = {}) {
  return createStore(initialState(options), { snapshot, restore });
}

// ---- lines ------------------------------------------------------------------------------------
export function newLine(id, name) {
  return {
    id,
    name: name ?? `Line ${id}`,
    keys: [],
    closed: false,
    trace: false, // one key, the whole feature through it (trace.js)
    result: null, // the last answer (possibly for earlier keys: then drawn as out of date)
    resultKey: null, // the request the result answers
    error: '',
    failedKey: null, // the request that failed (not sent again until the line changes)
  };
}

export function activeLine(state) {
  return state.lines.find((l) => l.id === state.activeLineId) || null;
}

export function lineById(state, id) {
  return state.lines.find((l) => l.id === id) || null;
}

export function hasWork(state) {
  return state.lines.some((l) => l.keys.length > 0);
}

// Whether keys can go to the server: at least two, consecutive ones distinct (1-based); a
// traced line has exactly one.
export function keysProblem(line) {
  if (line.trace) return line.keys.length === 1 ? '' : 'a traced line has one key';
  if (line.keys.length < 2) return 'place at least two keys';
  for (let i = 1; i < line.keys.length; ++i) if (line.keys[i] === line.keys[i - 1]) return `keys ${i} and ${i + 1} are the same vertex`;
  return '';
}

export function canUseVertex(line, index, v) {
  const n = line.keys.length;
  const prev = index > 0 ? line.keys[index - 1] : line.closed && n > 2 ? line.keys[n - 1] : undefined;
  const next = index < n - 1 ? line.keys[index + 1] : line.closed && n > 2 ? line.keys[0] : undefined;
  return v !== prev && v !== next;
}

// A traced line becomes an ordinary keyed line (to add keys by hand): its ends, and vertices
// along it so the keyed line keeps the traced route (a loop needs three keys).
export function keysAlongTrace(result) {
  const v = result.initial.vertices;
  const n = v.length;
  const picks = result.closed ? [0, Math.floor(n / 3), Math.floor((2 * n) / 3)] : [0, Math.floor(n / 2), n - 1];
  return picks.map((i) => v[i]).filter((k, i, all) => i === 0 || k !== all[i - 1]);
}

export function lineRequest(line, options) {
  const body = line.trace ? { keys: [...line.keys], trace: true } : { keys: [...line.keys], closed: line.closed };
  if (Object.keys(options).length) body.options = structuredClone(options);
  return body;
}

export const requestKey = (line, options) => JSON.stringify(lineRequest(line, options));

// Whether the drawn result is for other keys or options than the line has now.
export function isStale(line, options) {
  return !!line.result && line.resultKey !== requestKey(line, options);
}

export function needsRequest(state, line) {
  if (keysProblem(line) || !state.optionsValid) return false;
  const key = requestKey(line, state.options);
  return line.resultKey !== key && line.failedKey !== key;
}

// ---- decomposition ----------------------------------------------------------------------------
export function readyLines(state) {
  return state.lines.filter((l) => !keysProblem(l)).map((l) => lineRequest(l, state.options));
}

// The segments came from the lines as they were when Decompose ran.
export function segmentationStale(state) {
  const seg = state.segmentation;
  return !!seg && seg.linesKey !== JSON.stringify(readyLines(state));
}

// The server's colour of a segment label (its answer carries the one palette, the same as in
// its GLB); grey for an answer without colours.
export function segmentColor(seg, label) {
  return seg.answer.segments[label]?.color ?? [0.5, 0.5, 0.5];
}

// What the colours show: the choice when it can be shown, else plain.
export function colorMode(state) {
  const seg = state.segmentation;
  if (state.colorChoice === 'segments' && seg && (seg.faceColored || seg.sceneLoaded)) return 'segments';
  if (state.colorChoice === 'curvature' && state.curvature) return 'curvature';
  return 'plain';
}
