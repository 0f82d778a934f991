// Pointing at the mesh (mouse, pen or touch through pointer events): a press on a key's marker
// grabs it, a click or tap places a key (snapped to the strongest feature nearby), hovering
// shows the read-out and where a click would land, double-click sets the orbit centre.
import { $, history, num, showMessage, state, viewer } from './app.js';
import { ringNeighbourhood, strongestFeatureVertex } from './geometry.js';
import { activeLine, addKey, afterEdit, deleteKey, moveKeyUnrecorded, renderHistoryButtons, restore, snapshot } from './lines.js';
import { refresh } from './panel.js';
import { clearTracePreview, hoverTrace, traceClick } from './trace.js';

// Snapping: a clicked key moves to the vertex of largest |curvature| within this many edges
// of the clicked vertex and this many pixels of the click (so zooming in makes it finer).
const SNAP_RINGS = 2;
const SNAP_PIXELS = 10;
// Only vertices whose |curvature| is at least this share of the mesh's robust range (95th
// percentile) count as features to snap to.
const SNAP_MIN_SHARE = 0.25;
// A press that moves more than this (pixels) is a drag (or an orbit), not a click.
const CLICK_SLOP_PIXELS = 4;

// ---- pointer interaction on the canvas --------------------------------------------------------------
// A press on a key's marker grabs it (a drag starts only once the pointer moves; a press
// without moving selects the key); a press anywhere else is a click that places a key, or an
// orbit when the pointer moves.
export const pointer = { down: null, press: null, drag: null, pendingMove: null, moveScheduled: false };

// The vertex a click at (x, y) places: the hit vertex, or with snapping the strongest feature
// vertex nearby. Returns {vertex, hit, snapped} or null when the click misses the mesh.
export function keyVertexAt(clientX, clientY, avoid = []) {
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

export function onPointerDown(e) {
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

export function startDrag() {
  const { key, pointerId } = pointer.press;
  const line = state.lines.find((l) => l.id === key.lineId);
  if (!line) return;
  pointer.drag = { lineId: key.lineId, keyIndex: key.keyIndex, pointerId, before: snapshot(), startVertex: line.keys[key.keyIndex] };
  state.activeLineId = key.lineId;
  state.selectedKey = { lineId: key.lineId, keyIndex: key.keyIndex };
  viewer.canvas.style.cursor = 'grabbing';
  refresh();
}

export function processMove() {
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
export function hoverFeedback(x, y) {
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
    clearTracePreview();
    return;
  }
  const target = keyVertexAt(x, y, lastKeyOfActiveLine());
  if (!target) {
    readout.hidden = true;
    viewer.setSnapPreview(null);
    clearTracePreview();
    return;
  }
  hoverTrace(pointer.down ? null : target.vertex); // not while orbiting
  const c = state.curvature ? ` · curvature ${num(state.curvature[target.hit.vertex], 3)}` : '';
  const snap = target.snapped ? ` · snaps to vertex ${target.vertex}${state.curvature ? ` (${num(state.curvature[target.vertex], 3)})` : ''}` : '';
  readout.textContent = `vertex ${target.hit.vertex}${c}${snap}`;
  readout.hidden = false;
  viewer.setSnapPreview(target.vertex);
}

export function lastKeyOfActiveLine() {
  const keys = activeLine()?.keys ?? [];
  return keys.length ? [keys[keys.length - 1]] : [];
}

export function onPointerMove(e) {
  if (!state.mesh) return;
  pointer.pendingMove = { clientX: e.clientX, clientY: e.clientY };
  if (!pointer.moveScheduled) {
    pointer.moveScheduled = true;
    requestAnimationFrame(processMove);
  }
}

export function endPress(e) {
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

export function onPointerUp(e) {
  if (pointer.press || pointer.drag) return endPress(e);
  const down = pointer.down;
  pointer.down = null;
  if (!down || e.button !== 0 || !state.mesh) return;
  // A click (not an orbit drag) adds a key where the surface was hit.
  if (Math.hypot(e.clientX - down.x, e.clientY - down.y) > CLICK_SLOP_PIXELS) return;
  const target = keyVertexAt(e.clientX, e.clientY, lastKeyOfActiveLine());
  if (!target) {
    showMessage(`That click missed the mesh: click on the surface to ${state.traceMode ? 'trace a feature' : 'place a key'}.`);
    return;
  }
  // Trace mode: a click traces the feature under it; Shift+click adds a key as in key mode.
  if (state.traceMode && !e.shiftKey) {
    state.lastClickAdd = null;
    traceClick(target.vertex);
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
export function onDoubleClick(e) {
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
