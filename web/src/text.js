// What the user reads: numbers counted from 1, and error text that says what happened.

// The engine counts keys, segments and lines from 0 in its messages ("keys 0 and 1 are the
// same vertex", "segment 2 had to cross ...", "line 0 separates no segments", "lines[1].keys");
// the page counts from 1 everywhere. Vertex ids stay as they are: they are ids, not counts.
export function oneBasedNumbers(text) {
  if (!text) return text;
  const plus1 = (n) => String(Number(n) + 1);
  // One pass, so a number is never shifted twice.
  return String(text).replace(
    /\b(?:(lines|keys)\[(\d+)\]|(keys?|segments?|lines?|pieces?) (\d+)((?:,? and | to | or )(\d+))?)/g,
    (_, listName, listIndex, what, a, sep, b) => {
      if (listName) return `${listName === 'lines' ? 'line' : 'key'} ${plus1(listIndex)}`;
      return `${what} ${plus1(a)}${sep ? sep.replace(/\d+$/, plus1(b)) : ''}`;
    },
  );
}

// An error as one line of text, with the HTTP status when there is one.
export function errorText(e) {
  if (e && typeof e === 'object' && 'status' in e && typeof e.toString === 'function' && e.name === 'ApiError') return e.toString();
  return e?.message ?? String(e);
}

// A vertex id typed by the user: an error text, or '' when it can be a key of the active line.
export function vertexIdProblem(text, vertexCount, line) {
  const trimmed = String(text).trim();
  if (!/^\d+$/.test(trimmed)) return `"${trimmed}" is not a vertex id: type a whole number from 0 to ${vertexCount - 1}`;
  const v = Number(trimmed);
  if (v >= vertexCount) return `vertex ${v} is out of range: this mesh has vertices 0 to ${vertexCount - 1}`;
  if (line?.keys.length && line.keys[line.keys.length - 1] === v) return `vertex ${v} is already the last key of ${line.name}`;
  return '';
}

// Server text about lines, keys and segments, counted from 1 as the page counts.
export function serverText(e) {
  return oneBasedNumbers(typeof e === 'string' ? e : errorText(e));
}

export function formatBytes(n) {
  if (n < 1024) return `${n} B`;
  if (n < 1024 * 1024) return `${(n / 1024).toFixed(1)} KiB`;
  return `${(n / 1024 / 1024).toFixed(1)} MiB`;
}

export function num(x, digits = 4) {
  if (typeof x !== 'number' || !Number.isFinite(x)) return String(x);
  if (x !== 0 && (Math.abs(x) >= 1e5 || Math.abs(x) < 1e-3)) return x.toExponential(2);
  return Number(x.toPrecision(digits)).toString();
}
