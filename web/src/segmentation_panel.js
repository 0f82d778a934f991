// Decomposition along the lines: one request, the segmented surface drawn from the answer, the
// segments table, and marking it out of date when the lines change.
import * as api from './api.js';
import { $, errorText, num, serverText, showMessage, state, viewer } from './app.js';
import { rgbCss } from './colors.js';
import { isStale, keysProblem, lineRequest, retryNotice } from './lines.js';
import { applyColors } from './panel.js';
import { parseGlb, segmentedSurface } from './viewer.js';

// ---- decomposition -------------------------------------------------------------------------------------
export function readyLines() {
  return state.lines.filter((l) => !keysProblem(l)).map(lineRequest);
}

// A line for the decomposition: the line the page already has when its answer is current
// (computed once: the server only cuts along it), else its request (the server detects it).
export function segmentationItem(line) {
  const refined = line.result?.refined;
  if (!isStale(line) && Array.isArray(refined?.faces) && Array.isArray(refined?.barycentric))
    return { keys: [...line.keys], closed: line.closed, refined: { faces: refined.faces, barycentric: refined.barycentric } };
  return lineRequest(line);
}

// The server's colour of a segment label (its answer carries the one palette, the same as in
// its GLB); grey for an answer without colours.
export function segmentColor(seg, label) {
  return seg.answer.segments[label]?.color ?? [0.5, 0.5, 0.5];
}

export function clearSegmentation() {
  state.segmentation = null;
  state.decomposeMessage = '';
  viewer.setSegmentScene(null);
  $('segments-toggle').checked = false;
  $('segments-toggle').disabled = true;
  $('download-segmented').disabled = true;
  $('decompose-status').textContent = '';
  renderSegments();
}

export async function decompose() {
  if (!state.mesh) return;
  $('decompose-section').open = true;
  const ready = state.lines.filter((l) => !keysProblem(l));
  const lines = ready.map(segmentationItem);
  const status = $('decompose-status');
  status.classList.remove('error');
  if (!lines.length) {
    status.textContent = 'Place a line with at least two keys first.';
    showMessage(`Decompose: ${status.textContent}`, { error: true });
    return;
  }
  // Slivers left where a line doubles back to a pinned key join their neighbour.
  const request = { lines, mode: $('decompose-mode').value, merge_tiny_segments: true };
  const meshId = state.mesh.id;
  status.textContent = 'Decomposing…';
  showMessage(`Decomposing along ${lines.length} line(s)…`);
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
    showMessage(text, { error: true });
  } finally {
    $('decompose').disabled = false;
    $('toolbar-decompose').disabled = false;
  }
}

// The segmented surface of an answer as three.js objects: the remeshed surface it carries
// (remesh mode), or the page's mesh with the answer's labels (snap mode); null when the answer
// carries neither.
export function segmentedObject(seg) {
  const { answer } = seg;
  const colorOf = (label) => segmentColor(seg, label);
  const remeshed = answer.remeshed;
  if (Array.isArray(remeshed?.vertices) && Array.isArray(remeshed?.faces))
    return segmentedSurface(remeshed.vertices.flat(), remeshed.faces.flat(), answer.labels, colorOf);
  if (seg.faceColored && viewer.mesh) return segmentedSurface(viewer.mesh.positions, viewer.mesh.index, answer.labels, colorOf);
  return null;
}

// linesKey: the line requests the answer is for (to tell when it is out of date).
export async function applySegmentation(request, answer, linesKey) {
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
  // The panel's copy may be scrolled out of view; the status line is always in view.
  showMessage(`Decomposed into ${parts.join('\n')}`);
  $('segments-toggle').disabled = !(faceColored || seg.sceneLoaded);
  $('segments-toggle').checked = faceColored || seg.sceneLoaded;
  if ($('segments-toggle').checked) $('curvature-toggle').checked = false;
  $('download-segmented').disabled = false;
  renderSegments();
  applyColors();
}

// The segments came from the lines as they were when Decompose ran.
export function segmentationStale() {
  const seg = state.segmentation;
  return !!seg && seg.linesKey !== JSON.stringify(readyLines());
}

export function renderSegmentStaleness() {
  const stale = segmentationStale();
  $('segments').classList.toggle('stale', stale);
  $('segments-stale').hidden = !stale;
  $('view-stale').hidden = !(stale && state.colorMode === 'segments');
}

export function renderSegments() {
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
