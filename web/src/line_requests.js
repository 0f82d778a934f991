// The lines' requests, as an effect of the state: whenever the store changes, the next line
// whose keys or options have no answer yet is sent, one request in flight; a change made
// meanwhile is sent when the running request returns. Answers are cached by request, so undo
// and redo take them without the server. No DOM: `api` is the HTTP API (api.js) or a fake.
import { ApiError, withRetry } from './api.js';
import { retryNotice, showMessage } from './actions.js';
import { activeLine, keysProblem, needsRequest, requestKey } from './model.js';
import { serverText } from './text.js';

// Answers kept for undo and redo (by request).
const RESULT_CACHE_SIZE = 300;

// onMeshGone(reason): the server forgot the mesh (mesh_effects.js uploads it again).
export function createLineRequests(store, api, { onMeshGone = async () => {} } = {}) {
  const cache = new Map(); // request key -> FeatureLine answer
  let idleWaiters = [];

  function cacheResult(key, result) {
    cache.delete(key);
    cache.set(key, result);
    if (cache.size > RESULT_CACHE_SIZE) cache.delete(cache.keys().next().value);
  }

  // Lines whose request is answered in the cache (undo, redo) take it at once; lines with too
  // few keys drop theirs. Returns false when nothing changed.
  function takeCachedResults(state) {
    let changed = false;
    for (const line of state.lines) {
      if (keysProblem(line)) {
        if (line.result || line.resultKey || line.error) changed = true;
        line.result = null; // fewer than two keys: nothing to be out of date against
        line.resultKey = null;
        line.error = '';
        continue;
      }
      const key = requestKey(line, state.options);
      if (line.resultKey !== key && cache.has(key)) {
        line.result = cache.get(key);
        if (line.id === state.activeLineId) state.lastResult = line.result;
        line.resultKey = key;
        line.error = '';
        line.failedKey = null;
        changed = true;
      }
    }
    return changed;
  }

  function isIdle() {
    const s = store.state;
    return !s.inFlight && !s.loading && !s.recovering && !s.pendingTraces && !s.lines.some((l) => needsRequest(s, l));
  }

  function settleIdle() {
    if (!isIdle()) return;
    const waiters = idleWaiters;
    idleWaiters = [];
    for (const w of waiters) w();
  }

  // Sends the next pending line.
  async function pump() {
    const state = store.state;
    if (state.inFlight || !state.mesh || state.loading || state.recovering) return settleIdle();
    store.update(null, takeCachedResults);
    const line = [activeLine(state), ...state.lines].find((l) => l && needsRequest(state, l));
    if (!line) return settleIdle();
    const meshId = state.mesh.id;
    const key = requestKey(line, state.options);
    const body = JSON.parse(key);
    store.update(null, (s) => {
      s.inFlight = { line, key };
      s.requestCount++;
    });
    let meshGone = null;
    let answer = null;
    try {
      answer = { result: await withRetry(() => api.detectFeatureLines(meshId, body), { onRetry: (r) => retryNotice(store, `Detecting ${line.name}`, r) }) };
    } catch (e) {
      answer = { error: e };
    }
    store.update(null, (s) => {
      s.responseCount++;
      s.inFlight = null;
      if (s.mesh?.id !== meshId) return; // another mesh by now: the answer is for nothing shown
      if (answer.result) {
        cacheResult(key, answer.result);
        line.result = answer.result;
        line.resultKey = key;
        line.error = '';
        line.failedKey = null;
        s.lastResult = answer.result;
      } else if (answer.error instanceof ApiError && answer.error.isMeshGone) {
        meshGone = answer.error;
      } else {
        line.error = serverText(answer.error);
        line.failedKey = key; // the last good result stays drawn, marked out of date
      }
    });
    const { message, messageIsError } = store.state;
    if (answer.result && messageIsError && /retry|could not reach|busy/i.test(message)) showMessage(store, `${line.name} detected.`);
    if (meshGone) await onMeshGone(meshGone.message);
    else pump();
  }

  store.subscribe(() => pump());

  return {
    pump,
    settleIdle,
    isIdle,
    // Answers of another mesh mean other vertices.
    clearCache: () => cache.clear(),
    // Resolves when no request is running or waiting.
    idle() {
      return new Promise((resolve) => {
        idleWaiters.push(resolve);
        settleIdle();
      });
    },
  };
}
