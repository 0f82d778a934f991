// Decomposition along the lines as an effect on the store: one request per Decompose, the
// lines whose answers are current sent as computed lines (not detected again), the answer kept
// with the lines it is for (to tell when it is out of date). No DOM: `api` is the HTTP API or a
// fake; the views draw the segments and their colours from the state.
import { ApiError, withRetry } from './api.js';
import { retryNotice, showMessage } from './actions.js';
import { isStale, keysProblem, lineRequest } from './model.js';
import { errorText, serverText } from './text.js';

// A line for the decomposition: the line the page already has when its answer is current
// (computed once: the server only cuts along it), else its request (the server detects it).
export function segmentationItem(line, options) {
  const refined = line.result?.refined;
  if (!isStale(line, options) && Array.isArray(refined?.faces) && Array.isArray(refined?.barycentric))
    return { keys: [...line.keys], closed: line.closed, refined: { faces: refined.faces, barycentric: refined.barycentric } };
  return lineRequest(line, options);
}

export function createSegmentation(store, api) {
  const state = store.state;
  // The panel's status; `result` also makes it the decomposition's message (an answer or a failure).
  const setStatus = (text, { error = false, result = false } = {}) =>
    store.update(null, (s) => {
      s.decomposeStatus = text;
      s.decomposeError = error;
      if (result) s.decomposeMessage = text;
    });

  // mode: 'snap' or 'remesh'.
  async function decompose(mode) {
    if (!state.mesh) return;
    const ready = state.lines.filter((l) => !keysProblem(l));
    const lines = ready.map((l) => segmentationItem(l, state.options));
    if (!lines.length) {
      setStatus('Place a line with at least two keys first.');
      showMessage(store, `Decompose: ${state.decomposeStatus}`, { error: true });
      return;
    }
    // Slivers left where a line doubles back to a pinned key join their neighbour.
    const request = { lines, mode, merge_tiny_segments: true };
    const meshId = state.mesh.id;
    const linesKey = JSON.stringify(ready.map((l) => lineRequest(l, state.options)));
    setStatus('Decomposing…');
    showMessage(store, `Decomposing along ${lines.length} line(s)…`);
    store.update(null, (s) => void (s.decomposing = true));
    try {
      const answer = await withRetry(() => api.segmentation(meshId, request), { onRetry: (r) => retryNotice(store, 'Decomposing', r) });
      if (state.mesh?.id !== meshId) return;
      await applySegmentation(request, answer, linesKey);
    } catch (e) {
      let text = `Decomposition failed: ${serverText(e)}`;
      if (e instanceof ApiError && (e.status === 404 || e.status === 405)) {
        // A 404 for the route (not for the mesh) means the server has no decomposition.
        let meshThere = true;
        try {
          await api.describeMesh(meshId);
        } catch {
          meshThere = false;
        }
        if (meshThere) text = 'Decomposition not available on this server.';
      }
      setStatus(text, { error: true, result: true });
      showMessage(store, text, { error: true });
    } finally {
      store.update(null, (s) => void (s.decomposing = false));
    }
  }

  // linesKey: the line requests the answer is for (to tell when it is out of date).
  async function applySegmentation(request, answer, linesKey) {
    if (!answer || !Array.isArray(answer.labels) || !Array.isArray(answer.segments))
      throw new ApiError(0, '', 'the server answered the decomposition in an unknown shape');
    const faceColored = answer.labels.length === state.mesh.faceCount;
    const seg = { request, linesKey, answer, faceColored, sceneLoaded: false, surfaceGlb: null };
    const parts = [`${answer.segments.length} segment(s)`];
    if (!faceColored) {
      // Remesh mode: the labels are for the remeshed surface, which the answer carries; an
      // answer without it (an older server) is asked for once more as GLB.
      const remeshed = answer.remeshed;
      if (Array.isArray(remeshed?.vertices) && Array.isArray(remeshed?.faces)) seg.sceneLoaded = true;
      else {
        try {
          seg.surfaceGlb = await (await api.segmentationGlb(state.mesh.id, request)).arrayBuffer();
          seg.sceneLoaded = true;
        } catch (e) {
          parts.push(`the labels are for a remeshed surface of ${answer.labels.length} faces; its colours cannot be shown (${errorText(e)})`);
        }
      }
    }
    if (answer.warnings?.length) parts.push(...answer.warnings.map((w) => `warning: ${serverText(w)}`));
    store.update(null, (s) => {
      s.segmentation = seg;
      s.decomposeMessage = s.decomposeStatus = parts.join('\n');
      s.decomposeError = false;
      s.colorChoice = faceColored || seg.sceneLoaded ? 'segments' : s.colorChoice === 'segments' ? 'plain' : s.colorChoice;
    });
    // The panel's copy may be scrolled out of view; the status line is always in view.
    showMessage(store, `Decomposed into ${parts.join('\n')}`);
  }

  return { decompose, applySegmentation };
}
