// One click, one line: in trace mode a click on a ridge, valley or crease asks the server for
// the whole feature through it ({"keys": [v], "trace": true}), and hovering shows, faintly, the
// line that click would give. Previews are the trace alone (no snake: a few milliseconds on
// the server), debounced, the previous one cancelled as the pointer moves, and remembered per
// vertex so moving back and forth asks the server once.
// No DOM: the preview is state (`tracePreview`) the viewer's view draws; `api` is the HTTP API
// or a fake.
import { ApiError, withRetry } from './api.js';
import { addLineTo, showMessage } from './actions.js';
import { activeLine, isStale, keysAlongTrace } from './model.js';

// Pointer moves closer together than this (ms) ask for one preview, the last.
const HOVER_DEBOUNCE_MS = 40;
// Previews remembered (per vertex and options); the oldest is forgotten first.
const PREVIEW_CACHE_SIZE = 256;
const STOP_NAMES = {
  closed: 'closed',
  'feature-end': 'the feature fades',
  boundary: 'the boundary',
  junction: 'a junction of creases',
  'line-met': 'the line itself',
  'max-edges': 'the length limit',
};


// The request of a traced line from `vertex` with the page's options; a preview is the trace
// alone (refine false).
export function traceRequest(vertex, options, { preview = false } = {}) {
  const o = structuredClone(options);
  if (preview) o.refine = false;
  const body = { keys: [vertex], trace: true };
  if (Object.keys(o).length) body.options = o;
  return body;
}

export function describeTrace(trace, closed) {
  if (closed) return 'a closed loop';
  const [a, b] = trace.ends.map((e) => STOP_NAMES[e.reason] ?? e.reason);
  return a === b ? `both ends at ${a}` : `ends at ${a} and at ${b}`;
}

// The vertex where the active traced line stopped at a junction and `result` (a trace from a
// branch there) ends too; null when there is none.
function sharedJunction(line, result, options) {
  if (!line?.trace || !line.result?.trace || isStale(line, options) || result.closed || line.result.closed) return null;
  const stops = line.result.trace.ends.filter((e) => e.reason === 'junction').map((e) => e.vertex);
  return result.trace.ends.map((e) => e.vertex).find((v) => stops.includes(v)) ?? null;
}

export function createTracing(store, api, { now = () => performance.now() } = {}) {
  const state = store.state;
  const previews = new Map(); // cache key -> {result} or {error}
  const hover = { vertex: null, timer: 0, controller: null, since: 0 };

  const previewKey = (vertex) => `${state.mesh?.id}:${JSON.stringify(traceRequest(vertex, state.options, { preview: true }))}`;

  function remember(key, answer) {
    previews.delete(key);
    previews.set(key, answer);
    if (previews.size > PREVIEW_CACHE_SIZE) previews.delete(previews.keys().next().value);
  }

  const setPreview = (preview) =>
    store.update(null, (s) => {
      if (s.tracePreview === preview) return false;
      s.tracePreview = preview;
    });

  // The preview of a trace from `vertex`: {result} or {error} (a 422 when there is nothing to
  // trace there, which is remembered like a line). Other failures are not remembered.
  async function previewTrace(vertex, { signal } = {}) {
    const key = previewKey(vertex);
    if (previews.has(key)) return previews.get(key);
    store.update(null, (s) => void s.previewRequests++);
    try {
      const result = await api.detectFeatureLines(state.mesh.id, traceRequest(vertex, state.options, { preview: true }), { signal });
      remember(key, { result });
      return { result };
    } catch (e) {
      if (e instanceof ApiError && e.status === 422) {
        const answer = { error: e.message };
        remember(key, answer);
        return answer;
      }
      throw e;
    }
  }

  function clearPreview() {
    clearTimeout(hover.timer);
    hover.controller?.abort();
    hover.controller = null;
    hover.vertex = null;
    setPreview(null);
  }

  function drawPreview(answer) {
    const r = answer.result;
    setPreview(r ? { points: r.initial.points, closed: !!r.closed } : null);
    // From the pointer reaching the vertex to its preview drawn (the page's benchmark reads it).
    if (r) store.update(null, (s) => void (s.previewLatencyMs = now() - hover.since));
  }

  // The pointer is over `vertex` (null: off the mesh): after a short pause, the line a click
  // there would trace is drawn faintly.
  function hoverAt(vertex) {
    if (!state.traceMode || !state.mesh || vertex == null) return clearPreview();
    if (vertex === hover.vertex) return;
    clearTimeout(hover.timer);
    hover.controller?.abort();
    hover.vertex = vertex;
    hover.since = now();
    const cached = previews.get(previewKey(vertex));
    if (cached) return drawPreview(cached);
    setPreview(null);
    hover.timer = setTimeout(async () => {
      const controller = new AbortController();
      hover.controller = controller;
      try {
        const answer = await previewTrace(vertex, { signal: controller.signal });
        if (hover.vertex === vertex) drawPreview(answer);
      } catch {
        // cancelled by a newer move, or the server is busy: no preview is fine
      }
    }, HOVER_DEBOUNCE_MS);
  }

  // A second click on a branch beyond the junction where the active traced line stopped
  // continues that line along the branch: both traces become one keyed line through the junction.
  function extendThroughJunction(result) {
    const line = activeLine(state);
    const junction = sharedJunction(line, result, state.options);
    if (junction === null) return false;
    const before = keysAlongTrace(line.result);
    const after = keysAlongTrace(result);
    if (before[0] === junction) before.reverse();
    if (after[after.length - 1] === junction) after.reverse();
    store.update(`extend ${line.name} through the junction at vertex ${junction}`, () => {
      line.trace = false;
      line.closed = false;
      line.keys = [...before, ...after.slice(1)];
    });
    showMessage(store, `${line.name} goes on through the junction at vertex ${junction} along the branch clicked (now ${line.keys.length} keys).`);
    return true;
  }

  // A click in trace mode: the traced line becomes the active line when that one has no keys, a
  // new line otherwise. Nothing to trace there: a message, and no edit.
  async function traceClick(vertex) {
    store.update(null, (s) => void s.pendingTraces++);
    try {
      let answer;
      try {
        answer = await withRetry(() => previewTrace(vertex));
      } catch (e) {
        return showMessage(store, `Tracing from vertex ${vertex} failed: ${e.message}`, { error: true });
      }
      if (!answer.result) return showMessage(store, `Nothing to trace at vertex ${vertex}: ${answer.error}`, { error: true });
      if (extendThroughJunction(answer.result)) return;
      const reuse = activeLine(state)?.keys.length === 0 ? activeLine(state) : null;
      let line = reuse;
      store.update(`trace a line from vertex ${vertex}`, (s) => {
        line = reuse ?? addLineTo(s);
        line.keys = [vertex];
        line.trace = true;
        line.closed = false;
      });
      const r = answer.result;
      showMessage(store, `${line.name}: the ${r.trace.sign} through vertex ${vertex}, ${r.initial.vertices.length - (r.closed ? 0 : 1)} edges, ${describeTrace(r.trace, r.closed)}. Drag its key to trace from elsewhere; Shift+click adds keys to edit it by hand.`);
    } finally {
      store.update(null, (s) => void s.pendingTraces--);
    }
  }

  return { hoverAt, clearPreview, previewTrace, traceClick };
}
