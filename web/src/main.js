// The Featureline page: open a mesh, place keys, see the initial and refined lines,
// tune options, decompose the mesh along the lines, download the results.
import * as api from './api.js';
import { curvatureRange, diverging, divergingCss, labelColor, rgbCss } from './colors.js';
import { Viewer, parseGlb, indexedMeshFromGltf } from './viewer.js';

const $ = (id) => document.getElementById(id);

const state = {
  mesh: null, // {id, name, description, vertexCount, faceCount}
  curvature: null, // Float32Array per vertex
  curvatureRange: 0,
  lines: [],
  activeLineId: 0,
  nextLineId: 1,
  options: {},
  optionsValid: true,
  inFlight: null, // the line whose request is running (at most one request at a time)
  requestCount: 0,
  responseCount: 0,
  lastResult: null,
  lastResultLineId: 0,
  segmentation: null, // {request, answer, faceColored, remeshed}
  decomposeMessage: '',
  message: '',
  samples: [],
  loading: false,
  colorMode: 'plain', // plain | curvature | segments
  uploadProgress: null, // the last upload progress event {loaded, total}
};

const viewer = new Viewer($('canvas-host'));
let idleWaiters = [];

// ---- messages ---------------------------------------------------------------------------
function showMessage(text, { error = false } = {}) {
  state.message = text;
  const el = $('message');
  el.textContent = text;
  el.classList.toggle('error', error);
}

function errorText(e) {
  return e instanceof api.ApiError ? e.toString() : e?.message ?? String(e);
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

// ---- opening a mesh -----------------------------------------------------------------------
function setProgress(visible, fraction = 0, text = '') {
  $('upload-progress').hidden = !visible;
  const bar = $('upload-bar');
  if (fraction === null) bar.removeAttribute('value');
  else bar.value = fraction;
  $('upload-text').textContent = text;
}

async function openMesh(name, bytes, format) {
  if (state.loading) return;
  state.loading = true;
  const total = bytes.size ?? bytes.byteLength ?? 0;
  showMessage(`Opening ${name}…`);
  setProgress(true, 0, `uploading 0% of ${formatBytes(total)}`);
  try {
    const description = await api.uploadMesh(bytes, {
      format,
      onProgress: ({ loaded, total: t, phase }) => {
        if (phase === 'upload') state.uploadProgress = { loaded, total: t };
        if (phase === 'prepare') setProgress(true, null, 'preparing on the server…');
        else if (t > 0) setProgress(true, loaded / t, `uploading ${Math.round((100 * loaded) / t)}% of ${formatBytes(t)}`);
      },
    });
    setProgress(true, null, 'loading the prepared mesh…');
    await loadSession(description, name);
    setProgress(false);
    showMessage(`Opened ${name}. Click the surface to place keys.`);
  } catch (e) {
    setProgress(false);
    showMessage(`Could not open ${name}: ${errorText(e)}`, { error: true });
  } finally {
    state.loading = false;
    settleIdle();
  }
}

async function loadSession(description, name) {
  const id = description.mesh_id;
  const [glb, curvature] = await Promise.all([api.meshGlb(id), api.curvature(id)]);
  const mesh = indexedMeshFromGltf(await parseGlb(glb));
  if (mesh.vertexCount !== description.vertices)
    console.warn(`mesh.glb has ${mesh.vertexCount} vertices, the description ${description.vertices}`);
  state.mesh = { id, name, description, vertexCount: mesh.vertexCount, faceCount: mesh.faceCount };
  state.curvature = curvature.length === mesh.vertexCount ? curvature : null;
  state.curvatureRange = state.curvature ? curvatureRange(state.curvature) : 0;
  state.lines = [];
  state.nextLineId = 1;
  state.lastResult = null;
  state.segmentation = null;
  state.decomposeMessage = '';
  viewer.setMesh(mesh);
  $('empty-hint').hidden = true;
  addLine();
  $('segments-toggle').checked = false;
  $('segments-toggle').disabled = true;
  $('download-segmented').disabled = true;
  $('decompose-status').textContent = '';
  renderSegments();
  applyColors();
  renderMeshInfo();
  renderTimings();
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
    d.expires_in_s == null ? 'preloaded: never expires' : `expires after ${Math.round(d.expires_in_s)} s unused`,
  ];
  if (d.warnings?.length) lines.push(`warnings: ${d.warnings.join('; ')}`);
  $('mesh-info').textContent = lines.join('\n');
}

function openFile(file) {
  const format = api.formatOfFileName(file.name);
  openMesh(file.name, file, format);
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

async function openSample(file) {
  const sample = state.samples.find((s) => s.file === file);
  if (!sample) return;
  try {
    const response = await fetch(sample.file);
    if (!response.ok) throw new Error(`HTTP ${response.status} for ${sample.file}`);
    await openMesh(`${sample.name}.${sample.format}`, await response.arrayBuffer(), sample.format);
  } catch (e) {
    showMessage(`Could not read the sample: ${errorText(e)}`, { error: true });
  }
}

// ---- colours --------------------------------------------------------------------------------
function applyColors() {
  if (!state.mesh) return;
  const seg = state.segmentation;
  if ($('segments-toggle').checked && seg) {
    if (seg.faceColored) {
      const labels = seg.answer.labels;
      viewer.setFaceColors((f) => (labels[f] >= 0 ? labelColor(labels[f]) : [0.5, 0.5, 0.5]));
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
}

// ---- lines ------------------------------------------------------------------------------------
function activeLine() {
  return state.lines.find((l) => l.id === state.activeLineId) || null;
}

function addLine() {
  const line = {
    id: state.nextLineId++,
    keys: [],
    closed: false,
    result: null,
    error: '',
    version: 0, // bumped on every change
    sentVersion: 0, // the version of the last request sent (or settled without one)
  };
  line.name = `Line ${line.id}`;
  state.lines.push(line);
  state.activeLineId = line.id;
  refresh();
  return line;
}

function deleteLine(id) {
  state.lines = state.lines.filter((l) => l.id !== id);
  if (state.lines.length === 0) addLine();
  if (!activeLine()) state.activeLineId = state.lines[state.lines.length - 1].id;
  refresh();
}

// Whether keys can go to the server: at least two, consecutive ones distinct.
function keysProblem(line) {
  if (line.keys.length < 2) return 'place at least two keys';
  for (let i = 1; i < line.keys.length; ++i) if (line.keys[i] === line.keys[i - 1]) return `keys ${i} and ${i + 1} are the same vertex`;
  return '';
}

function changed(line) {
  line.version++;
  refresh();
  pump();
}

function canUseVertex(line, index, v) {
  const n = line.keys.length;
  const prev = index > 0 ? line.keys[index - 1] : line.closed && n > 2 ? line.keys[n - 1] : undefined;
  const next = index < n - 1 ? line.keys[index + 1] : line.closed && n > 2 ? line.keys[0] : undefined;
  return v !== prev && v !== next;
}

function addKey(vertex) {
  const line = activeLine();
  if (!line || !state.mesh) return;
  if (line.keys.length && line.keys[line.keys.length - 1] === vertex) return;
  line.keys.push(vertex);
  changed(line);
}

function moveKey(line, index, vertex) {
  if (line.keys[index] === vertex || !canUseVertex(line, index, vertex)) return false;
  line.keys[index] = vertex;
  changed(line);
  return true;
}

function deleteKey(line, index) {
  line.keys.splice(index, 1);
  changed(line);
}

function lineRequest(line) {
  const body = { keys: [...line.keys], closed: line.closed };
  if (Object.keys(state.options).length) body.options = structuredClone(state.options);
  return body;
}

// Sends the next pending line: at most one request in flight; each request carries the line's
// latest state, and a change made meanwhile is sent when the running request returns.
async function pump() {
  if (state.inFlight || !state.mesh) return settleIdle();
  const line = [activeLine(), ...state.lines].find((l) => l && l.version !== l.sentVersion);
  if (!line) return settleIdle();
  const version = line.version;
  const problem = keysProblem(line);
  if (problem || !state.optionsValid) {
    line.sentVersion = version;
    if (problem) {
      line.result = null;
      line.error = '';
    }
    refresh();
    return pump();
  }
  const meshId = state.mesh.id;
  const body = lineRequest(line);
  state.inFlight = line;
  line.sentVersion = version;
  state.requestCount++;
  $('busy').hidden = false;
  try {
    const result = await api.detectFeatureLines(meshId, body);
    if (state.mesh?.id === meshId) {
      line.result = result;
      line.error = '';
      state.lastResult = result;
      state.lastResultLineId = line.id;
    }
  } catch (e) {
    if (state.mesh?.id === meshId) {
      line.error = errorText(e);
      if (version === line.version) line.result = null;
    }
  } finally {
    state.responseCount++;
    state.inFlight = null;
    $('busy').hidden = true;
    refresh();
    pump();
  }
}

function isIdle() {
  return !state.inFlight && state.lines.every((l) => l.version === l.sentVersion) && !state.loading;
}

function settleIdle() {
  if (!isIdle()) return;
  const waiters = idleWaiters;
  idleWaiters = [];
  for (const w of waiters) w();
}

function markAllChanged() {
  for (const l of state.lines) l.version++;
  refresh();
  pump();
}

// ---- rendering the panel ---------------------------------------------------------------------------
function refresh() {
  viewer.setLines(state.lines, state.activeLineId);
  renderLineList();
  renderKeyList();
  renderLineStatus();
  renderTimings();
}

function renderLineList() {
  const ul = $('line-list');
  ul.innerHTML = '';
  for (const line of state.lines) {
    const li = document.createElement('li');
    li.classList.toggle('active', line.id === state.activeLineId);
    li.dataset.lineId = line.id;
    const name = document.createElement('span');
    name.className = 'name';
    name.textContent = `${line.name}${line.closed ? ' (loop)' : ''}`;
    const st = document.createElement('span');
    st.className = 'state';
    if (line.error) {
      st.textContent = 'error';
      st.classList.add('error');
    } else if (line.result) st.textContent = `${line.keys.length} keys · length ${num(line.result.refined.length, 3)}`;
    else st.textContent = `${line.keys.length} key${line.keys.length === 1 ? '' : 's'}`;
    const del = document.createElement('button');
    del.className = 'x';
    del.type = 'button';
    del.title = `delete ${line.name}`;
    del.textContent = '×';
    del.addEventListener('click', (e) => {
      e.stopPropagation();
      deleteLine(line.id);
    });
    li.append(name, st, del);
    li.addEventListener('click', () => {
      state.activeLineId = line.id;
      refresh();
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
    const label = document.createElement('span');
    label.textContent = `vertex ${v}`;
    const del = document.createElement('button');
    del.className = 'x';
    del.type = 'button';
    del.title = 'delete this key';
    del.textContent = '×';
    del.addEventListener('click', () => deleteKey(line, i));
    li.append(label, del);
    ol.appendChild(li);
  });
}

function renderLineStatus() {
  const line = activeLine();
  const el = $('line-status');
  el.classList.remove('error');
  if (!state.mesh) {
    el.textContent = 'Open a mesh first.';
    return;
  }
  if (!line) return (el.textContent = '');
  if (line.error) {
    el.textContent = `The server refused this line: ${line.error}`;
    el.classList.add('error');
    return;
  }
  const r = line.result;
  if (!r) {
    el.textContent = keysProblem(line) ? `${line.name}: ${keysProblem(line)}.` : `${line.name}: detecting…`;
    return;
  }
  const parts = [
    `initial (${r.initial.method}): ${r.initial.vertices.length} vertices, length ${num(r.initial.length)}`,
    `refined: ${r.refined.points.length} points, length ${num(r.refined.length)}`,
  ];
  if (r.stats.fallbacks?.length)
    parts.push(...r.stats.fallbacks.map((f) => `segment ${f.segment}: ${f.from} → ${f.to} (${f.reason})`));
  if (r.stats.warnings?.length) parts.push(...r.stats.warnings.map((w) => `warning: ${w}`));
  el.textContent = parts.join('\n');
}

function renderTimings() {
  const tbody = $('timings').querySelector('tbody');
  tbody.innerHTML = '';
  const line = activeLine();
  const r = line?.result || state.lastResult;
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

let optionsTimer = 0;
function optionsChanged() {
  clearTimeout(optionsTimer);
  optionsTimer = setTimeout(() => {
    const { options, problems } = readOptions();
    $('options-error').hidden = problems.length === 0;
    $('options-error').textContent = problems.join('\n');
    state.optionsValid = problems.length === 0;
    if (!state.optionsValid) return;
    if (JSON.stringify(options) === JSON.stringify(state.options)) return;
    state.options = options;
    markAllChanged();
  }, 250);
}

// ---- decomposition -------------------------------------------------------------------------------------
function readyLines() {
  return state.lines.filter((l) => !keysProblem(l)).map(lineRequest);
}

async function decompose() {
  if (!state.mesh) return;
  const lines = readyLines();
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
  try {
    const answer = await api.segmentation(meshId, request);
    if (state.mesh?.id !== meshId) return;
    await applySegmentation(request, answer);
  } catch (e) {
    let text = `Decomposition failed: ${errorText(e)}`;
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
  }
}

async function applySegmentation(request, answer) {
  if (!answer || !Array.isArray(answer.labels) || !Array.isArray(answer.segments))
    throw new api.ApiError(0, '', 'the server answered the decomposition in an unknown shape');
  const faceColored = answer.labels.length === state.mesh.faceCount;
  const seg = { request, answer, faceColored, sceneLoaded: false };
  viewer.setSegmentScene(null);
  state.segmentation = seg;
  const parts = [`${answer.segments.length} segment(s)`];
  if (!faceColored) {
    // Remesh mode: the labels are for the remeshed surface; show the server's segmented GLB.
    try {
      const blob = await api.segmentationGlb(state.mesh.id, request);
      viewer.setSegmentScene(await parseGlb(await blob.arrayBuffer()));
      seg.sceneLoaded = true;
    } catch (e) {
      parts.push(`the labels are for a remeshed surface of ${answer.labels.length} faces; its colours cannot be shown (${errorText(e)})`);
    }
  }
  if (answer.warnings?.length) parts.push(...answer.warnings.map((w) => `warning: ${w}`));
  state.decomposeMessage = parts.join('\n');
  $('decompose-status').textContent = state.decomposeMessage;
  $('segments-toggle').disabled = !(faceColored || seg.sceneLoaded);
  $('segments-toggle').checked = faceColored || seg.sceneLoaded;
  if ($('segments-toggle').checked) $('curvature-toggle').checked = false;
  $('download-segmented').disabled = false;
  renderSegments();
  applyColors();
}

function renderSegments() {
  const tbody = $('segments').querySelector('tbody');
  tbody.innerHTML = '';
  const seg = state.segmentation;
  $('segments').hidden = !seg;
  if (!seg) return;
  let totalArea = 0;
  for (const s of seg.answer.segments) {
    totalArea += Number(s.area) || 0;
    const tr = document.createElement('tr');
    const sw = document.createElement('td');
    const box = document.createElement('span');
    box.className = 'swatch';
    box.style.background = rgbCss(labelColor(s.label));
    sw.appendChild(box);
    tr.appendChild(sw);
    for (const v of [s.label, s.faces, num(s.area), num(s.boundary_length)]) {
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
}

// ---- downloads ----------------------------------------------------------------------------------------
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
      saveBlob(await api.featureLinesGlb(state.mesh.id, { lines }), `${baseName()}-lines.glb`);
    } else {
      const answer = await api.detectFeatureLines(state.mesh.id, { lines });
      const doc = { mesh_id: state.mesh.id, mesh: state.mesh.name, requests: lines, lines: answer.lines };
      saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-lines.json`);
    }
    showMessage(`Downloaded ${lines.length} line(s) as ${format.toUpperCase()}.`);
  } catch (e) {
    showMessage(`Download failed: ${errorText(e)}`, { error: true });
  }
}

async function downloadSegmented() {
  const seg = state.segmentation;
  if (!seg || !state.mesh) return;
  try {
    saveBlob(await api.segmentationGlb(state.mesh.id, seg.request), `${baseName()}-segments.glb`);
  } catch (e) {
    if (e instanceof api.ApiError && (e.code === 'no_glb' || [400, 404, 406, 415].includes(e.status))) {
      // No GLB from the server: save the labels and segments instead.
      const doc = { mesh_id: state.mesh.id, ...seg.answer };
      saveBlob(new Blob([JSON.stringify(doc)], { type: 'application/json' }), `${baseName()}-segments.json`);
      showMessage('The server has no GLB for segmentations; saved the labels as JSON.');
    } else {
      showMessage(`Download failed: ${errorText(e)}`, { error: true });
    }
  }
}

// ---- pointer interaction on the canvas --------------------------------------------------------------
const pointer = { down: null, drag: null, pendingMove: null, moveScheduled: false };

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
    // Drag the key: the orbit controls must not see this gesture.
    e.stopPropagation();
    e.preventDefault();
    state.activeLineId = key.lineId;
    pointer.drag = { lineId: key.lineId, keyIndex: key.keyIndex, pointerId: e.pointerId };
    viewer.controls.enabled = false;
    viewer.canvas.setPointerCapture?.(e.pointerId);
    viewer.canvas.style.cursor = 'grabbing';
    refresh();
    return;
  }
  pointer.down = { x: e.clientX, y: e.clientY, t: performance.now() };
}

function processMove() {
  pointer.moveScheduled = false;
  const e = pointer.pendingMove;
  pointer.pendingMove = null;
  if (!e) return;
  if (pointer.drag) {
    const line = state.lines.find((l) => l.id === pointer.drag.lineId);
    const hit = viewer.pickVertex(e.clientX, e.clientY);
    if (line && hit) moveKey(line, pointer.drag.keyIndex, hit.vertex);
    return;
  }
  // Hover feedback.
  const key = viewer.pickKey(e.clientX, e.clientY);
  const same = (a, b) => (a && b ? a.lineId === b.lineId && a.keyIndex === b.keyIndex : a === b);
  if (!same(key, viewer.hoverKey)) {
    viewer.hoverKey = key;
    viewer.canvas.style.cursor = key ? 'grab' : '';
    viewer.setLines(state.lines, state.activeLineId);
  }
}

function onPointerMove(e) {
  if (!state.mesh) return;
  pointer.pendingMove = { clientX: e.clientX, clientY: e.clientY };
  if (!pointer.moveScheduled) {
    pointer.moveScheduled = true;
    requestAnimationFrame(processMove);
  }
}

function onPointerUp(e) {
  if (pointer.drag) {
    // Apply the last position now (a pending frame may not have run yet).
    pointer.pendingMove = { clientX: e.clientX, clientY: e.clientY };
    processMove();
    viewer.canvas.releasePointerCapture?.(pointer.drag.pointerId);
    pointer.drag = null;
    viewer.controls.enabled = true;
    viewer.canvas.style.cursor = '';
    return;
  }
  const down = pointer.down;
  pointer.down = null;
  if (!down || e.button !== 0) return;
  // A click (not an orbit drag) adds a key where the surface was hit.
  if (Math.hypot(e.clientX - down.x, e.clientY - down.y) > 4) return;
  const hit = viewer.pickVertex(e.clientX, e.clientY);
  if (hit) addKey(hit.vertex);
}

// ---- wiring ------------------------------------------------------------------------------------------------
function wire() {
  const host = $('canvas-host');
  host.addEventListener('pointerdown', onPointerDown, { capture: true });
  host.addEventListener('pointermove', onPointerMove);
  host.addEventListener('pointerleave', () => {
    if (pointer.drag || !viewer.hoverKey) return;
    viewer.hoverKey = null;
    viewer.canvas.style.cursor = '';
    viewer.setLines(state.lines, state.activeLineId);
  });
  window.addEventListener('pointerup', onPointerUp);
  host.addEventListener('contextmenu', (e) => e.preventDefault());

  $('file-input').addEventListener('change', (e) => {
    const file = e.target.files?.[0];
    if (file) openFile(file);
    e.target.value = '';
  });
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
    const file = e.dataTransfer?.files?.[0];
    if (file) openFile(file);
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
  $('reset-view').addEventListener('click', () => viewer.fitView());
  $('add-line').addEventListener('click', () => addLine());
  $('clear-keys').addEventListener('click', () => {
    const line = activeLine();
    if (line && line.keys.length) {
      line.keys = [];
      changed(line);
    }
  });
  $('closed-toggle').addEventListener('change', (e) => {
    const line = activeLine();
    if (!line) return;
    line.closed = e.target.checked;
    changed(line);
  });
  $('options-form').addEventListener('input', optionsChanged);
  $('options-form').addEventListener('change', optionsChanged);
  $('options-form').addEventListener('submit', (e) => e.preventDefault());
  $('decompose').addEventListener('click', decompose);
  $('download-json').addEventListener('click', () => downloadLines('json'));
  $('download-glb').addEventListener('click', () => downloadLines('glb'));
  $('download-segmented').addEventListener('click', downloadSegmented);
  document.querySelector('#legend .legend-bar').style.background = divergingCss();
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
    return state.lines.map((l) => ({ id: l.id, name: l.name, keys: [...l.keys], closed: l.closed, result: l.result, error: l.error }));
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
  get options() {
    return structuredClone(state.options);
  },
  get segmentation() {
    return state.segmentation ? { faceColored: state.segmentation.faceColored, ...state.segmentation.answer } : null;
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
  get curvatureRange() {
    return state.curvatureRange;
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
  sceneStats: () => viewer.sceneStats(),
  probe: () => viewer.probe(),
};

wire();
renderMeshInfo();
refresh();
showMessage('Open a bundled sample, or drop a mesh file anywhere on the page.');
loadSamples();
