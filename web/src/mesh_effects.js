// Opening a mesh, as effects on the store: upload with progress, the compact mesh download,
// the page's per-mesh tables (adjacency, the outline from the server's creases, CAD and up-axis
// guesses), samples, sessions, and uploading again when the server forgot the mesh. No DOM:
// `api` is the HTTP API (api.js) with the samples, or a fake, and `deps` what the browser adds
// (readMesh: GLB bytes -> indexed mesh arrays; confirm: a yes/no question; viewState: the camera).
import { ApiError, MESH_FORMATS, formatOfFileName, withRetry } from './api.js';
import { addLineTo, applySession, retryNotice, showMessage } from './actions.js';
import { curvatureRange } from './colors.js';
import { dihedralCreases, guessUpAxis, looksLikeCad, sharpEdges, vertexAdjacency } from './geometry.js';
import { hasWork } from './model.js';
import { parseSession, rememberedUpAxis, sessionDocument } from './session.js';
import { errorText, formatBytes } from './text.js';

// Expected bytes of the server's compact mesh.glb (8 bytes a vertex, indices of 1, 2 or 4
// bytes) to show download progress when the answer is compressed and its decoded size is
// unknown.
export function expectedGlbBytes(d) {
  const indexBytes = d.vertices < 0xff ? 1 : d.vertices < 0xffff ? 2 : 4;
  return d.vertices * 8 + d.faces * 3 * indexBytes + 2048;
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

// The creases to outline: the server's, those the lines follow. Where the angle the server
// chose is 180 degrees or more it marks none at all: a coarse mesh whose creases are most of
// its edges (a 12-triangle box) reads them as noise. There, and from a server that sends no
// creases, the page outlines the edges past 30 degrees itself so such a part still shows them.
export function outlineCreases(mesh) {
  if (mesh.creaseAngle == null || mesh.creaseAngle >= 180) return dihedralCreases(mesh.positions, mesh.index, 30);
  return mesh.creaseEdges;
}

// What a session file holds of the current state.
export function sessionParts(state, view = null) {
  return { mesh: state.mesh, lines: state.lines, options: state.options, upAxis: state.upAxis, view: state.mesh ? view : null };
}

export function createMeshEffects(store, api, { readMesh, confirm = async () => true, viewState = () => null, lineRequests = null, now = () => performance.now(), afterFrame = (f) => setTimeout(f, 0) } = {}) {
  const state = store.state;
  const setProgress = (progress) => store.update(null, (s) => void (s.progress = progress));
  const message = (text, options) => showMessage(store, text, options);

  // Uploads a file, downloads the prepared mesh, and shows it. `keepLines`: the mesh is the
  // same file again (the server forgot it), so the lines stay.
  async function openMesh(name, bytes, format, { keepLines = false, confirmed = false } = {}) {
    if (state.loading) {
      message(`Still opening ${state.loadingName}; open ${name} again when it is done.`, { error: true });
      return false;
    }
    if (!keepLines && !confirmed && hasWork(state) && !state.pendingSession) {
      const keys = state.lines.reduce((n, l) => n + l.keys.length, 0);
      const ok = await confirm(
        `Open ${name}? The ${state.lines.length} line(s) and ${keys} key(s) on ${state.mesh?.name ?? 'the current mesh'} will be closed (save the session first to keep them).`,
        `Open ${name}`,
      );
      if (!ok) {
        message(`Kept ${state.mesh?.name}; ${name} was not opened.`);
        return false;
      }
    }
    store.update(null, (s) => {
      s.loading = true;
      s.loadingName = name;
    });
    const started = now();
    const total = Array.isArray(bytes) ? bytes.reduce((n, f) => n + f.size, 0) : (bytes.size ?? bytes.byteLength ?? 0);
    message(`Opening ${name}…`);
    setProgress({ fraction: 0, text: `uploading 0% of ${formatBytes(total)}` });
    try {
      const description = await withRetry(
        () =>
          api.uploadMesh(bytes, {
            format,
            onProgress: ({ loaded, total: t, phase }) => {
              if (phase === 'upload') store.update(null, (s) => void (s.uploadProgress = { loaded, total: t }));
              if (phase === 'prepare') setProgress({ fraction: null, text: 'preparing on the server…' });
              else if (t > 0) setProgress({ fraction: loaded / t, text: `uploading ${Math.round((100 * loaded) / t)}% of ${formatBytes(t)}` });
            },
          }),
        { onRetry: (r) => retryNotice(store, `Uploading ${name}`, r) },
      );
      const uploaded = now();
      await showServerMesh(description, name, { keepLines });
      store.update(null, (s) => void (s.source = { name, bytes, format }));
      // Time to the first frame showing the mesh (the benchmark reads it).
      const shown = now();
      afterFrame(() => store.update(null, (s) => void (s.openTimings = { name, uploadMs: uploaded - started, downloadAndBuildMs: shown - uploaded, firstRenderMs: now() - started })));
      setProgress(null);
      if (!keepLines) message(`Opened ${name}. Click the surface to place keys (? for help).`);
      if (state.pendingSession) await applyPendingSession();
      return true;
    } catch (e) {
      setProgress(null);
      message(`Could not open ${name}: ${errorText(e)}`, { error: true });
      return false;
    } finally {
      store.update(null, (s) => void (s.loading = false)); // lines edited while loading (a session applied) go out now
    }
  }

  async function showServerMesh(description, name, { keepLines = false } = {}) {
    const id = description.mesh_id;
    setProgress({ fraction: 0, text: 'downloading the prepared mesh…' });
    let progressEvents = 0,
      progressBytes = 0;
    const glb = await withRetry(() =>
      api.meshGlb(id, {
        expectedBytes: expectedGlbBytes(description),
        onProgress: ({ received, total }) => {
          progressEvents++;
          progressBytes = received;
          setProgress({ fraction: total ? Math.min(0.99, received / total) : null, text: `downloading the prepared mesh: ${formatBytes(received)}${total ? ` of about ${formatBytes(total)}` : ''}` });
        },
      }),
    );
    const mesh = await readMesh(glb.bytes);
    // The compact GLB carries the curvature (16-bit over its range); /curvature only without it.
    const curvature = mesh.curvature ?? (await withRetry(() => api.curvature(id)));
    if (keepLines && state.mesh && mesh.vertexCount !== state.mesh.vertexCount)
      throw new Error(`the file now has ${mesh.vertexCount} vertices, not ${state.mesh.vertexCount}; the keys would not match`);
    const sameFile = state.mesh && state.mesh.name === name && state.mesh.vertexCount === mesh.vertexCount;
    if (!sameFile) lineRequests?.clearCache(); // keys of another mesh mean other vertices
    const sharp = sharpEdges(mesh.positions, mesh.index, outlineCreases(mesh));
    const cad = looksLikeCad(sharp, mesh.faceCount);
    store.update(null, (s) => {
      s.download = { received: glb.bytes.byteLength, wireBytes: glb.wireBytes, encoding: glb.encoding, progressEvents, progressBytes };
      s.mesh = { id, name, description, vertexCount: mesh.vertexCount, faceCount: mesh.faceCount };
      s.geometry = mesh;
      s.curvature = curvature.length === mesh.vertexCount ? curvature : null;
      s.curvatureRange = s.curvature ? curvatureRange(s.curvature) : 0;
      s.adjacency = vertexAdjacency(mesh.index, mesh.vertexCount);
      s.sharp = sharp;
      s.cad = cad;
      s.flatShading = cad;
      s.edgesShown = cad;
      s.upAxis = rememberedUpAxis(name) ?? guessUpAxis(boundingSize(mesh.positions), description.format);
      s.segmentation = null;
      s.decomposeMessage = '';
      s.decomposeStatus = '';
      s.decomposeError = false;
      if (s.colorChoice === 'segments') s.colorChoice = 'plain';
      s.hoverKey = null;
      s.tracePreview = null;
      if (!keepLines) {
        s.lines = [];
        s.nextLineId = 1;
        s.lastResult = null;
        s.selectedKey = null;
        addLineTo(s);
      } else {
        for (const line of s.lines) line.resultKey = null; // ask the new session again
      }
    });
    if (!keepLines) store.history.clear();
  }

  // Files from the chooser or a drop: a .gltf with other files is opened with them (its .bin
  // files; the server packs them); otherwise the first mesh (or session) file is opened, and the
  // user is told when others were left out.
  function openFiles(fileList) {
    const files = [...(fileList || [])];
    if (!files.length) return;
    const gltf = files.find((f) => /\.gltf$/i.test(f.name));
    if (gltf && files.length > 1) {
      message(`Opening ${gltf.name} with ${files.length - 1} file(s) beside it.`);
      openMesh(gltf.name, [gltf, ...files.filter((f) => f !== gltf)], 'gltf');
      return;
    }
    const first = files[0];
    const note = files.length > 1 ? `${files.length} files dropped: opening the first, ${first.name} (one at a time). ` : '';
    if (/\.json$/i.test(first.name)) {
      if (note) message(note);
      loadSessionFile(first);
      return;
    }
    const format = formatOfFileName(first.name);
    if (!format) {
      message(`${note}${first.name} is not a mesh file this page knows (${MESH_FORMATS.join(', ')}); sending it anyway, the server will say.`);
    } else if (note) {
      message(note);
    }
    openMesh(first.name, first, format).then((opened) => {
      if (opened && note) message(`${note.replace('opening', 'opened')}Click the surface to place keys.`);
    });
  }

  async function loadSamples() {
    try {
      const samples = await api.sampleList();
      store.update(null, (s) => void (s.samples = samples));
    } catch (e) {
      console.warn('no sample list', e);
    }
  }

  async function openSample(file, options) {
    const sample = state.samples.find((s) => s.file === file);
    if (!sample) return false;
    try {
      return await openMesh(`${sample.name}.${sample.format}`, await api.sampleBytes(sample.file), sample.format, options);
    } catch (e) {
      message(`Could not read the sample: ${errorText(e)}`, { error: true });
      return false;
    }
  }

  // The server forgot the mesh (expired after idling, evicted, deleted): upload the same file
  // again and re-create every line on it. Vertex ids are the file's own, so keys stay valid.
  async function recoverMesh(reason) {
    if (state.recovering) return false;
    if (!state.source) {
      const doc = sessionDocument(sessionParts(state, viewState()));
      store.update(null, (s) => void (s.pendingSession = doc));
      message(`The server no longer has ${state.mesh?.name} (${reason}). Open that file again and the ${state.lines.length} line(s) will be re-created.`, { error: true });
      return false;
    }
    store.update(null, (s) => void (s.recovering = true));
    const { name, bytes, format } = state.source;
    message(`The server had forgotten ${name}; uploading it again…`);
    try {
      const ok = await openMesh(name, bytes, format, { keepLines: true });
      if (ok) message(`The server had forgotten ${name} (${reason}); uploaded it again and re-created ${state.lines.length} line(s).`);
      return ok;
    } finally {
      store.update(null, (s) => void (s.recovering = false));
    }
  }

  async function loadSessionFile(file) {
    let doc;
    try {
      const raw = JSON.parse(await file.text());
      // A lines download carries the session too (its "lines" are results: use session_lines).
      if (raw && Array.isArray(raw.session_lines)) raw.lines = raw.session_lines;
      doc = parseSession(JSON.stringify(raw));
    } catch (e) {
      return message(`Could not load the session ${file.name}: ${e.message}`, { error: true });
    }
    await loadSessionDocument(doc);
  }

  // Finds the session's mesh: already open, still on the server, a bundled sample, or else the
  // user is asked to open the file; the lines are then re-created.
  async function loadSessionDocument(doc) {
    const m = state.mesh;
    if (m && (m.id === doc.mesh.id || (m.name === doc.mesh.name && m.vertexCount === doc.mesh.vertices))) return applySession(store, doc);
    if (hasWork(state) && !(await confirm(`Load the session for ${doc.mesh.name}? The lines on ${m?.name} will be closed.`, 'Load session'))) return;
    store.update(null, (s) => void (s.pendingSession = doc));
    if (doc.mesh.id) {
      try {
        const description = await api.describeMesh(doc.mesh.id);
        if (description.vertices === doc.mesh.vertices) {
          store.update(null, (s) => void (s.loading = true));
          try {
            await showServerMesh(description, doc.mesh.name);
            store.update(null, (s) => void (s.source = null)); // not uploaded from this page: asked for if the server forgets it
          } finally {
            setProgress(null);
            store.update(null, (s) => void (s.loading = false));
          }
          return applyPendingSession();
        }
      } catch (e) {
        if (!(e instanceof ApiError && e.isMeshGone)) {
          store.update(null, (s) => void (s.pendingSession = null));
          return message(`Could not load the session: ${errorText(e)}`, { error: true });
        }
      }
    }
    const sample = state.samples.find((s) => `${s.name}.${s.format}` === doc.mesh.name);
    if (sample) return openSample(sample.file, { confirmed: true });
    message(`The server no longer has ${doc.mesh.name}: open that file (drop it or choose it) and the session's ${doc.lines.length} line(s) will be re-created.`);
  }

  async function applyPendingSession() {
    const doc = state.pendingSession;
    store.update(null, (s) => void (s.pendingSession = null));
    if (!doc || !state.mesh) return;
    if (state.mesh.vertexCount !== doc.mesh.vertices) {
      message(`${state.mesh.name} has ${state.mesh.vertexCount} vertices, the session's ${doc.mesh.name} had ${doc.mesh.vertices}: the session was not applied (its keys would be other vertices).`, { error: true });
      return;
    }
    applySession(store, doc);
  }

  return { openMesh, showServerMesh, openFiles, loadSamples, openSample, recoverMesh, loadSessionFile, loadSessionDocument, applyPendingSession };
}
