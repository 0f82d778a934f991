// Lines and their keys as edits (every one undoable), and the requests that compute them: one
// in flight, the latest state sent when it returns, answers cached by request.
import * as api from './api.js';
import { $, history, num, resultCache, serverText, showMessage, state } from './app.js';
import { recoverMesh } from './open_mesh.js';
import { writeOptionsForm } from './options_panel.js';
import { vertexIdProblem } from './text.js';
import { refresh } from './panel.js';

const MAX_LINE_NAME = 80;
// Answers kept for undo and redo (by request).
const RESULT_CACHE_SIZE = 300;
export let idleWaiters = [];

// ---- edits, history -----------------------------------------------------------------------------
// What undo restores: the lines with their keys, which one is active, and the options.
export function snapshot() {
  return {
    lines: state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed, trace: l.trace })),
    activeLineId: state.activeLineId,
    nextLineId: state.nextLineId,
    options: structuredClone(state.options),
  };
}

export function restore(snap) {
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
    writeOptionsForm(state.options);
  }
}

// Every edit goes through here: `mutate` changes the state (returns false when nothing
// changed), and the state before is kept for undo.
export function edit(label, mutate) {
  const before = snapshot();
  if (mutate() === false) return false;
  history.record(before, label);
  afterEdit();
  return true;
}

export function afterEdit() {
  refresh();
  pump();
}

export function undo() {
  const entry = history.undo(snapshot());
  if (!entry) return showMessage('Nothing to undo.');
  restore(entry.snapshot);
  showMessage(`Undid: ${entry.label}.`);
  afterEdit();
}

export function redo() {
  const entry = history.redo(snapshot());
  if (!entry) return showMessage('Nothing to redo.');
  restore(entry.snapshot);
  showMessage(`Redid: ${entry.label}.`);
  afterEdit();
}

export function renderHistoryButtons() {
  $('undo').disabled = !history.canUndo;
  $('redo').disabled = !history.canRedo;
  $('undo').title = history.canUndo ? `Undo: ${history.undoLabel} (Ctrl+Z)` : 'Nothing to undo (Ctrl+Z)';
  $('redo').title = history.canRedo ? `Redo: ${history.redoLabel} (Ctrl+Shift+Z)` : 'Nothing to redo (Ctrl+Shift+Z)';
}

// ---- lines ------------------------------------------------------------------------------------
export function activeLine() {
  return state.lines.find((l) => l.id === state.activeLineId) || null;
}

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

export function addLineUnrecorded() {
  const line = newLine(state.nextLineId++);
  state.lines.push(line);
  state.activeLineId = line.id;
  return line;
}

export function addLine() {
  // Lines belong to a mesh: without one there is nothing to add (and nothing to undo).
  if (!state.mesh) return showMessage('Open a mesh first: lines are drawn on a mesh.', { error: true });
  edit('new line', () => {
    addLineUnrecorded();
  });
  showMessage(`${activeLine().name} is active: click the surface to place its keys.`);
}

// Names are the user's: any text, trimmed; an empty name keeps the old one.
export function renameLine(id, name) {
  const line = state.lines.find((l) => l.id === id);
  const wanted = String(name ?? '').trim().slice(0, MAX_LINE_NAME);
  if (!line || !wanted || wanted === line.name) return false;
  const old = line.name;
  edit(`rename ${old} to ${wanted}`, () => {
    line.name = wanted;
  });
  showMessage(`Renamed ${old} to ${wanted}.`);
  return true;
}

export function deleteLine(id) {
  const line = state.lines.find((l) => l.id === id);
  if (!line) return;
  edit(`delete ${line.name}`, () => {
    state.lines = state.lines.filter((l) => l.id !== id);
    if (state.lines.length === 0) addLineUnrecorded();
    if (!activeLine()) state.activeLineId = state.lines[state.lines.length - 1].id;
    state.selectedKey = null;
  });
  showMessage(`Deleted ${line.name}. Undo brings it back (Ctrl+Z).`);
}

export function setActiveLine(id) {
  if (state.activeLineId === id) return;
  state.activeLineId = id;
  state.selectedKey = null;
  refresh();
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

function untrace(line) {
  if (!line.trace) return;
  const current = line.result && !isStale(line);
  line.trace = false;
  if (current) {
    line.keys = keysAlongTrace(line.result);
    line.closed = line.result.closed;
  }
}

export function addKey(vertex) {
  const line = activeLine();
  if (!line || !state.mesh) return false;
  if (line.keys.length && line.keys[line.keys.length - 1] === vertex && !line.trace) return false;
  const added = edit(line.trace ? 'add a key to a traced line' : 'add key', () => {
    untrace(line);
    if (line.keys[line.keys.length - 1] !== vertex) line.keys.push(vertex);
    state.selectedKey = { lineId: line.id, keyIndex: line.keys.length - 1 };
  });
  return added;
}

// Adds a key at a typed vertex id; returns the error text ('' when added).
export function addKeyById(text) {
  if (!state.mesh) return 'open a mesh first';
  const line = activeLine();
  const problem = vertexIdProblem(text, state.mesh.vertexCount, line);
  if (problem) return problem;
  const vertex = Number(String(text).trim());
  addKey(vertex);
  showMessage(`Key ${line.keys.length} of ${line.name}: vertex ${vertex} (typed).`);
  return '';
}

export function moveKeyUnrecorded(line, index, vertex) {
  if (line.keys[index] === vertex || !canUseVertex(line, index, vertex)) return false;
  line.keys[index] = vertex;
  afterEdit();
  return true;
}

export function deleteKey(line, index) {
  const vertex = line.keys[index];
  edit(`delete key ${index + 1} of ${line.name}`, () => {
    line.keys.splice(index, 1);
    state.selectedKey = null;
  });
  showMessage(`Deleted key ${index + 1} of ${line.name} (vertex ${vertex}). Undo brings it back (Ctrl+Z).`);
}

export function deleteSelectedKey() {
  const sel = state.selectedKey;
  const line = sel && state.lines.find((l) => l.id === sel.lineId);
  if (line && sel.keyIndex < line.keys.length) return deleteKey(line, sel.keyIndex);
  const active = activeLine();
  if (active?.keys.length) return deleteKey(active, active.keys.length - 1); // nothing selected: the last key
  showMessage('No key to delete.');
}

export function setClosed(closed) {
  const line = activeLine();
  if (!line) return showMessage('Open a mesh first: there is no line to close.', { error: true });
  if (line.closed === closed) return;
  edit(closed ? `close ${line.name}` : `open ${line.name}`, () => {
    untrace(line);
    line.closed = closed;
  });
  const few = closed && line.keys.length < 3 ? ` (a loop needs at least 3 keys; it has ${line.keys.length})` : '';
  showMessage(closed ? `Closed ${line.name} into a loop: its last key joins the first${few}.` : `Opened ${line.name}'s loop: its ends are free again.`);
}

export function clearKeys() {
  const line = activeLine();
  if (!line || !line.keys.length) return;
  edit(`clear the keys of ${line.name}`, () => {
    line.keys = [];
    state.selectedKey = null;
  });
  showMessage(`Cleared the keys of ${line.name}. Undo brings them back (Ctrl+Z).`);
}

export function lineRequest(line) {
  const body = line.trace ? { keys: [...line.keys], trace: true } : { keys: [...line.keys], closed: line.closed };
  if (Object.keys(state.options).length) body.options = structuredClone(state.options);
  return body;
}

export const requestKey = (line) => JSON.stringify(lineRequest(line));

// Whether the drawn result is for other keys or options than the line has now.
export function isStale(line) {
  return !!line.result && line.resultKey !== requestKey(line);
}

export function needsRequest(line) {
  if (keysProblem(line) || !state.optionsValid) return false;
  const key = requestKey(line);
  return line.resultKey !== key && line.failedKey !== key;
}

export function cacheResult(key, result) {
  resultCache.delete(key);
  resultCache.set(key, result);
  if (resultCache.size > RESULT_CACHE_SIZE) resultCache.delete(resultCache.keys().next().value);
}

// Lines whose request is answered in the cache (undo, redo) take it at once.
export function takeCachedResults() {
  for (const line of state.lines) {
    if (keysProblem(line)) {
      line.result = null; // fewer than two keys: nothing to be out of date against
      line.resultKey = null;
      line.error = '';
      continue;
    }
    const key = requestKey(line);
    if (line.resultKey !== key && resultCache.has(key)) {
      line.result = resultCache.get(key);
      if (line.id === state.activeLineId) state.lastResult = line.result;
      line.resultKey = key;
      line.error = '';
      line.failedKey = null;
    }
  }
}

// Sends the next pending line: at most one request in flight; each request carries the line's
// latest state, and a change made meanwhile is sent when the running request returns.
export async function pump() {
  if (state.inFlight || !state.mesh || state.loading || state.recovering) return settleIdle();
  takeCachedResults();
  const line = [activeLine(), ...state.lines].find((l) => l && needsRequest(l));
  if (!line) {
    refresh();
    return settleIdle();
  }
  const meshId = state.mesh.id;
  const body = lineRequest(line);
  const key = JSON.stringify(body);
  state.inFlight = { line, key };
  state.requestCount++;
  $('busy').hidden = false;
  let meshGone = null;
  try {
    const result = await api.withRetry(() => api.detectFeatureLines(meshId, body), {
      onRetry: (r) => retryNotice(`Detecting ${line.name}`, r),
    });
    if (state.mesh?.id === meshId) {
      cacheResult(key, result);
      line.result = result;
      line.resultKey = key;
      line.error = '';
      line.failedKey = null;
      state.lastResult = result;
      if (state.messageIsError && /retry|could not reach|busy/i.test(state.message)) showMessage(`${line.name} detected.`);
    }
  } catch (e) {
    if (state.mesh?.id === meshId) {
      if (e instanceof api.ApiError && e.isMeshGone) meshGone = e;
      else {
        line.error = serverText(e);
        line.failedKey = key; // the last good result stays drawn, marked out of date
      }
    }
  } finally {
    state.responseCount++;
    state.inFlight = null;
    $('busy').hidden = true;
    refresh();
  }
  if (meshGone) await recoverMesh(meshGone.message);
  else pump();
}

export function retryNotice(what, { error, attempt, delayS }) {
  state.retryCount++;
  const why = error.isNetwork ? 'could not reach the server' : `the server is busy (HTTP ${error.status})`;
  showMessage(`${what}: ${why}; retrying in ${num(delayS, 2)} s (try ${attempt + 1}).`, { error: true });
}

export function isIdle() {
  return !state.inFlight && !state.loading && !state.recovering && !state.pendingTraces && !state.lines.some(needsRequest);
}

export function settleIdle() {
  if (!isIdle()) return;
  const waiters = idleWaiters;
  idleWaiters = [];
  for (const w of waiters) w();
}
