// Keyboard shortcuts and the help overlay, and the drawer of narrow windows. The shortcuts call
// the actions, and `commands` for what is not state (files, the camera, a drag in progress).
import { $, answerConfirm, confirmOpen } from './dom.js';
import { activeLine } from './model.js';

export function typingInField(e) {
  const t = e.target;
  return t && (t.tagName === 'INPUT' || t.tagName === 'SELECT' || t.tagName === 'TEXTAREA' || t.isContentEditable) && t.type !== 'checkbox' && t.type !== 'radio';
}

export function toggleHelp(show = $('help').hidden) {
  $('help').hidden = !show;
  if (show) $('help-close').focus();
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

// commands: {saveSession, openFileChooser, cancelDrag, fitView, lookFrom(name), setTraceMode(on)}.
export function createKeyboard(store, actions, commands) {
  const state = store.state;
  return function onKeyDown(e) {
    const ctrl = e.ctrlKey || e.metaKey;
    if (e.key === 'Escape') {
      if (confirmOpen()) return answerConfirm(false);
      if (!$('help').hidden) return toggleHelp(false);
      if (drawerOpen()) return toggleDrawer(false);
      if (commands.cancelDrag()) return; // the key goes back
      actions.selectKey(null);
      return;
    }
    if (confirmOpen()) return;
    if (ctrl && (e.key === 'z' || e.key === 'Z')) {
      if (typingInField(e)) return; // the field's own undo
      e.preventDefault();
      return e.shiftKey ? actions.redo() : actions.undo();
    }
    if (ctrl && (e.key === 'y' || e.key === 'Y') && !typingInField(e)) {
      e.preventDefault();
      return actions.redo();
    }
    if (ctrl && (e.key === 's' || e.key === 'S')) {
      e.preventDefault();
      return commands.saveSession();
    }
    if (ctrl && (e.key === 'o' || e.key === 'O')) {
      e.preventDefault();
      return commands.openFileChooser();
    }
    if (ctrl || e.altKey || typingInField(e)) return;
    const keyActions = {
      Delete: actions.deleteSelectedKey,
      Backspace: actions.deleteSelectedKey,
      n: actions.addLine,
      c: () => actions.setClosed(!activeLine(state)?.closed),
      s: () => actions.setSnapping(!state.snapping),
      t: () => commands.setTraceMode(!state.traceMode),
      f: () => commands.fitView(),
      1: () => commands.lookFrom('front'),
      2: () => commands.lookFrom('top'),
      3: () => commands.lookFrom('side'),
      o: () => actions.setOrthographic(!state.orthographic),
      p: () => toggleDrawer(),
      e: () => actions.setEdgesShown(),
      '?': () => toggleHelp(),
      h: () => toggleHelp(),
    };
    const action = keyActions[e.key];
    if (!action) return;
    if (e.target?.tagName === 'BUTTON' && (e.key === 'Enter' || e.key === ' ')) return;
    e.preventDefault();
    action();
  };
}
