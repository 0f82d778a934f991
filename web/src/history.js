// Undo and redo of the page's edits. Each entry is a snapshot of what the user edits (lines,
// keys, options; never server results, which are re-fetched or found in a cache), taken
// before an edit, with a label saying what the edit was ("add key", "delete Line 2").
export class History {
  constructor(limit = 200) {
    this.limit = limit;
    this.undoStack = [];
    this.redoStack = [];
  }

  // Call before an edit with the state as it was; a new edit forgets what could be redone.
  record(snapshot, label) {
    this.undoStack.push({ snapshot, label });
    if (this.undoStack.length > this.limit) this.undoStack.shift();
    this.redoStack = [];
  }

  get canUndo() {
    return this.undoStack.length > 0;
  }

  get canRedo() {
    return this.redoStack.length > 0;
  }

  get undoLabel() {
    return this.undoStack.at(-1)?.label ?? '';
  }

  get redoLabel() {
    return this.redoStack.at(-1)?.label ?? '';
  }

  // Returns the entry to restore ({snapshot, label}) and keeps `current` for redo; null if none.
  undo(current) {
    const entry = this.undoStack.pop();
    if (!entry) return null;
    this.redoStack.push({ snapshot: current, label: entry.label });
    return entry;
  }

  redo(current) {
    const entry = this.redoStack.pop();
    if (!entry) return null;
    this.undoStack.push({ snapshot: current, label: entry.label });
    return entry;
  }

  // Drops the last edit without keeping it for redo (a double-click's first click placed a
  // key the user did not mean).
  discardLast() {
    return this.undoStack.pop() ?? null;
  }

  clear() {
    this.undoStack = [];
    this.redoStack = [];
  }
}
