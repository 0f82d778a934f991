// Keyboard shortcuts and the help overlay, and the toggles they share with the panel.
import { $, confirmResolver, showMessage, state, viewer } from './app.js';
import { activeLine, addLine, afterEdit, deleteSelectedKey, redo, restore, setClosed, undo } from './lines.js';
import { saveSession } from './open_mesh.js';
import { refresh } from './panel.js';
import { pointer } from './picking.js';
import { setTraceMode } from './trace.js';

// ---- keyboard -----------------------------------------------------------------------------------------------
export function typingInField(e) {
  const t = e.target;
  return t && (t.tagName === 'INPUT' || t.tagName === 'SELECT' || t.tagName === 'TEXTAREA' || t.isContentEditable) && t.type !== 'checkbox' && t.type !== 'radio';
}

export function toggleHelp(show = $('help').hidden) {
  $('help').hidden = !show;
  if (show) $('help-close').focus();
}

export function onKeyDown(e) {
  const ctrl = e.ctrlKey || e.metaKey;
  if (e.key === 'Escape') {
    if (confirmResolver) return confirmResolver(false);
    if (!$('help').hidden) return toggleHelp(false);
    if (drawerOpen()) return toggleDrawer(false);
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
    t: () => setTraceMode(!state.traceMode),
    f: () => viewer.fitView(),
    1: () => lookFrom('front'),
    2: () => lookFrom('top'),
    3: () => lookFrom('side'),
    o: () => setOrthographic(!viewer.orthographic),
    p: () => toggleDrawer(),
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

export function setSnapping(on) {
  state.snapping = on;
  $('snap-toggle').checked = on;
  showMessage(on ? 'Snapping on: a click places the key on the strongest feature vertex nearby.' : 'Snapping off: a click places the key on the vertex clicked.');
}

export function toggleEdges(on = !viewer.edgesShown) {
  viewer.showEdges(on);
  $('edges-toggle').checked = on;
}

const VIEW_NAMES = { front: 'the front', top: 'above', side: 'the right side' };

export function lookFrom(name) {
  if (!state.mesh) return showMessage('Open a mesh first.', { error: true });
  if (viewer.viewFrom(name)) showMessage(`Looking from ${VIEW_NAMES[name]} (${state.upAxis === 'z' ? '+Z' : '+Y'} up); F frames the mesh as it opened.`);
}

export function setOrthographic(on) {
  viewer.setOrthographic(on);
  $('ortho-toggle').checked = on;
  showMessage(on ? 'Orthographic projection: sizes no longer shrink with distance (O switches back).' : 'Perspective projection (O switches to orthographic).');
}

// Narrow windows show the panel as a drawer over the view (the width is style.css's).
const NARROW = '(max-width: 899px)';
export function drawerOpen() {
  return document.body.classList.contains('drawer-open') && window.matchMedia(NARROW).matches;
}

export function toggleDrawer(open = !drawerOpen()) {
  document.body.classList.toggle('drawer-open', open);
  $('panel-toggle').setAttribute('aria-expanded', String(open));
  if (open) $('panel').querySelector('#toolbar button')?.focus();
  else if (document.activeElement && $('panel').contains(document.activeElement)) $('panel-toggle').focus();
}
