// What every part of the page shares: the state, the 3D view, the undo history and the answer
// cache, messages and the in-page confirmation. The parts import these; main.js wires them.
import * as api from './api.js';
import { History } from './history.js';
import { oneBasedNumbers } from './text.js';
import { Viewer } from './viewer.js';

export const $ = (id) => document.getElementById(id);


export const state = {
  mesh: null, // {id, name, description, vertexCount, faceCount}
  source: null, // {name, bytes, format}: the file the mesh came from, to upload again if the server forgets it
  curvature: null, // Float32Array per vertex (the server's signed field)
  curvatureRange: 0,
  adjacency: null,
  sharp: null, // {edges, creaseCount, flatShare}
  cad: false,
  upAxis: 'y',
  lines: [],
  activeLineId: 0,
  nextLineId: 1,
  options: {},
  optionsValid: true,
  inFlight: null, // {line, key}: the request running (at most one at a time)
  requestCount: 0,
  responseCount: 0,
  retryCount: 0,
  lastResult: null,
  segmentation: null, // {request, linesKey, answer, faceColored, sceneLoaded}
  decomposeMessage: '',
  message: '',
  messageIsError: false,
  samples: [],
  loading: false,
  loadingName: '',
  recovering: false,
  colorMode: 'plain', // plain | curvature | segments
  uploadProgress: null, // the last upload progress event {loaded, total}
  download: null, // {received, total, wireBytes, encoding} of the last mesh download
  snapping: true,
  // A click traces the whole feature (trace.js); ?trace=0 opens the page in key mode.
  traceMode: new URLSearchParams(globalThis.location?.search ?? '').get('trace') !== '0',
  selectedKey: null, // {lineId, keyIndex}
  pendingSession: null, // a loaded session waiting for its mesh file
  lastClickAdd: null, // {time, before}: the last key placed by a click (a double-click takes it back)
};

export const viewer = new Viewer($('canvas-host'));
export const history = new History();
export const resultCache = new Map(); // request key -> FeatureLine answer, for undo/redo without the server


// ---- messages ---------------------------------------------------------------------------
export function showMessage(text, { error = false } = {}) {
  state.message = text;
  state.messageIsError = error;
  const el = $('message');
  el.textContent = text;
  el.classList.toggle('error', error);
}

export function errorText(e) {
  return e instanceof api.ApiError ? e.toString() : e?.message ?? String(e);
}

// Server text about lines, keys and segments, counted from 1 as the page counts.
export function serverText(e) {
  return oneBasedNumbers(typeof e === 'string' ? e : errorText(e));
}

export function formatBytes(n) {
  if (n < 1024) return `${n} B`;
  if (n < 1024 * 1024) return `${(n / 1024).toFixed(1)} KiB`;
  return `${(n / 1024 / 1024).toFixed(1)} MiB`;
}

export function num(x, digits = 4) {
  if (typeof x !== 'number' || !Number.isFinite(x)) return String(x);
  if (x !== 0 && (Math.abs(x) >= 1e5 || Math.abs(x) < 1e-3)) return x.toExponential(2);
  return Number(x.toPrecision(digits)).toString();
}

// ---- a small in-page confirmation (window.confirm blocks and cannot be styled or tested) ----
export function confirmAction(text, okLabel) {
  const dialog = $('confirm');
  $('confirm-text').textContent = text;
  $('confirm-ok').textContent = okLabel;
  dialog.hidden = false;
  $('confirm-ok').focus();
  return new Promise((resolve) => {
    const done = (answer) => {
      dialog.hidden = true;
      $('confirm-ok').onclick = $('confirm-cancel').onclick = null;
      confirmResolver = null;
      resolve(answer);
    };
    confirmResolver = done;
    $('confirm-ok').onclick = () => done(true);
    $('confirm-cancel').onclick = () => done(false);
  });
}
export let confirmResolver = null;

export function hasWork() {
  return state.lines.some((l) => l.keys.length > 0);
}
