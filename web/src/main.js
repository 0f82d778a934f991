// The Featureline page: open a mesh, place keys, see the initial and refined lines,
// tune options, decompose the mesh along the lines, download the results; undo and redo every
// edit, save and load the work as a session file.
import * as api from './api.js';
import { curvatureRange, diverging, divergingCss, rgbCss } from './colors.js';
import { guessUpAxis, looksLikeCad, ringNeighbourhood, sharpEdges, strongestFeatureVertex, vertexAdjacency } from './geometry.js';
import { History } from './history.js';
import { parseSession, rememberUpAxis, rememberedUpAxis, sessionDocument } from './session.js';
import { oneBasedNumbers } from './text.js';
import { Viewer, parseGlb, indexedMeshFromGltf, segmentedSurface, exportGlb } from './viewer.js';

const $ = (id) => document.getElementById(id);

// Snapping: a clicked key moves to the vertex of largest |curvature| within this many edges
// of the clicked vertex and this many pixels of the click (so zooming in makes it finer).
const SNAP_RINGS = 2;
const SNAP_PIXELS = 10;
// Only vertices whose |curvature| is at least this share of the mesh's robust range (95th
// percentile) count as features to snap to.
const SNAP_MIN_SHARE = 0.25;
// A press that moves more than this (pixels) is a drag (or an orbit), not a click.
const CLICK_SLOP_PIXELS = 4;
const RESULT_CACHE_SIZE = 300;

const state = {
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
  selectedKey: null, // {lineId, keyIndex}
  pendingSession: null, // a loaded session waiting for its mesh file
  lastClickAdd: null, // {time, before}: the last key placed by a click (a double-click takes it back)
};

const viewer = new Viewer($('canvas-host'));
const history = new History();
const resultCache = new Map(); // request key -> FeatureLine answer, for undo/redo without the server
let idleWaiters = [];

// ---- messages ---------------------------------------------------------------------------
function showMessage(text, { error = false } = {}) {
  state.message = text;
  state.messageIsError = error;
  const el = $('message');
  el.textContent = text;
  el.classList.toggle('error', error);
}

function errorText(e) {
  return e instanceof api.ApiError ? e.toString() : e?.message ?? String(e);
}

// Server text about lines, keys and segments, counted from 1 as the page counts.
function serverText(e) {
  return oneBasedNumbers(typeof e === 'string' ? e : errorText(e));
}

function formatBytes(n) {
  if (n < 1024) return `${n} B`;
  if (n < 1024 * 1024) return `${(n / 1024).toFixed(1)} KiB`;
  return `${(n / 1024 / 1024).toFixed(1)} MiB`;
}

function num(x, digits = 4) {
  if (typeof x !== 'number' || !Number.isFinite(x)) return String(x);
  if (x !== 0 && (Math.abs(x) >= 1e5 || Math.abs(x) < 1e-3)) return x.toExponential(2);
  return Number(x.toPrecision(digits)).toString();
}

// ---- a small in-page confirmation (window.confirm blocks and cannot be styled or tested) ----
function confirmAction(text, okLabel) {
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
let confirmResolver = null;

function hasWork() {
  return state.lines.some((l) => l.keys.length > 0);
}

// ---- opening a mesh -----------------------------------------------------------------------
function setProgress(visible, fraction = 0, text = '') {
  $('upload-progress').hidden = !visible;
  const bar = $('upload-bar');
  if (fraction === null) bar.removeAttribute('value');
  else bar.value = fraction;
  $('upload-text').textContent = text;
}

// Uploads a file, downloads the prepared mesh, and shows it. `keepLines`: the mesh is the
// same file again (the server forgot it), so the lines stay.
async function openMesh(name, bytes, format, { keepLines = false, confirmed = false } = {}) {
  if (state.loading) {
    showMessage(`Still opening ${state.loadingName}; open ${name} again when it is done.`, { error: true });
    return false;
  }
  if (!keepLines && !confirmed && hasWork() && !state.pendingSession) {
    const keys = state.lines.reduce((n, l) => n + l.keys.length, 0);
    const ok = await confirmAction(
      `Open ${name}? The ${state.lines.length} line(s) and ${keys} key(s) on ${state.mesh?.name ?? 'the current mesh'} will be closed (save the session first to keep them).`,
      `Open ${name}`,
    );
    if (!ok) {
      showMessage(`Kept ${state.mesh?.name}; ${name} was not opened.`);
      return false;
    }
  }
  state.loading = true;
  state.loadingName = name;
  const started = performance.now();
  const total = bytes.size ?? bytes.byteLength ?? 0;
  showMessage(`Opening ${name}…`);
  setProgress(true, 0, `uploading 0% of ${formatBytes(total)}`);
  try {
    const description = await api.withRetry(
      () =>
        api.uploadMesh(bytes, {
          format,
          onProgress: ({ loaded, total: t, phase }) => {
            if (phase === 'upload') state.uploadProgress = { loaded, total: t };
            if (phase === 'prepare') setProgress(true, null, 'preparing on the server…');
            else if (t > 0) setProgress(true, loaded / t, `uploading ${Math.round((100 * loaded) / t)}% of ${formatBytes(t)}`);
          },
        }),
      { onRetry: (r) => retryNotice(`Uploading ${name}`, r) },
    );
    const uploaded = performance.now();
    await showServerMesh(description, name, { keepLines });
    state.source = { name, bytes, format };
    // Time to the first frame showing the mesh (the benchmark reads it).
    const shown = performance.now();
    requestAnimationFrame(() => {
      state.openTimings = { name, uploadMs: uploaded - started, downloadAndBuildMs: shown - uploaded, firstRenderMs: performance.now() - started };
    });
    setProgress(false);
    if (!keepLines) showMessage(`Opened ${name}. Click the surface to place keys (? for help).`);
    if (state.pendingSession) await applyPendingSession();
    return true;
  } catch (e) {
    setProgress(false);
    showMessage(`Could not open ${name}: ${errorText(e)}`, { error: true });
    return false;
  } finally {
    state.loading = false;
    pump(); // lines edited while loading (a session applied) go out now
  }
}

// Expected bytes of the server's compact mesh.glb (8 bytes a vertex, indices of 1, 2 or 4
// bytes) to show download progress when the answer is compressed and its decoded size is
// unknown.
function expectedGlbBytes(d) {
  const indexBytes = d.vertices < 0xff ? 1 : d.vertices < 0xffff ? 2 : 4;
  return d.vertices * 8 + d.faces * 3 * indexBytes + 2048;
}

async function showServerMesh(description, name, { keepLines = false } = {}) {
  const id = description.mesh_id;
  setProgress(true, 0, 'downloading the prepared mesh…');
  let progressEvents = 0;
  const glb = await api.withRetry(() =>
    api.meshGlb(id, {
      expectedBytes: expectedGlbBytes(description),
      onProgress: ({ received, total }) => {
        progressEvents++;
        setProgress(true, total ? Math.min(0.99, received / total) : null, `downloading the prepared mesh: ${formatBytes(received)}${total ? ` of about ${formatBytes(total)}` : ''}`);
      },
    }),
  );
  state.download = { received: glb.bytes.byteLength, wireBytes: glb.wireBytes, encoding: glb.encoding, progressEvents };
  const mesh = indexedMeshFromGltf(await parseGlb(glb.bytes));
  // The compact GLB carries the curvature (16-bit over its range); /curvature only without it.
  const curvature = mesh.curvature ?? (await api.withRetry(() => api.curvature(id)));
  if (keepLines && state.mesh && mesh.vertexCount !== state.mesh.vertexCount)
    throw new Error(`the file now has ${mesh.vertexCount} vertices, not ${state.mesh.vertexCount}; the keys would not match`);
  const sameFile = state.mesh && state.mesh.name === name && state.mesh.vertexCount === mesh.vertexCount;
  state.mesh = { id, name, description, vertexCount: mesh.vertexCount, faceCount: mesh.faceCount };
  state.curvature = curvature.length === mesh.vertexCount ? curvature : null;
  state.curvatureRange = state.curvature ? curvatureRange(state.curvature) : 0;
  state.adjacency = vertexAdjacency(mesh.index, mesh.vertexCount);
  state.sharp = sharpEdges(mesh.positions, mesh.index);
  state.cad = looksLikeCad(state.sharp, mesh.faceCount);
  const size = boundingSize(mesh.positions);
  state.upAxis = rememberedUpAxis(name) ?? guessUpAxis(size, description.format);
  if (!sameFile) resultCache.clear(); // keys of another mesh mean other vertices
  clearSegmentation();
  if (!keepLines) {
    state.lines = [];
    state.nextLineId = 1;
    state.lastResult = null;
    state.selectedKey = null;
    history.clear();
  } else {
    for (const line of state.lines) line.resultKey = null; // ask the new session again
  }
  viewer.setMesh(mesh, { upAxis: state.upAxis, flat: state.cad, sharpEdges: state.sharp.edges, showEdges: state.cad });
  $('flat-toggle').checked = state.cad;
  $('edges-toggle').checked = state.cad;
  $('empty-hint').hidden = true;
  if (!keepLines) addLineUnrecorded();
  renderUpAxis();
  applyColors();
  renderMeshInfo();
  refresh();
  pump();
}

function boundingSize(positions) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3)
    for (let k = 0; k < 3; ++k) {
      min[k] = Math.min(min[k], positions[i + k]);
      max[k] = Math.max(max[k], positions[i + k]);
    }
  return max.map((m, k) => m - min[k]);
}

function renderMeshInfo() {
  const m = state.mesh;
  if (!m) {
    $('mesh-info').textContent = 'No mesh open.';
    return;
  }
  const d = m.description;
  const lines = [
    `${m.name} (${d.format}): ${d.vertices} vertices, ${d.faces} triangles`,
    `${d.components} component(s), ${d.boundary_loops} boundary loop(s); mean edge ${num(d.mean_edge)}`,
    `loaded in ${num(d.timings_ms.load, 3)} ms, prepared in ${num(d.timings_ms.prepare, 3)} ms`,
    d.expires_in_s == null ? 'preloaded: never expires' : `the server forgets it after ${Math.round(d.expires_in_s)} s unused${state.source ? ' (it is then uploaded again)' : ''}`,
  ];
  if (state.download)
    lines.push(`mesh download: ${formatBytes(state.download.wireBytes)} on the wire${state.download.encoding !== 'identity' ? ` (${state.download.encoding}, ${formatBytes(state.download.received)} unpacked)` : ''}`);
  if (state.cad) lines.push('looks like a CAD part: flat shading and sharp edges on');
  if (d.warnings?.length) lines.push(`warnings: ${d.warnings.join('; ')}`);
  $('mesh-info').textContent = lines.join('\n');
}

// Files from the chooser or a drop: the first mesh (or session) file is opened; the user is
// told when others were left out.
function openFiles(fileList) {
  const files = [...(fileList || [])];
  if (!files.length) return;
  const first = files[0];
  const note = files.length > 1 ? `${files.length} files dropped: opening the first, ${first.name} (one at a time). ` : '';
  if (/\.json$/i.test(first.name)) {
    if (note) showMessage(note);
    loadSessionFile(first);
    return;
  }
  const format = api.formatOfFileName(first.name);
  if (!format) {
    showMessage(`${note}${first.name} is not a mesh file this page knows (${api.MESH_FORMATS.join(', ')}); sending it anyway, the server will say.`);
  } else if (note) {
    showMessage(note);
  }
  openMesh(first.name, first, format).then((opened) => {
    if (opened && note) showMessage(`${note.replace('opening', 'opened')}Click the surface to place keys.`);
  });
}

async function loadSamples() {
  try {
    const response = await fetch('samples/index.json');
    if (!response.ok) throw new Error(`HTTP ${response.status}`);
    const { samples } = await response.json();
    state.samples = samples;
    const select = $('sample-select');
    select.innerHTML = '';
    for (const s of samples) {
      const o = document.createElement('option');
      o.value = s.file;
      o.textContent = `${s.name} (${s.format}, ${formatBytes(s.bytes)})`;
      select.appendChild(o);
    }
    if (!samples.length) select.innerHTML = '<option value="">(none bundled)</option>';
  } catch (e) {
    console.warn('no sample list', e);
  }
}

async function openSample(file, options) {
  const sample = state.samples.find((s) => s.file === file);
  if (!sample) return false;
  try {
    const response = await fetch(sample.file);
    if (!response.ok) throw new Error(`HTTP ${response.status} for ${sample.file}`);
    return await openMesh(`${sample.name}.${sample.format}`, await response.arrayBuffer(), sample.format, options);
  } catch (e) {
    showMessage(`Could not read the sample: ${errorText(e)}`, { error: true });
    return false;
  }
}

// The server forgot the mesh (expired after idling, evicted, deleted): upload the same file
// again and re-create every line on it. Vertex ids are the file's own, so keys stay valid.
async function recoverMesh(reason) {
  if (state.recovering) return false;
  if (!state.source) {
    state.pendingSession = sessionDocument(currentSessionParts());
    showMessage(`The server no longer has ${state.mesh?.name} (${reason}). Open that file again and the ${state.lines.length} line(s) will be re-created.`, { error: true });
    return false;
  }
  state.recovering = true;
  const { name, bytes, format } = state.source;
  showMessage(`The server had forgotten ${name}; uploading it again…`);
  try {
    const ok = await openMesh(name, bytes, format, { keepLines: true });
    if (ok) showMessage(`The server had forgotten ${name} (${reason}); uploaded it again and re-created ${state.lines.length} line(s).`);
    return ok;
  } finally {
    state.recovering = false;
    pump();
  }
}

// ---- colours --------------------------------------------------------------------------------
function applyColors() {
  if (!state.mesh) return;
  const seg = state.segmentation;
  if ($('segments-toggle').checked && seg) {
    if (seg.faceColored) {
      const labels = seg.answer.labels;
      viewer.setFaceColors((f) => segmentColor(seg, labels[f]));
    } else {
      viewer.showSegmentScene(true);
    }
    state.colorMode = 'segments';
    $('legend').hidden = true;
  } else if ($('curvature-toggle').checked && state.curvature) {
    const h = state.curvature;
    const r = state.curvatureRange;
    viewer.setVertexColors((v) => diverging(h[v] / r));
    $('legend-min').textContent = num(-r, 3);
    $('legend-max').textContent = num(r, 3);
    $('legend').hidden = false;
    state.colorMode = 'curvature';
  } else {
    viewer.setPlainColors();
    state.colorMode = 'plain';
    $('legend').hidden = true;
  }
  renderSegmentStaleness();
}

function setUpAxis(axis) {
  if (!state.mesh || (axis !== 'y' && axis !== 'z')) return;
  state.upAxis = axis;
  rememberUpAxis(state.mesh.name, axis);
  viewer.setUpAxis(axis);
  renderUpAxis();
}

function renderUpAxis() {
  for (const el of document.querySelectorAll('input[name="up-axis"]')) el.checked = el.value === state.upAxis;
}

// ---- edits, history -----------------------------------------------------------------------------
// What undo restores: the lines with their keys, which one is active, and the options.
function snapshot() {
  return {
    lines: state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed })),
    activeLineId: state.activeLineId,
    nextLineId: state.nextLineId,
    options: structuredClone(state.options),
  };
}

function restore(snap) {
  const old = new Map(state.lines.map((l) => [l.id, l]));
  state.lines = snap.lines.map((s) => {
    const line = newLine(s.id, s.name);
    line.keys = [...s.keys];
    line.closed = s.closed;
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
function edit(label, mutate) {
  const before = snapshot();
  if (mutate() === false) return false;
  history.record(before, label);
  afterEdit();
  return true;
}

function afterEdit() {
  refresh();
  pump();
}

function undo() {
  const entry = history.undo(snapshot());
  if (!entry) return showMessage('Nothing to undo.');
  restore(entry.snapshot);
  showMessage(`Undid: ${entry.label}.`);
  afterEdit();
}

function redo() {
  const entry = history.redo(snapshot());
  if (!entry) return showMessage('Nothing to redo.');
  restore(entry.snapshot);
  showMessage(`Redid: ${entry.label}.`);
  afterEdit();
}

function renderHistoryButtons() {
  $('undo').disabled = !history.canUndo;
  $('redo').disabled = !history.canRedo;
  $('undo').title = history.canUndo ? `Undo: ${history.undoLabel} (Ctrl+Z)` : 'Nothing to undo (Ctrl+Z)';
  $('redo').title = history.canRedo ? `Redo: ${history.redoLabel} (Ctrl+Shift+Z)` : 'Nothing to redo (Ctrl+Shift+Z)';
}

// ---- lines ------------------------------------------------------------------------------------
function activeLine() {
  return state.lines.find((l) => l.id === state.activeLineId) || null;
}

function newLine(id, name) {
  return {
    id,
    name: name ?? `Line ${id}`,
    keys: [],
    closed: false,
    result: null, // the last answer (possibly for earlier keys: then drawn as out of date)
    resultKey: null, // the request the result answers
    error: '',
    failedKey: null, // the request that failed (not sent again until the line changes)
  };
}

function addLineUnrecorded() {
  const line = newLine(state.nextLineId++);
  state.lines.push(line);
  state.activeLineId = line.id;
  return line;
}

function addLine() {
  edit('new line', () => {
    addLineUnrecorded();
  });
  showMessage(`${activeLine().name} is active: click the surface to place its keys.`);
}

function deleteLine(id) {
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

function setActiveLine(id) {
  if (state.activeLineId === id) return;
  state.activeLineId = id;
  state.selectedKey = null;
  refresh();
}

// Whether keys can go to the server: at least two, consecutive ones distinct (1-based).
function keysProblem(line) {
  if (line.keys.length < 2) return 'place at least two keys';
  for (let i = 1; i < line.keys.length; ++i) if (line.keys[i] === line.keys[i - 1]) return `keys ${i} and ${i + 1} are the same vertex`;
  return '';
}

function canUseVertex(line, index, v) {
  const n = line.keys.length;
  const prev = index > 0 ? line.keys[index - 1] : line.closed && n > 2 ? line.keys[n - 1] : undefined;
  const next = index < n - 1 ? line.keys[index + 1] : line.closed && n > 2 ? line.keys[0] : undefined;
  return v !== prev && v !== next;
}

function addKey(vertex) {
  const line = activeLine();
  if (!line || !state.mesh) return false;
  if (line.keys.length && line.keys[line.keys.length - 1] === vertex) return false;
  const added = edit('add key', () => {
    line.keys.push(vertex);
    state.selectedKey = { lineId: line.id, keyIndex: line.keys.length - 1 };
  });
  return added;
}

function moveKeyUnrecorded(line, index, vertex) {
  if (line.keys[index] === vertex || !canUseVertex(line, index, vertex)) return false;
  line.keys[index] = vertex;
  afterEdit();
  return true;
}

function deleteKey(line, index) {
  edit(`delete key ${index + 1} of ${line.name}`, () => {
    line.keys.splice(index, 1);
    state.selectedKey = null;
  });
}

function deleteSelectedKey() {
  const sel = state.selectedKey;
  const line = sel && state.lines.find((l) => l.id === sel.lineId);
  if (line && sel.keyIndex < line.keys.length) return deleteKey(line, sel.keyIndex);
  const active = activeLine();
  if (active?.keys.length) return deleteKey(active, active.keys.length - 1); // nothing selected: the last key
  showMessage('No key to delete.');
}

function setClosed(closed) {
  const line = activeLine();
  if (!line || line.closed === closed) return;
  edit(closed ? `close ${line.name}` : `open ${line.name}`, () => {
    line.closed = closed;
  });
}

function clearKeys() {
  const line = activeLine();
  if (!line || !line.keys.length) return;
  edit(`clear the keys of ${line.name}`, () => {
    line.keys = [];
    state.selectedKey = null;
  });
  showMessage(`Cleared the keys of ${line.name}. Undo brings them back (Ctrl+Z).`);
}

function lineRequest(line) {
  const body = { keys: [...line.keys], closed: line.closed };
  if (Object.keys(state.options).length) body.options = structuredClone(state.options);
  return body;
}

const requestKey = (line) => JSON.stringify(lineRequest(line));

// Whether the drawn result is for other keys or options than the line has now.
function isStale(line) {
  return !!line.result && line.resultKey !== requestKey(line);
}

function needsRequest(line) {
  if (keysProblem(line) || !state.optionsValid) return false;
  const key = requestKey(line);
  return line.resultKey !== key && line.failedKey !== key;
}

function cacheResult(key, result) {
  resultCache.delete(key);
  resultCache.set(key, result);
  if (resultCache.size > RESULT_CACHE_SIZE) resultCache.delete(resultCache.keys().next().value);
}

// Lines whose request is answered in the cache (undo, redo) take it at once.
function takeCachedResults() {
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
async function pump() {
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

function retryNotice(what, { error, attempt, delayS }) {
  state.retryCount++;
  const why = error.isNetwork ? 'could not reach the server' : `the server is busy (HTTP ${error.status})`;
  showMessage(`${what}: ${why}; retrying in ${num(delayS, 2)} s (try ${attempt + 1}).`, { error: true });
}

function isIdle() {
  return !state.inFlight && !state.loading && !state.recovering && !state.lines.some(needsRequest);
}

function settleIdle() {
  if (!isIdle()) return;
  const waiters = idleWaiters;
  idleWaiters = [];
  for (const w of waiters) w();
}

// ---- rendering the panel ---------------------------------------------------------------------------
function refresh() {
  viewer.selectedKey = state.selectedKey;
  viewer.setLines(
    state.lines.map((l) => ({ ...l, stale: isStale(l) })),
    state.activeLineId,
  );
  renderLineList();
  renderKeyList();
  renderLineStatus();
  renderTimings();
  renderHistoryButtons();
  renderSegmentStaleness();
  $('snap-toggle').checked = state.snapping;
}

function lineStateText(line) {
  if (line.error && line.failedKey === requestKey(line)) return { text: 'error', error: true };
  if (keysProblem(line)) return { text: `${line.keys.length} key${line.keys.length === 1 ? '' : 's'}` };
  if (isStale(line) || !line.result) return { text: `${line.keys.length} keys · updating…` };
  return { text: `${line.keys.length} keys · length ${num(line.result.refined.length, 3)}` };
}

function renderLineList() {
  const ul = $('line-list');
  ul.innerHTML = '';
  for (const line of state.lines) {
    const li = document.createElement('li');
    li.classList.toggle('active', line.id === state.activeLineId);
    li.classList.toggle('stale', isStale(line));
    li.dataset.lineId = line.id;
    li.tabIndex = 0;
    li.title = 'Make this the active line (new keys go to it)';
    const name = document.createElement('span');
    name.className = 'name';
    name.textContent = `${line.name}${line.closed ? ' (loop)' : ''}`;
    const st = document.createElement('span');
    st.className = 'state';
    const { text, error } = lineStateText(line);
    st.textContent = text;
    st.classList.toggle('error', !!error);
    const del = document.createElement('button');
    del.className = 'x';
    del.type = 'button';
    del.title = `Delete ${line.name} (undo brings it back)`;
    del.setAttribute('aria-label', `delete ${line.name}`);
    del.textContent = '×';
    del.addEventListener('click', (e) => {
      e.stopPropagation();
      deleteLine(line.id);
    });
    li.append(name, st, del);
    li.addEventListener('click', () => setActiveLine(line.id));
    li.addEventListener('keydown', (e) => {
      if (e.key === 'Enter' || e.key === ' ') setActiveLine(line.id);
    });
    ul.appendChild(li);
  }
  const line = activeLine();
  $('closed-toggle').checked = !!line?.closed;
}

function renderKeyList() {
  const ol = $('key-list');
  ol.innerHTML = '';
  const line = activeLine();
  if (!line) return;
  line.keys.forEach((v, i) => {
    const li = document.createElement('li');
    const selected = state.selectedKey?.lineId === line.id && state.selectedKey.keyIndex === i;
    li.classList.toggle('selected', selected);
    const label = document.createElement('span');
    label.textContent = `vertex ${v}`;
    const del = document.createElement('button');
    del.className = 'x';
    del.type = 'button';
    del.title = `Delete key ${i + 1}`;
    del.setAttribute('aria-label', `delete key ${i + 1}`);
    del.textContent = '×';
    del.addEventListener('click', () => deleteKey(line, i));
    li.append(label, del);
    ol.appendChild(li);
  });
}

function renderLineStatus() {
  const line = activeLine();
  const el = $('line-status');
  el.classList.remove('error', 'stale');
  if (!state.mesh) {
    el.textContent = 'Open a mesh first.';
    return;
  }
  if (!line) return (el.textContent = '');
  const parts = [];
  const failedNow = line.error && line.failedKey === requestKey(line);
  if (keysProblem(line)) {
    el.textContent = `${line.name}: ${keysProblem(line)}.`;
    return;
  }
  if (failedNow) {
    parts.push(`${line.name} could not be detected: ${line.error}`);
    el.classList.add('error');
    if (line.result) parts.push('The dashed line is the last one that worked, for earlier keys.');
    el.textContent = parts.join('\n');
    return;
  }
  const r = line.result;
  if (!r) {
    el.textContent = `${line.name}: detecting…`;
    return;
  }
  if (isStale(line)) {
    parts.push(`${line.name}: updating… (the dashed line is for the earlier keys)`);
    el.classList.add('stale');
  }
  parts.push(
    `initial (${r.initial.method}): ${r.initial.vertices.length} vertices, length ${num(r.initial.length)}`,
    `refined: ${r.refined.points.length} points, length ${num(r.refined.length)}`,
  );
  if (r.stats.fallbacks?.length)
    parts.push(...r.stats.fallbacks.map((f) => `segment ${f.segment + 1} (keys ${f.segment + 1} to ${((f.segment + 1) % r.keys.length) + 1}): ${f.from} → ${f.to} (${serverText(f.reason)})`));
  if (r.stats.warnings?.length) parts.push(...r.stats.warnings.map((w) => `warning: ${serverText(w)}`));
  el.textContent = parts.join('\n');
}

// The timings of the active line's own last answer; marked out of date when the line changed.
function renderTimings() {
  const tbody = $('timings').querySelector('tbody');
  tbody.innerHTML = '';
  const line = activeLine();
  const r = line?.result;
  const stale = line ? isStale(line) : false;
  $('timings-title').textContent = line ? `Last run of ${line.name}${stale ? ' (out of date: the line changed since)' : ''}` : 'Last run';
  $('timings').classList.toggle('stale', stale);
  if (!r) {
    tbody.innerHTML = '<tr><td colspan="2">no run yet</td></tr>';
    return;
  }
  const t = r.stats.timings_ms;
  const rows = [
    ['initial line', `${num(t.initial, 3)} ms`],
    ['feature strip', `${num(t.strip, 3)} ms`],
    ['flattening', `${num(t.flatten, 3)} ms`],
    ['snake', `${num(t.snake, 3)} ms`],
    ['total', `${num(t.total, 3)} ms`],
    ['snake iterations', String(r.stats.iterations)],
    ['strip faces', String(r.stats.strip_faces)],
    ['pieces / splits', `${r.stats.pieces} / ${r.stats.splits}`],
    ['requests sent', String(state.requestCount)],
  ];
  for (const [k, v] of rows) {
    const tr = document.createElement('tr');
    const a = document.createElement('td');
    a.textContent = k;
    const b = document.createElement('td');
    b.textContent = v;
    tr.append(a, b);
    tbody.appendChild(tr);
  }
}

// ---- options -----------------------------------------------------------------------------------------
function readOptions() {
  const options = {};
  const problems = [];
  for (const el of $('options-form').elements) {
    if (!el.name || el.value === '') continue;
    let value = el.value;
    if (el.type === 'number') {
      value = Number(el.value);
      const min = el.min === '' ? -Infinity : Number(el.min);
      const max = el.max === '' ? Infinity : Number(el.max);
      const integer = el.step === '1';
      if (!Number.isFinite(value) || value < min || value > max || (integer && !Number.isInteger(value))) {
        problems.push(`${el.labels?.[0]?.textContent ?? el.name} must be ${integer ? 'an integer' : 'a number'} from ${min} to ${max}`);
        continue;
      }
    } else if (el.name === 'refine') {
      value = value === 'true';
    }
    const path = el.name.split('.');
    let o = options;
    for (const p of path.slice(0, -1)) o = o[p] ??= {};
    o[path[path.length - 1]] = value;
  }
  return { options, problems };
}

// The inputs' limits, steps, choices and tooltips come from the server's option tables
// (GET /v1/options), so the page never accepts what the server refuses or refuses what it
// accepts. Until they arrive the server's own checks answer.
function applyOptionTables(tables) {
  const rows = new Map(tables.feature_line.map((row) => [row.name, row]));
  for (const el of $('options-form').elements) {
    const row = rows.get(el.name);
    if (!row) continue;
    const shown = typeof row.default === 'number' ? String(row.default) : JSON.stringify(row.default);
    el.title = `${row.description} (default ${shown.replaceAll('"', '')})`;
    if (el.type === 'number') {
      el.min = String(row.minimum);
      el.max = String(row.maximum);
      el.step = row.type === 'integer' ? '1' : 'any';
      el.title = `${row.description} (${row.minimum} to ${row.maximum}; default ${shown})`;
    } else if (el.tagName === 'SELECT' && row.enum) {
      const chosen = el.value;
      while (el.options.length > 1) el.remove(1);  // the first option is "default"
      for (const name of row.enum) el.add(new Option(name, name));
      el.value = row.enum.includes(chosen) ? chosen : '';
    }
  }
}

async function loadOptionTables() {
  try {
    applyOptionTables(await api.optionTables());
  } catch (e) {
    console.warn('option tables unavailable; the server checks the options', e);
  }
}

// The form shows `options` (undo, redo, a loaded session).
function writeOptionsForm(options) {
  for (const el of $('options-form').elements) {
    if (!el.name) continue;
    let v = options;
    for (const p of el.name.split('.')) v = v?.[p];
    el.value = v === undefined || v === null ? '' : String(v);
  }
  $('options-error').hidden = true;
  state.optionsValid = true;
}

let optionsTimer = 0;
function optionsChanged() {
  clearTimeout(optionsTimer);
  optionsTimer = setTimeout(() => {
    const { options, problems } = readOptions();
    $('options-error').hidden = problems.length === 0;
    $('options-error').textContent = problems.join('\n');
    state.optionsValid = problems.length === 0;
    if (!state.optionsValid) return refresh();
    if (JSON.stringify(options) === JSON.stringify(state.options)) return;
    edit('change options', () => {
      state.options = options;
    });
  }, 250);
}

// ---- decomposition -------------------------------------------------------------------------------------
function readyLines() {
  return state.lines.filter((l) => !keysProblem(l)).map(lineRequest);
}

// A line for the decomposition: the line the page already has when its answer is current
// (computed once: the server only cuts along it), else its request (the server detects it).
function segmentationItem(line) {
  const refined = line.result?.refined;
  if (!isStale(line) && Array.isArray(refined?.faces) && Array.isArray(refined?.barycentric))
    return { keys: [...line.keys], closed: line.closed, refined: { faces: refined.faces, barycentric: refined.barycentric } };
  return lineRequest(line);
}

// The server's colour of a segment label (its answer carries the one palette, the same as in
// its GLB); grey for an answer without colours.
function segmentColor(seg, label) {
  return seg.answer.segments[label]?.color ?? [0.5, 0.5, 0.5];
}

function clearSegmentation() {
  state.segmentation = null;
  state.decomposeMessage = '';
  viewer.setSegmentScene(null);
  $('segments-toggle').checked = false;
  $('segments-toggle').disabled = true;
  $('download-segmented').disabled = true;
  $('decompose-status').textContent = '';
  renderSegments();
}

async function decompose() {
  if (!state.mesh) return;
  $('decompose-section').open = true;
  const ready = state.lines.filter((l) => !keysProblem(l));
  const lines = ready.map(segmentationItem);
  const status = $('decompose-status');
  status.classList.remove('error');
  if (!lines.length) {
    status.textContent = 'Place a line with at least two keys first.';
    return;
  }
  // Slivers left where a line doubles back to a pinned key join their neighbour.
  const request = { lines, mode: $('decompose-mode').value, merge_tiny_segments: true };
  const meshId = state.mesh.id;
  status.textContent = 'Decomposing…';
  $('decompose').disabled = true;
  $('toolbar-decompose').disabled = true;
  try {
    const answer = await api.withRetry(() => api.segmentation(meshId, request), { onRetry: (r) => retryNotice('Decomposing', r) });
    if (state.mesh?.id !== meshId) return;
    await applySegmentation(request, answer, JSON.stringify(ready.map(lineRequest)));
  } catch (e) {
    let text = `Decomposition failed: ${serverText(e)}`;
    if (e instanceof api.ApiError && (e.status === 404 || e.status === 405)) {
      // A 404 for the route (not for the mesh) means the server has no decomposition.
      let meshThere = true;
      try {
        await api.describeMesh(meshId);
      } catch {
        meshThere = false;
      }
      if (meshThere) text = 'Decomposition not available on this server.';
    }
    state.decomposeMessage = text;
    status.textContent = text;
    status.classList.add('error');
  } finally {
    $('decompose').disabled = false;
    $('toolbar-decompose').disabled = false;
  }
}

// The segmented surface of an answer as three.js objects: the remeshed surface it carries
// (remesh mode), or the page's mesh with the answer's labels (snap mode); null when the answer
// carries neither.
function segmentedObject(seg) {
  const { answer } = seg;
  const colorOf = (label) => segmentColor(seg, label);
  const remeshed = answer.remeshed;
  if (Array.isArray(remeshed?.vertices) && Array.isArray(remeshed?.faces))
    return segmentedSurface(remeshed.vertices.flat(), remeshed.faces.flat(), answer.labels, colorOf);
  if (seg.faceColored && viewer.mesh) return segmentedSurface(viewer.mesh.positions, viewer.mesh.index, answer.labels, colorOf);
  return null;
}

// linesKey: the line requests the answer is for (to tell when it is out of date).
async function applySegmentation(request, answer, linesKey) {
  if (!answer || !Array.isArray(answer.labels) || !Array.isArray(answer.segments))
    throw new api.ApiError(0, '', 'the server answered the decomposition in an unknown shape');
  const faceColored = answer.labels.length === state.mesh.faceCount;
  const seg = { request, linesKey, answer, faceColored, sceneLoaded: false };
  viewer.setSegmentScene(null);
  state.segmentation = seg;
  const parts = [`${answer.segments.length} segment(s)`];
  if (!faceColored) {
    // Remesh mode: the labels are for the remeshed surface, which the answer carries; an
    // answer without it (an older server) is asked for once more as GLB.
    try {
      const surface = segmentedObject(seg);
      if (surface) viewer.setSegmentScene(surface);
      else viewer.setSegmentScene((await parseGlb(await (await api.segmentationGlb(state.mesh.id, request)).arrayBuffer())).scene);
      seg.sceneLoaded = true;
    } catch (e) {
      parts.push(`the labels are for a remeshed surface of ${answer.labels.length} faces; its colours cannot be shown (${errorText(e)})`);
    }
  }
  if (answer.warnings?.length) parts.push(...answer.warnings.map((w) => `warning: ${serverText(w)}`));
  state.decomposeMessage = parts.join('\n');
  $('decompose-status').textContent = state.decomposeMessage;
  $('segments-toggle').disabled = !(faceColored || seg.sceneLoaded);
  $('segments-toggle').checked = faceColored || seg.sceneLoaded;
  if ($('segments-toggle').checked) $('curvature-toggle').checked = false;
  $('download-segmented').disabled = false;
  renderSegments();
  applyColors();
}

// The segments came from the lines as they were when Decompose ran.
function segmentationStale() {
  const seg = state.segmentation;
  return !!seg && seg.linesKey !== JSON.stringify(readyLines());
}

function renderSegmentStaleness() {
  const stale = segmentationStale();
  $('segments').classList.toggle('stale', stale);
  $('segments-stale').hidden = !stale;
  $('view-stale').hidden = !(stale && state.colorMode === 'segments');
}

function renderSegments() {
  const tbody = $('segments').querySelector('tbody');
  tbody.innerHTML = '';
  const seg = state.segmentation;
  $('segments').hidden = !seg;
  if (!seg) return renderSegmentStaleness();
  let totalArea = 0;
  for (const s of seg.answer.segments) {
    totalArea += Number(s.area) || 0;
    const tr = document.createElement('tr');
    const sw = document.createElement('td');
    const box = document.createElement('span');
    box.className = 'swatch';
    box.style.background = rgbCss(segmentColor(seg, s.label));
    sw.appendChild(box);
    tr.appendChild(sw);
    // Labels are shown from 1, like every other count on the page.
    for (const v of [s.label + 1, s.faces, num(s.area), num(s.boundary_length)]) {
      const td = document.createElement('td');
      td.textContent = String(v);
      tr.appendChild(td);
    }
    tbody.appendChild(tr);
  }
  const tr = document.createElement('tr');
  tr.innerHTML = '<td></td><td>total</td><td></td><td></td><td></td>';
  tr.children[3].textContent = num(totalArea);
  tbody.appendChild(tr);
  renderSegmentStaleness();
}

// ---- downloads, sessions ----------------------------------------------------------------------------------------
function saveBlob(blob, name) {
  const url = URL.createObjectURL(blob);
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

function baseName() {
  return (state.mesh?.name || 'mesh').replace(/\.[^.]+$/, '');
}

async function downloadLines(format) {
  if (!state.mesh) return;
  const lines = readyLines();
  if (!lines.length) return showMessage('No line to download: place at least two keys.', { error: true });
  try {
    if (format === 'glb') {
      saveBlob(await api.withRetry(() => api.featureLinesGlb(state.mesh.id, { lines })), `${baseName()}-lines.glb`);
    } else {
      const answer = await api.withRetry(() => api.detectFeatureLines(state.mesh.id, { lines }));
      // The session fields make the file loadable again (Load session).
      const doc = { ...sessionDocument(currentSessionParts()), mesh_id: state.mesh.id, requests: lines, lines: answer.lines };
      doc.session_lines = sessionDocument(currentSessionParts()).lines;
      saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-lines.json`);
    }
    showMessage(`Downloaded ${lines.length} line(s) as ${format.toUpperCase()}.`);
  } catch (e) {
    if (e instanceof api.ApiError && e.isMeshGone) return recoverMesh(e.message);
    showMessage(`Download failed: ${serverText(e)}`, { error: true });
  }
}

// Saves the decomposition the page already has as GLB (one mesh per part, the answer's
// colours), written in the page: no request.
async function downloadSegmented() {
  const seg = state.segmentation;
  if (!seg || !state.mesh) return;
  try {
    const object = segmentedObject(seg) ?? viewer.segmentGroup.children[0];
    if (!object) {
      // Nothing to write as GLB: save the labels and segments instead.
      const doc = { mesh_id: state.mesh.id, ...seg.answer };
      saveBlob(new Blob([JSON.stringify(doc)], { type: 'application/json' }), `${baseName()}-segments.json`);
      showMessage('Saved the labels and segments as JSON (the answer carries no surface to write as GLB).');
      return;
    }
    saveBlob(new Blob([await exportGlb(object)], { type: 'model/gltf-binary' }), `${baseName()}-segments.glb`);
  } catch (e) {
    showMessage(`Download failed: ${errorText(e)}`, { error: true });
  }
}

function currentSessionParts() {
  return { mesh: state.mesh, lines: state.lines, options: state.options, upAxis: state.upAxis };
}

function saveSession() {
  if (!state.mesh) return showMessage('Open a mesh first: a session is the work on one mesh.', { error: true });
  const doc = sessionDocument(currentSessionParts());
  saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-session.json`);
  showMessage(`Saved the session: ${doc.lines.length} line(s) on ${doc.mesh.name}.`);
}

async function loadSessionFile(file) {
  let doc;
  try {
    const text = await file.text();
    const raw = JSON.parse(text);
    // A lines download carries the session too (its "lines" are results: use session_lines).
    if (raw && Array.isArray(raw.session_lines)) raw.lines = raw.session_lines;
    doc = parseSession(JSON.stringify(raw));
  } catch (e) {
    return showMessage(`Could not load the session ${file.name}: ${e.message}`, { error: true });
  }
  await loadSessionDocument(doc);
}

// Finds the session's mesh: already open, still on the server, a bundled sample, or else the
// user is asked to open the file; the lines are then re-created.
async function loadSessionDocument(doc) {
  const m = state.mesh;
  if (m && (m.id === doc.mesh.id || (m.name === doc.mesh.name && m.vertexCount === doc.mesh.vertices))) return applySession(doc);
  if (hasWork() && !(await confirmAction(`Load the session for ${doc.mesh.name}? The lines on ${m?.name} will be closed.`, 'Load session'))) return;
  state.pendingSession = doc;
  if (doc.mesh.id) {
    try {
      const description = await api.describeMesh(doc.mesh.id);
      if (description.vertices === doc.mesh.vertices) {
        state.loading = true;
        try {
          await showServerMesh(description, doc.mesh.name);
          state.source = null; // not uploaded from this page: asked for if the server forgets it
        } finally {
          state.loading = false;
        }
        return applyPendingSession();
      }
    } catch (e) {
      if (!(e instanceof api.ApiError && e.isMeshGone)) {
        state.pendingSession = null;
        return showMessage(`Could not load the session: ${errorText(e)}`, { error: true });
      }
    }
  }
  const sample = state.samples.find((s) => `${s.name}.${s.format}` === doc.mesh.name);
  if (sample) return openSample(sample.file, { confirmed: true });
  showMessage(`The server no longer has ${doc.mesh.name}: open that file (drop it or choose it) and the session's ${doc.lines.length} line(s) will be re-created.`);
}

async function applyPendingSession() {
  const doc = state.pendingSession;
  state.pendingSession = null;
  if (!doc || !state.mesh) return;
  if (state.mesh.vertexCount !== doc.mesh.vertices) {
    showMessage(`${state.mesh.name} has ${state.mesh.vertexCount} vertices, the session's ${doc.mesh.name} had ${doc.mesh.vertices}: the session was not applied (its keys would be other vertices).`, { error: true });
    return;
  }
  applySession(doc);
}

function applySession(doc) {
  edit(`load session (${doc.lines.length} lines)`, () => {
    state.lines = [];
    state.nextLineId = 1;
    for (const l of doc.lines) {
      const line = addLineUnrecorded();
      if (l.name) line.name = l.name;
      line.keys = [...l.keys];
      line.closed = !!l.closed;
    }
    if (!state.lines.length) addLineUnrecorded();
    state.activeLineId = state.lines[0].id;
    state.options = structuredClone(doc.options ?? {});
    writeOptionsForm(state.options);
    state.selectedKey = null;
  });
  if (doc.up_axis === 'y' || doc.up_axis === 'z') setUpAxis(doc.up_axis);
  showMessage(`Loaded the session: ${doc.lines.length} line(s) on ${state.mesh.name}.`);
}

// ---- pointer interaction on the canvas --------------------------------------------------------------
// A press on a key's marker grabs it (a drag starts only once the pointer moves; a press
// without moving selects the key); a press anywhere else is a click that places a key, or an
// orbit when the pointer moves.
const pointer = { down: null, press: null, drag: null, pendingMove: null, moveScheduled: false };

// The vertex a click at (x, y) places: the hit vertex, or with snapping the strongest feature
// vertex nearby. Returns {vertex, hit, snapped} or null when the click misses the mesh.
function keyVertexAt(clientX, clientY, avoid = []) {
  const hit = viewer.pickVertex(clientX, clientY);
  if (!hit) return null;
  if (!state.snapping || !state.curvature || !state.adjacency) return { vertex: hit.vertex, hit, snapped: false };
  // A click on the boundary stays on it: a line meant to end there (to cut the mesh) must.
  const boundary = state.sharp?.onBoundary;
  const onBoundary = boundary && boundary[hit.vertex];
  const candidates = ringNeighbourhood(state.adjacency, hit.vertex, SNAP_RINGS).filter((v) => !onBoundary || boundary[v]);
  const near = (v) => {
    const p = viewer.toClient(viewer.vertexPosition(v));
    return p.inFront && Math.hypot(p.x - clientX, p.y - clientY) <= SNAP_PIXELS;
  };
  let vertex = strongestFeatureVertex(hit.vertex, candidates, state.curvature, near, SNAP_MIN_SHARE * state.curvatureRange);
  // Two keys meant to sit close together must not snap onto one vertex.
  if (avoid.includes(vertex)) vertex = hit.vertex;
  return { vertex, hit, snapped: vertex !== hit.vertex };
}

function onPointerDown(e) {
  if (!state.mesh) return;
  const key = viewer.pickKey(e.clientX, e.clientY);
  if (e.button === 2 && key) {
    // Right-click on a key deletes it.
    e.stopPropagation();
    e.preventDefault();
    const line = state.lines.find((l) => l.id === key.lineId);
    if (line) deleteKey(line, key.keyIndex);
    return;
  }
  if (e.button !== 0) return;
  if (key) {
    // On a marker: the orbit controls must not see this gesture.
    e.stopPropagation();
    e.preventDefault();
    pointer.press = { key, x: e.clientX, y: e.clientY, pointerId: e.pointerId };
    viewer.controls.enabled = false;
    viewer.canvas.setPointerCapture?.(e.pointerId);
    return;
  }
  pointer.down = { x: e.clientX, y: e.clientY, t: performance.now() };
}

function startDrag() {
  const { key, pointerId } = pointer.press;
  const line = state.lines.find((l) => l.id === key.lineId);
  if (!line) return;
  pointer.drag = { lineId: key.lineId, keyIndex: key.keyIndex, pointerId, before: snapshot(), startVertex: line.keys[key.keyIndex] };
  state.activeLineId = key.lineId;
  state.selectedKey = { lineId: key.lineId, keyIndex: key.keyIndex };
  viewer.canvas.style.cursor = 'grabbing';
  refresh();
}

function processMove() {
  pointer.moveScheduled = false;
  const e = pointer.pendingMove;
  pointer.pendingMove = null;
  if (!e) return;
  if (pointer.press && !pointer.drag && Math.hypot(e.clientX - pointer.press.x, e.clientY - pointer.press.y) > CLICK_SLOP_PIXELS) startDrag();
  if (pointer.drag) {
    const line = state.lines.find((l) => l.id === pointer.drag.lineId);
    if (!line) return;
    const i = pointer.drag.keyIndex;
    const neighbours = [line.keys[i - 1], line.keys[i + 1]].filter((v) => v !== undefined);
    const target = keyVertexAt(e.clientX, e.clientY, neighbours);
    if (target) moveKeyUnrecorded(line, i, target.vertex);
    return;
  }
  if (pointer.press) return;
  hoverFeedback(e.clientX, e.clientY);
}

// Hovering: the key under the pointer is highlighted; elsewhere the read-out names the vertex
// and its curvature, and a dot shows where a click would place the key (after snapping).
function hoverFeedback(x, y) {
  const key = viewer.pickKey(x, y);
  const same = (a, b) => (a && b ? a.lineId === b.lineId && a.keyIndex === b.keyIndex : a === b);
  if (!same(key, viewer.hoverKey)) {
    viewer.hoverKey = key;
    viewer.canvas.style.cursor = key ? 'grab' : '';
    refresh();
  }
  const readout = $('readout');
  if (key) {
    const line = state.lines.find((l) => l.id === key.lineId);
    readout.textContent = `${line?.name ?? 'line'}, key ${key.keyIndex + 1} (vertex ${line?.keys[key.keyIndex]}): drag to move, right-click or Delete to remove`;
    readout.hidden = false;
    viewer.setSnapPreview(null);
    return;
  }
  const target = keyVertexAt(x, y, lastKeyOfActiveLine());
  if (!target) {
    readout.hidden = true;
    viewer.setSnapPreview(null);
    return;
  }
  const c = state.curvature ? ` · curvature ${num(state.curvature[target.hit.vertex], 3)}` : '';
  const snap = target.snapped ? ` · snaps to vertex ${target.vertex}${state.curvature ? ` (${num(state.curvature[target.vertex], 3)})` : ''}` : '';
  readout.textContent = `vertex ${target.hit.vertex}${c}${snap}`;
  readout.hidden = false;
  viewer.setSnapPreview(target.vertex);
}

function lastKeyOfActiveLine() {
  const keys = activeLine()?.keys ?? [];
  return keys.length ? [keys[keys.length - 1]] : [];
}

function onPointerMove(e) {
  if (!state.mesh) return;
  pointer.pendingMove = { clientX: e.clientX, clientY: e.clientY };
  if (!pointer.moveScheduled) {
    pointer.moveScheduled = true;
    requestAnimationFrame(processMove);
  }
}

function endPress(e) {
  if (pointer.drag) {
    // Apply the last position now (a pending frame may not have run yet).
    pointer.pendingMove = { clientX: e.clientX, clientY: e.clientY };
    processMove();
    const { before, startVertex, lineId, keyIndex } = pointer.drag;
    const line = state.lines.find((l) => l.id === lineId);
    if (line && line.keys[keyIndex] !== startVertex) history.record(before, `move key ${keyIndex + 1} of ${line.name}`);
    renderHistoryButtons();
  } else if (pointer.press) {
    // A press on a marker without moving selects that key (and its line).
    const { key } = pointer.press;
    state.activeLineId = key.lineId;
    state.selectedKey = { lineId: key.lineId, keyIndex: key.keyIndex };
    const line = activeLine();
    showMessage(`Selected key ${key.keyIndex + 1} of ${line?.name}: drag it to move it, Delete removes it.`);
    refresh();
  }
  viewer.canvas.releasePointerCapture?.(pointer.press?.pointerId ?? pointer.drag?.pointerId);
  pointer.press = null;
  pointer.drag = null;
  viewer.controls.enabled = true;
  viewer.canvas.style.cursor = '';
}

function onPointerUp(e) {
  if (pointer.press || pointer.drag) return endPress(e);
  const down = pointer.down;
  pointer.down = null;
  if (!down || e.button !== 0 || !state.mesh) return;
  // A click (not an orbit drag) adds a key where the surface was hit.
  if (Math.hypot(e.clientX - down.x, e.clientY - down.y) > CLICK_SLOP_PIXELS) return;
  const target = keyVertexAt(e.clientX, e.clientY, lastKeyOfActiveLine());
  if (!target) {
    showMessage('That click missed the mesh: click on the surface to place a key.');
    return;
  }
  const before = snapshot();
  if (addKey(target.vertex)) {
    state.lastClickAdd = { time: performance.now(), before, x: e.clientX, y: e.clientY };
    const line = activeLine();
    showMessage(`Key ${line.keys.length} of ${line.name}: vertex ${target.vertex}${target.snapped ? ` (snapped from ${target.hit.vertex} to the strongest feature nearby)` : ''}.`);
  }
}

// Double-click: orbit around the point under the pointer. The double-click's first click
// placed a key the user did not mean; it is taken back (not kept for redo).
function onDoubleClick(e) {
  if (!state.mesh) return;
  const last = state.lastClickAdd;
  if (last && performance.now() - last.time < 800 && Math.hypot(e.clientX - last.x, e.clientY - last.y) <= CLICK_SLOP_PIXELS * 2) {
    history.discardLast();
    restore(last.before);
    afterEdit();
  }
  state.lastClickAdd = null;
  const hit = viewer.pickVertex(e.clientX, e.clientY);
  if (!hit) return;
  viewer.setOrbitCenter(hit.point);
  showMessage(`Orbiting around vertex ${hit.vertex} (double-click elsewhere to move the centre; F frames the mesh).`);
}

// ---- keyboard -----------------------------------------------------------------------------------------------
function typingInField(e) {
  const t = e.target;
  return t && (t.tagName === 'INPUT' || t.tagName === 'SELECT' || t.tagName === 'TEXTAREA' || t.isContentEditable) && t.type !== 'checkbox' && t.type !== 'radio';
}

function toggleHelp(show = $('help').hidden) {
  $('help').hidden = !show;
  if (show) $('help-close').focus();
}

function onKeyDown(e) {
  const ctrl = e.ctrlKey || e.metaKey;
  if (e.key === 'Escape') {
    if (confirmResolver) return confirmResolver(false);
    if (!$('help').hidden) return toggleHelp(false);
    if (pointer.drag) {
      // Cancel the drag: put the key back.
      restore(pointer.drag.before);
      pointer.drag = null;
      pointer.press = null;
      viewer.controls.enabled = true;
      afterEdit();
      return;
    }
    state.selectedKey = null;
    refresh();
    return;
  }
  if (confirmResolver) return;
  if (ctrl && (e.key === 'z' || e.key === 'Z')) {
    if (typingInField(e)) return; // the field's own undo
    e.preventDefault();
    return e.shiftKey ? redo() : undo();
  }
  if (ctrl && (e.key === 'y' || e.key === 'Y') && !typingInField(e)) {
    e.preventDefault();
    return redo();
  }
  if (ctrl && (e.key === 's' || e.key === 'S')) {
    e.preventDefault();
    return saveSession();
  }
  if (ctrl && (e.key === 'o' || e.key === 'O')) {
    e.preventDefault();
    return $('file-input').click();
  }
  if (ctrl || e.altKey || typingInField(e)) return;
  const actions = {
    Delete: deleteSelectedKey,
    Backspace: deleteSelectedKey,
    n: addLine,
    c: () => setClosed(!activeLine()?.closed),
    s: () => setSnapping(!state.snapping),
    f: () => viewer.fitView(),
    e: () => toggleEdges(),
    '?': () => toggleHelp(),
    h: () => toggleHelp(),
  };
  const action = actions[e.key];
  if (!action) return;
  if (e.target?.tagName === 'BUTTON' && (e.key === 'Enter' || e.key === ' ')) return;
  e.preventDefault();
  action();
}

function setSnapping(on) {
  state.snapping = on;
  $('snap-toggle').checked = on;
  showMessage(on ? 'Snapping on: a click places the key on the strongest feature vertex nearby.' : 'Snapping off: a click places the key on the vertex clicked.');
}

function toggleEdges(on = !viewer.edgesShown) {
  viewer.showEdges(on);
  $('edges-toggle').checked = on;
}

// ---- wiring ------------------------------------------------------------------------------------------------
function wire() {
  const host = $('canvas-host');
  host.addEventListener('pointerdown', onPointerDown, { capture: true });
  host.addEventListener('pointermove', onPointerMove);
  host.addEventListener('dblclick', onDoubleClick);
  host.addEventListener('pointerleave', () => {
    $('readout').hidden = true;
    viewer.setSnapPreview(null);
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
  $('reset-view').addEventListener('click', () => viewer.fitView());
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
  $('download-glb').addEventListener('click', () => downloadLines('glb'));
  $('download-segmented').addEventListener('click', downloadSegmented);
  document.querySelector('#legend .legend-bar').style.background = divergingCss();
  // Small windows start with the long sections folded, so the lines stay in view.
  if (window.innerHeight < 800) $('options-section').open = false;
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
    return state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed, result: l.result, error: l.error, stale: isStale(l) }));
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
  sceneStats: () => viewer.sceneStats(),
  probe: () => viewer.probe(),
};

wire();
loadOptionTables();
renderMeshInfo();
refresh();
showMessage('Open a bundled sample, or drop a mesh file anywhere on the page (? for help).');
loadSamples();
