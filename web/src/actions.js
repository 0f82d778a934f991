// What the user does to the page's state, as edits of the store (store.js): every edit of
// lines, keys and options is one undo step; selection, modes and messages are not. No DOM and
// no requests here: the lines' requests follow from the state (line_requests.js), and views
// draw it. Each action takes the store first; createActions binds them to one store.
import { activeLine, canUseVertex, isStale, keysAlongTrace, lineById, newLine } from './model.js';
import { rememberUpAxis } from './session.js';
import { num, vertexIdProblem } from './text.js';

const MAX_LINE_NAME = 80;

// ---- messages -----------------------------------------------------------------------------
export function showMessage(store, text, { error = false } = {}) {
  store.update(null, (s) => {
    s.message = text;
    s.messageIsError = error;
  });
}

// A request is tried again (api.js withRetry): the user is told why and when.
export function retryNotice(store, what, { error, attempt, delayS }) {
  store.update(null, (s) => void s.retryCount++);
  const why = error.isNetwork ? 'could not reach the server' : `the server is busy (HTTP ${error.status})`;
  showMessage(store, `${what}: ${why}; retrying in ${num(delayS, 2)} s (try ${attempt + 1}).`, { error: true });
}

// ---- history ----------------------------------------------------------------------------------
export function undo(store) {
  const label = store.undo();
  showMessage(store, label === null ? 'Nothing to undo.' : `Undid: ${label}.`);
}

export function redo(store) {
  const label = store.redo();
  showMessage(store, label === null ? 'Nothing to redo.' : `Redid: ${label}.`);
}

// ---- lines ------------------------------------------------------------------------------------
// A new line, made active; for use inside an update.
export function addLineTo(state) {
  const line = newLine(state.nextLineId++);
  state.lines.push(line);
  state.activeLineId = line.id;
  return line;
}

export function addLine(store) {
  // Lines belong to a mesh: without one there is nothing to add (and nothing to undo).
  if (!store.state.mesh) return showMessage(store, 'Open a mesh first: lines are drawn on a mesh.', { error: true });
  let line;
  store.update('new line', (s) => {
    line = addLineTo(s);
  });
  showMessage(store, `${line.name} is active: click the surface to place its keys.`);
}

// Names are the user's: any text, trimmed; an empty name keeps the old one.
export function renameLine(store, id, name) {
  const line = lineById(store.state, id);
  const wanted = String(name ?? '').trim().slice(0, MAX_LINE_NAME);
  if (!line || !wanted || wanted === line.name) return false;
  const old = line.name;
  store.update(`rename ${old} to ${wanted}`, () => {
    line.name = wanted;
  });
  showMessage(store, `Renamed ${old} to ${wanted}.`);
  return true;
}

// Renaming in place: the draft survives the list being drawn again (answers arriving).
export function startRenaming(store, id) {
  const line = lineById(store.state, id);
  if (line) store.update(null, (s) => void (s.renaming = { lineId: id, draft: line.name }));
}

export function editRenameDraft(store, draft) {
  store.update(null, (s) => {
    if (!s.renaming) return false;
    s.renaming.draft = draft;
  });
}

export function finishRenaming(store, keep) {
  const renaming = store.state.renaming;
  if (!renaming) return;
  store.update(null, (s) => void (s.renaming = null));
  if (keep) renameLine(store, renaming.lineId, renaming.draft);
}

export function deleteLine(store, id) {
  const line = lineById(store.state, id);
  if (!line) return;
  store.update(`delete ${line.name}`, (s) => {
    s.lines = s.lines.filter((l) => l.id !== id);
    if (s.lines.length === 0) addLineTo(s);
    if (!activeLine(s)) s.activeLineId = s.lines[s.lines.length - 1].id;
    s.selectedKey = null;
  });
  showMessage(store, `Deleted ${line.name}. Undo brings it back (Ctrl+Z).`);
}

export function setActiveLine(store, id) {
  store.update(null, (s) => {
    if (s.activeLineId === id) return false;
    s.activeLineId = id;
    s.selectedKey = null;
  });
}

function untrace(state, line) {
  if (!line.trace) return;
  const current = line.result && !isStale(line, state.options);
  line.trace = false;
  if (current) {
    line.keys = keysAlongTrace(line.result);
    line.closed = line.result.closed;
  }
}

// ---- keys -------------------------------------------------------------------------------------
export function addKey(store, vertex) {
  const line = activeLine(store.state);
  if (!line || !store.state.mesh) return false;
  if (line.keys.length && line.keys[line.keys.length - 1] === vertex && !line.trace) return false;
  return store.update(line.trace ? 'add a key to a traced line' : 'add key', (s) => {
    untrace(s, line);
    if (line.keys[line.keys.length - 1] !== vertex) line.keys.push(vertex);
    s.selectedKey = { lineId: line.id, keyIndex: line.keys.length - 1 };
  });
}

// Adds a key at a typed vertex id; returns the error text ('' when added).
export function addKeyById(store, text) {
  const { mesh } = store.state;
  if (!mesh) return 'open a mesh first';
  const line = activeLine(store.state);
  const problem = vertexIdProblem(text, mesh.vertexCount, line);
  if (problem) return problem;
  const vertex = Number(String(text).trim());
  addKey(store, vertex);
  showMessage(store, `Key ${line.keys.length} of ${line.name}: vertex ${vertex} (typed).`);
  return '';
}

// One step of a drag: not recorded (the whole drag is one undo step, store.record at its end).
export function moveKeyUnrecorded(store, line, index, vertex) {
  if (line.keys[index] === vertex || !canUseVertex(line, index, vertex)) return false;
  return store.update(null, () => {
    line.keys[index] = vertex;
  });
}

export function deleteKey(store, line, index) {
  const vertex = line.keys[index];
  store.update(`delete key ${index + 1} of ${line.name}`, (s) => {
    line.keys.splice(index, 1);
    s.selectedKey = null;
  });
  showMessage(store, `Deleted key ${index + 1} of ${line.name} (vertex ${vertex}). Undo brings it back (Ctrl+Z).`);
}

export function deleteSelectedKey(store) {
  const sel = store.state.selectedKey;
  const line = sel && lineById(store.state, sel.lineId);
  if (line && sel.keyIndex < line.keys.length) return deleteKey(store, line, sel.keyIndex);
  const active = activeLine(store.state);
  if (active?.keys.length) return deleteKey(store, active, active.keys.length - 1); // nothing selected: the last key
  showMessage(store, 'No key to delete.');
}

export function selectKey(store, key) {
  store.update(null, (s) => {
    if (key) s.activeLineId = key.lineId;
    s.selectedKey = key ? { lineId: key.lineId, keyIndex: key.keyIndex } : null;
  });
}

export function setHoverKey(store, key) {
  const same = (a, b) => (a && b ? a.lineId === b.lineId && a.keyIndex === b.keyIndex : a === b);
  store.update(null, (s) => {
    if (same(key, s.hoverKey)) return false;
    s.hoverKey = key;
  });
}

export function setClosed(store, closed) {
  const line = activeLine(store.state);
  if (!line) return showMessage(store, 'Open a mesh first: there is no line to close.', { error: true });
  if (line.closed === closed) return;
  store.update(closed ? `close ${line.name}` : `open ${line.name}`, (s) => {
    untrace(s, line);
    line.closed = closed;
  });
  const few = closed && line.keys.length < 3 ? ` (a loop needs at least 3 keys; it has ${line.keys.length})` : '';
  showMessage(store, closed ? `Closed ${line.name} into a loop: its last key joins the first${few}.` : `Opened ${line.name}'s loop: its ends are free again.`);
}

export function clearKeys(store) {
  const line = activeLine(store.state);
  if (!line || !line.keys.length) return;
  store.update(`clear the keys of ${line.name}`, (s) => {
    line.keys = [];
    s.selectedKey = null;
  });
  showMessage(store, `Cleared the keys of ${line.name}. Undo brings them back (Ctrl+Z).`);
}

// ---- options ----------------------------------------------------------------------------------
// The options as read from the form: an undo step when they are valid and differ.
export function setOptions(store, options, problems = []) {
  store.update(null, (s) => {
    s.optionsValid = problems.length === 0;
    s.optionsProblems = problems;
  });
  if (problems.length || JSON.stringify(options) === JSON.stringify(store.state.options)) return;
  store.update('change options', (s) => {
    s.options = options;
  });
}

// ---- modes and view -------------------------------------------------------------------------------
export function setSnapping(store, on) {
  store.update(null, (s) => void (s.snapping = on));
  showMessage(store, on ? 'Snapping on: a click places the key on the strongest feature vertex nearby.' : 'Snapping off: a click places the key on the vertex clicked.');
}

export function setTraceMode(store, on) {
  store.update(null, (s) => {
    s.traceMode = on;
    if (!on) s.tracePreview = null;
  });
  showMessage(
    store,
    on
      ? 'Trace mode: a click on a ridge, valley or crease gives the whole feature line (hover to see it first); Shift+click adds a key.'
      : 'Key mode: a click adds a key to the active line.',
  );
}

export function setUpAxis(store, axis) {
  const { mesh } = store.state;
  if (!mesh || (axis !== 'y' && axis !== 'z')) return;
  rememberUpAxis(mesh.name, axis);
  store.update(null, (s) => void (s.upAxis = axis));
}

export function setColorChoice(store, choice) {
  store.update(null, (s) => void (s.colorChoice = choice));
}

export function setFlatShading(store, on) {
  store.update(null, (s) => void (s.flatShading = on));
}

export function setEdgesShown(store, on = !store.state.edgesShown) {
  store.update(null, (s) => void (s.edgesShown = on));
}

export function setOrthographic(store, on) {
  store.update(null, (s) => void (s.orthographic = on));
  showMessage(store, on ? 'Orthographic projection: sizes no longer shrink with distance (O switches back).' : 'Perspective projection (O switches to orthographic).');
}

// ---- sessions ---------------------------------------------------------------------------------
// The lines, options, up axis and camera of a session file, as one undo step.
export function applySession(store, doc) {
  store.update(`load session (${doc.lines.length} lines)`, (s) => {
    s.lines = [];
    s.nextLineId = 1;
    for (const l of doc.lines) {
      const line = addLineTo(s);
      if (l.name) line.name = l.name;
      line.keys = [...l.keys];
      line.closed = !!l.closed;
      line.trace = l.trace === true;
    }
    if (!s.lines.length) addLineTo(s);
    s.activeLineId = s.lines[0].id;
    s.options = structuredClone(doc.options ?? {});
    s.optionsValid = true;
    s.optionsProblems = [];
    s.selectedKey = null;
  });
  if (doc.up_axis === 'y' || doc.up_axis === 'z') setUpAxis(store, doc.up_axis);
  if (doc.view)
    store.update(null, (s) => {
      s.sessionView = { ...doc.view };
      s.orthographic = !!doc.view.orthographic;
    });
  showMessage(store, `Loaded the session: ${doc.lines.length} line(s) on ${store.state.mesh.name}.`);
}

// Every action bound to one store.
export function createActions(store) {
  const bound = {};
  const all = {
    showMessage, undo, redo, addLine, renameLine, startRenaming, editRenameDraft, finishRenaming, deleteLine, setActiveLine,
    addKey, addKeyById, moveKeyUnrecorded, deleteKey, deleteSelectedKey, selectKey, setHoverKey, setClosed, clearKeys,
    setOptions, setSnapping, setTraceMode, setUpAxis, setColorChoice, setFlatShading, setEdgesShown, setOrthographic, applySession,
  };
  for (const [name, fn] of Object.entries(all)) bound[name] = (...args) => fn(store, ...args);
  return bound;
}
