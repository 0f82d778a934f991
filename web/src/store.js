// The page's one store: its state changes only through update(label, fn), which tells every
// subscriber once the current task's updates are done (many updates in one task, one render).
// A labelled update is an undoable edit: the editable part of the state (`snapshot`) is kept
// before it in the undo history (history.js); an update without a label (an answer arriving,
// a message, progress) is not.
import { History } from './history.js';

export function createStore(state, { snapshot, restore, history = new History() } = {}) {
  const listeners = new Set();
  let scheduled = false;
  let version = 0;

  function notify() {
    if (!scheduled) return; // flushed already
    scheduled = false;
    for (const listener of [...listeners]) listener(state);
  }

  function changed() {
    version++;
    if (scheduled) return;
    scheduled = true;
    queueMicrotask(notify);
  }

  const store = {
    history,
    get state() {
      return state;
    },
    // How many updates changed something so far (views compare it to skip work).
    get version() {
      return version;
    },
    // fn(state) changes the state in place and returns false when it changed nothing (then
    // no history entry and no notification). A string label records an undo step.
    update(label, fn) {
      const before = label && snapshot ? snapshot(state) : null;
      if (fn(state) === false) return false;
      if (label && snapshot) history.record(before, label);
      changed();
      return true;
    },
    // An edit made in several unrecorded steps (a key dragged) is kept as one step, from the
    // snapshot taken when it began.
    record(before, label) {
      history.record(before, label);
      changed();
    },
    snapshot() {
      return snapshot(state);
    },
    // Puts a snapshot back without recording it (a cancelled drag, a double-click's first click).
    restore(snap) {
      restore(state, snap);
      changed();
    },
    // Undo and redo restore the snapshot of the edit; both return its label, or null.
    undo() {
      const entry = history.undo(snapshot(state));
      if (!entry) return null;
      restore(state, entry.snapshot);
      changed();
      return entry.label;
    },
    redo() {
      const entry = history.redo(snapshot(state));
      if (!entry) return null;
      restore(state, entry.snapshot);
      changed();
      return entry.label;
    },
    subscribe(listener) {
      listeners.add(listener);
      return () => listeners.delete(listener);
    },
    // Tells the subscribers now (tests, and code that reads the page right after an update).
    flush() {
      notify();
    },
  };
  return store;
}
