// Files the page saves: the lines as the server writes them (with the page's line names put
// in), the decomposition as GLB written in the page, and the session.
import { ApiError, withRetry } from './api.js';
import { showMessage } from './actions.js';
import { LINE_FILE_FORMATS, nameLinesInFile } from './line_files.js';
import { sessionParts } from './mesh_effects.js';
import { keysProblem, readyLines } from './model.js';
import { sessionDocument } from './session.js';
import { errorText, serverText } from './text.js';
import { exportGlb, segmentedObject } from './viewer.js';

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

// recoverMesh(reason): the server forgot the mesh (mesh_effects.js).
export function createDownloads(store, api, viewer, { recoverMesh }) {
  const state = store.state;
  const message = (text, options) => showMessage(store, text, options);
  const baseName = () => (state.mesh?.name || 'mesh').replace(/\.[^.]+$/, '');
  const currentSession = () => sessionDocument(sessionParts(state, viewer.viewState()));

  async function downloadLines(format) {
    if (!state.mesh) return;
    const lines = readyLines(state);
    if (!lines.length) return message('No line to download: place at least two keys.', { error: true });
    try {
      if (LINE_FILE_FORMATS[format]) {
        await downloadLineFile(format, lines);
      } else {
        const answer = await withRetry(() => api.detectFeatureLines(state.mesh.id, { lines }));
        // The session fields make the file loadable again (Load session).
        const doc = { ...currentSession(), mesh_id: state.mesh.id, requests: lines, lines: answer.lines };
        doc.session_lines = currentSession().lines;
        saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-lines.json`);
      }
      message(`Downloaded ${lines.length} line(s) as ${format === 'polylines' ? 'CGAL polylines' : format.toUpperCase()}${format === 'json' || format === 'polylines' ? '' : ', named as here'}.`);
    } catch (e) {
      if (e instanceof ApiError && e.isMeshGone) return recoverMesh(e.message);
      message(`Download failed: ${serverText(e)}`, { error: true });
    }
  }

  // A file the server writes, with the page's line names put in (line_files.js).
  async function downloadLineFile(format, lines) {
    const { extension, type, binary } = LINE_FILE_FORMATS[format];
    const names = state.lines.filter((l) => !keysProblem(l)).map((l) => l.name);
    const response = await withRetry(() => api.featureLinesFile(state.mesh.id, { lines }, format));
    const content = binary ? await response.arrayBuffer() : await response.text();
    saveBlob(new Blob([nameLinesInFile(format, content, names)], { type }), `${baseName()}-lines${extension}`);
  }

  // Saves the decomposition the page already has as GLB (one mesh per part, the answer's
  // colours), written in the page: no request.
  async function downloadSegmented() {
    const seg = state.segmentation;
    if (!seg || !state.mesh) return;
    try {
      const object = segmentedObject(seg, viewer.mesh) ?? viewer.segmentGroup.children[0];
      if (!object) {
        // Nothing to write as GLB: save the labels and segments instead.
        const doc = { mesh_id: state.mesh.id, ...seg.answer };
        saveBlob(new Blob([JSON.stringify(doc)], { type: 'application/json' }), `${baseName()}-segments.json`);
        message('Saved the labels and segments as JSON (the answer carries no surface to write as GLB).');
        return;
      }
      saveBlob(new Blob([await exportGlb(object)], { type: 'model/gltf-binary' }), `${baseName()}-segments.glb`);
    } catch (e) {
      message(`Download failed: ${errorText(e)}`, { error: true });
    }
  }

  function saveSession() {
    if (!state.mesh) return message('Open a mesh first: a session is the work on one mesh.', { error: true });
    const doc = currentSession();
    saveBlob(new Blob([JSON.stringify(doc, null, 2)], { type: 'application/json' }), `${baseName()}-session.json`);
    message(`Saved the session: ${doc.lines.length} line(s) on ${doc.mesh.name}.`);
  }

  return { downloadLines, downloadSegmented, saveSession };
}
