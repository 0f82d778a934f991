// Opening a mesh: upload with progress, the compact mesh download, the page's per-mesh tables
// (adjacency, sharp edges, up axis), samples, and uploading again when the server forgot it;
// and the session files, downloads of lines and parts.
import * as api from './api.js';
import { $, confirmAction, errorText, formatBytes, hasWork, history, num, resultCache, serverText, showMessage, state, viewer } from './app.js';
import { curvatureRange } from './colors.js';
import { guessUpAxis, looksLikeCad, sharpEdges, vertexAdjacency } from './geometry.js';
import { LINE_FILE_FORMATS, nameLinesInFile } from './line_files.js';
import { addLineUnrecorded, edit, keysProblem, pump, retryNotice } from './lines.js';
import { writeOptionsForm } from './options_panel.js';
import { applyColors, refresh, renderUpAxis, setUpAxis } from './panel.js';
import { clearSegmentation, readyLines, segmentedObject } from './segmentation_panel.js';
import { parseSession, rememberedUpAxis, sessionDocument } from './session.js';
import { exportGlb, indexedMeshFromGltf, parseGlb } from './viewer.js';

// ---- opening a mesh -----------------------------------------------------------------------
export function setProgress(visible, fraction = 0, text = '') {
  $('upload-progress').hidden = !visible;
  const bar = $('upload-bar');
  if (fraction === null) bar.removeAttribute('value');
  else bar.value = fraction;
  $('upload-text').textContent = text;
}

// Uploads a file, downloads the prepared mesh, and shows it. `keepLines`: the mesh is the
// same file again (the server forgot it), so the lines stay.
export async function openMesh(name, bytes, format, { keepLines = false, confirmed = false } = {}) {
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
  const total = Array.isArray(bytes) ? bytes.reduce((n, f) => n + f.size, 0) : (bytes.size ?? bytes.byteLength ?? 0);
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
export function expectedGlbBytes(d) {
  const indexBytes = d.vertices < 0xff ? 1 : d.vertices < 0xffff ? 2 : 4;
  return d.vertices * 8 + d.faces * 3 * indexBytes + 2048;
}

export async function showServerMesh(description, name, { keepLines = false } = {}) {
  const id = description.mesh_id;
  setProgress(true, 0, 'downloading the prepared mesh…');
  let progressEvents = 0, progressBytes = 0;
  const glb = await api.withRetry(() =>
    api.meshGlb(id, {
      expectedBytes: expectedGlbBytes(description),
      onProgress: ({ received, total }) => {
        progressEvents++;
        progressBytes = received;
        setProgress(true, total ? Math.min(0.99, received / total) : null, `downloading the prepared mesh: ${formatBytes(received)}${total ? ` of about ${formatBytes(total)}` : ''}`);
      },
    }),
  );
  state.download = { received: glb.bytes.byteLength, wireBytes: glb.wireBytes, encoding: glb.encoding, progressEvents, progressBytes };
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

export function boundingSize(positions) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3)
    for (let k = 0; k < 3; ++k) {
      min[k] = Math.min(min[k], positions[i + k]);
      max[k] = Math.max(max[k], positions[i + k]);
    }
  return max.map((m, k) => m - min[k]);
}

export function renderMeshInfo() {
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

// Files from the chooser or a drop: a .gltf with other files is opened with them (its .bin
// files; the server packs them); otherwise the first mesh (or session) file is opened, and the
// user is told when others were left out.
export function openFiles(fileList) {
  const files = [...(fileList || [])];
  if (!files.length) return;
  const gltf = files.find((f) => /\.gltf$/i.test(f.name));
  if (gltf && files.length > 1) {
    showMessage(`Opening ${gltf.name} with ${files.length - 1} file(s) beside it.`);
    openMesh(gltf.name, [gltf, ...files.filter((f) => f !== gltf)], 'gltf');
    return;
  }
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

export async function loadSamples() {
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

export async function openSample(file, options) {
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
export async function recoverMesh(reason) {
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

// ---- downloads, sessions ----------------------------------------------------------------------------------------
export function saveBlob(blob, name) {
  const url = URL.createObjectURL(blob);
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

export function baseName() {
  return (state.mesh?.name || 'mesh').replace(/\.[^.]+$/, '');
}

export async function downloadLines(format) {
  if (!state.mesh) return;
  const lines = readyLines();
  if (!lines.length) return showMessage('No line to download: place at least two keys.', { error: true });
  try {
    if (LINE_FILE_FORMATS[format]) {
      await downloadLineFile(format, lines);
    } else {
      const answer = await api.withRetry(() => api.detectFeatureLines(state.mesh.id, { lines }));
      // The session fields make the file loadable again (Load session).
      const doc = { ...sessionDocument(currentSessionParts()), mesh_id: state.mesh.id, requests: lines, lines: answer.lines };
      doc.session_lines = sessionDocument(currentSessionParts()).lines;
      saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-lines.json`);
    }
    showMessage(`Downloaded ${lines.length} line(s) as ${format === 'polylines' ? 'CGAL polylines' : format.toUpperCase()}${format === 'json' || format === 'polylines' ? '' : ', named as here'}.`);
  } catch (e) {
    if (e instanceof api.ApiError && e.isMeshGone) return recoverMesh(e.message);
    showMessage(`Download failed: ${serverText(e)}`, { error: true });
  }
}

// A file the server writes, with the page's line names put in (line_files.js).
async function downloadLineFile(format, lines) {
  const { extension, type, binary } = LINE_FILE_FORMATS[format];
  const names = state.lines.filter((l) => !keysProblem(l)).map((l) => l.name);
  const response = await api.withRetry(() => api.featureLinesFile(state.mesh.id, { lines }, format));
  const content = binary ? await response.arrayBuffer() : await response.text();
  saveBlob(new Blob([nameLinesInFile(format, content, names)], { type }), `${baseName()}-lines${extension}`);
}

// Saves the decomposition the page already has as GLB (one mesh per part, the answer's
// colours), written in the page: no request.
export async function downloadSegmented() {
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

export function currentSessionParts() {
  return { mesh: state.mesh, lines: state.lines, options: state.options, upAxis: state.upAxis, view: state.mesh ? viewer.viewState() : null };
}

export function saveSession() {
  if (!state.mesh) return showMessage('Open a mesh first: a session is the work on one mesh.', { error: true });
  const doc = sessionDocument(currentSessionParts());
  saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-session.json`);
  showMessage(`Saved the session: ${doc.lines.length} line(s) on ${doc.mesh.name}.`);
}

export async function loadSessionFile(file) {
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
export async function loadSessionDocument(doc) {
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

export async function applyPendingSession() {
  const doc = state.pendingSession;
  state.pendingSession = null;
  if (!doc || !state.mesh) return;
  if (state.mesh.vertexCount !== doc.mesh.vertices) {
    showMessage(`${state.mesh.name} has ${state.mesh.vertexCount} vertices, the session's ${doc.mesh.name} had ${doc.mesh.vertices}: the session was not applied (its keys would be other vertices).`, { error: true });
    return;
  }
  applySession(doc);
}

export function applySession(doc) {
  edit(`load session (${doc.lines.length} lines)`, () => {
    state.lines = [];
    state.nextLineId = 1;
    for (const l of doc.lines) {
      const line = addLineUnrecorded();
      if (l.name) line.name = l.name;
      line.keys = [...l.keys];
      line.closed = !!l.closed;
      line.trace = l.trace === true;
    }
    if (!state.lines.length) addLineUnrecorded();
    state.activeLineId = state.lines[0].id;
    state.options = structuredClone(doc.options ?? {});
    writeOptionsForm(state.options);
    state.selectedKey = null;
  });
  if (doc.up_axis === 'y' || doc.up_axis === 'z') setUpAxis(doc.up_axis);
  if (doc.view) {
    viewer.setViewState(doc.view);
    $('ortho-toggle').checked = viewer.orthographic;
  }
  showMessage(`Loaded the session: ${doc.lines.length} line(s) on ${state.mesh.name}.`);
}
