// Pointing at the mesh (mouse, pen or touch through pointer events): a press on a key's marker
// grabs it, a click or tap places a key (snapped to the strongest feature nearby), hovering
// shows the read-out and where a click would land, double-click sets the orbit centre.
// It edits through the actions and asks `tracing` (trace.js) for previews and traced lines.
import { $ } from './dom.js';
import { ringNeighbourhood, strongestFeatureVertex } from './geometry.js';
import { activeLine, lineById } from './model.js';
import { num } from './text.js';

// Snapping: a clicked key moves to the vertex of largest |curvature| within this many edges
// of the clicked vertex and this many pixels of the click (so zooming in makes it finer).
const SNAP_RINGS = 2;
const SNAP_PIXELS = 10;
// Only vertices whose |curvature| is at least this share of the mesh's robust range (95th
// percentile) count as features to snap to.
const SNAP_MIN_SHARE = 0.25;
// A press that moves more than this (pixels) is a drag (or an orbit), not a click.
const CLICK_SLOP_PIXELS = 4;

// The pointer on the canvas for one store, viewer and tracing; returns the handlers main.js
// attaches, what a test calls (hoverFeedback) and the drag in progress (Escape cancels it).
export function createPicking(store, actions, viewer, tracing) {
  const state = store.state;
  let lastClickAdd = null; // {time, before, x, y}: the last key placed by a click (a double-click takes it back)

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
      const line = lineById(state, key.lineId);
      if (line) actions.deleteKey(line, key.keyIndex);
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
    const line = lineById(state, key.lineId);
    if (!line) return;
    pointer.drag = { lineId: key.lineId, keyIndex: key.keyIndex, pointerId, before: store.snapshot(), startVertex: line.keys[key.keyIndex] };
    actions.selectKey(key);
    viewer.canvas.style.cursor = 'grabbing';
  }

  function processMove() {
    pointer.moveScheduled = false;
    const e = pointer.pendingMove;
    pointer.pendingMove = null;
    if (!e) return;
    if (pointer.press && !pointer.drag && Math.hypot(e.clientX - pointer.press.x, e.clientY - pointer.press.y) > CLICK_SLOP_PIXELS) startDrag();
    if (pointer.drag) {
      const line = lineById(state, pointer.drag.lineId);
      if (!line) return;
      const i = pointer.drag.keyIndex;
      const neighbours = [line.keys[i - 1], line.keys[i + 1]].filter((v) => v !== undefined);
      const target = keyVertexAt(e.clientX, e.clientY, neighbours);
      if (target) actions.moveKeyUnrecorded(line, i, target.vertex);
      return;
    }
    if (pointer.press) return;
    hoverFeedback(e.clientX, e.clientY);
  }

  // Hovering: the key under the pointer is highlighted; elsewhere the read-out names the vertex
  // and its curvature, and a dot shows where a click would place the key (after snapping).
  function hoverFeedback(x, y) {
    const key = viewer.pickKey(x, y);
    actions.setHoverKey(key);
    if (!pointer.drag) viewer.canvas.style.cursor = key ? 'grab' : '';
    const readout = $('readout');
    if (key) {
      const line = lineById(state, key.lineId);
      readout.textContent = `${line?.name ?? 'line'}, key ${key.keyIndex + 1} (vertex ${line?.keys[key.keyIndex]}): drag to move, right-click or Delete to remove`;
      readout.hidden = false;
      viewer.setSnapPreview(null);
      tracing.clearPreview();
      return;
    }
    const target = keyVertexAt(x, y, lastKeyOfActiveLine());
    if (!target) {
      readout.hidden = true;
      viewer.setSnapPreview(null);
      tracing.clearPreview();
      return;
    }
    tracing.hoverAt(pointer.down ? null : target.vertex); // not while orbiting
    const c = state.curvature ? ` · curvature ${num(state.curvature[target.hit.vertex], 3)}` : '';
    const snap = target.snapped ? ` · snaps to vertex ${target.vertex}${state.curvature ? ` (${num(state.curvature[target.vertex], 3)})` : ''}` : '';
    readout.textContent = `vertex ${target.hit.vertex}${c}${snap}`;
    readout.hidden = false;
    viewer.setSnapPreview(target.vertex);
  }

  function lastKeyOfActiveLine() {
    const keys = activeLine(state)?.keys ?? [];
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
      const line = lineById(state, lineId);
      if (line && line.keys[keyIndex] !== startVertex) store.record(before, `move key ${keyIndex + 1} of ${line.name}`);
    } else if (pointer.press) {
      // A press on a marker without moving selects that key (and its line).
      const { key } = pointer.press;
      actions.selectKey(key);
      const line = activeLine(state);
      actions.showMessage(`Selected key ${key.keyIndex + 1} of ${line?.name}: drag it to move it, Delete removes it.`);
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
      actions.showMessage(`That click missed the mesh: click on the surface to ${state.traceMode ? 'trace a feature' : 'place a key'}.`);
      return;
    }
    // Trace mode: a click traces the feature under it; Shift+click adds a key as in key mode.
    if (state.traceMode && !e.shiftKey) {
      lastClickAdd = null;
      tracing.traceClick(target.vertex);
      return;
    }
    const before = store.snapshot();
    if (actions.addKey(target.vertex)) {
      lastClickAdd = { time: performance.now(), before, x: e.clientX, y: e.clientY };
      const line = activeLine(state);
      actions.showMessage(`Key ${line.keys.length} of ${line.name}: vertex ${target.vertex}${target.snapped ? ` (snapped from ${target.hit.vertex} to the strongest feature nearby)` : ''}.`);
    }
  }

  // Double-click: orbit around the point under the pointer. The double-click's first click
  // placed a key the user did not mean; it is taken back (not kept for redo).
  function onDoubleClick(e) {
    if (!state.mesh) return;
    const last = lastClickAdd;
    if (last && performance.now() - last.time < 800 && Math.hypot(e.clientX - last.x, e.clientY - last.y) <= CLICK_SLOP_PIXELS * 2) {
      store.history.discardLast();
      store.restore(last.before);
    }
    lastClickAdd = null;
    const hit = viewer.pickVertex(e.clientX, e.clientY);
    if (!hit) return;
    viewer.setOrbitCenter(hit.point);
    actions.showMessage(`Orbiting around vertex ${hit.vertex} (double-click elsewhere to move the centre; F frames the mesh).`);
  }

  // Escape during a drag: the key goes back.
  function cancelDrag() {
    if (!pointer.drag) return false;
    store.restore(pointer.drag.before);
    pointer.drag = null;
    pointer.press = null;
    viewer.controls.enabled = true;
    return true;
  }

  function onPointerLeave() {
    $('readout').hidden = true;
    viewer.setSnapPreview(null);
    tracing.clearPreview();
    if (pointer.drag || !state.hoverKey) return;
    actions.setHoverKey(null);
    viewer.canvas.style.cursor = '';
  }

  return { onPointerDown, onPointerMove, onPointerUp, onDoubleClick, onPointerLeave, hoverFeedback, cancelDrag };
}
