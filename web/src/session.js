// The page's work as a file: the mesh it was made on (name, server id, sizes), the lines
// (keys are the server's vertex ids, stable for the same file), the options and the view's up
// axis and camera. Loading one re-creates the lines, uploading the mesh again when the server has
// forgotten it.
export const SESSION_FORMAT = 'featureline-session';
export const SESSION_VERSION = 1;

export function sessionDocument({ mesh, lines, options, upAxis, view }) {
  const doc = {
    format: SESSION_FORMAT,
    version: SESSION_VERSION,
    saved: new Date().toISOString(),
    mesh: mesh ? { name: mesh.name, id: mesh.id, vertices: mesh.vertexCount, faces: mesh.faceCount, format: mesh.description?.format ?? null } : null,
    up_axis: upAxis,
    options: structuredClone(options ?? {}),
    lines: lines.map((l) => ({ name: l.name, keys: [...l.keys], closed: !!l.closed, ...(l.trace ? { trace: true } : {}) })),
  };
  if (view) doc.view = { position: [...view.position], target: [...view.target], orthographic: !!view.orthographic, zoom: view.zoom };
  return doc;
}

// The camera a session was saved with: {position, target} in the mesh's coordinates,
// orthographic or not, and the zoom of the orthographic view (1 in perspective).
function checkView(view) {
  const point = (p) => Array.isArray(p) && p.length === 3 && p.every(Number.isFinite);
  if (!view || typeof view !== 'object' || !point(view.position) || !point(view.target)) throw new Error('"view" needs a "position" and a "target" of three numbers each');
  if (typeof view.orthographic !== 'boolean' || !(Number.isFinite(view.zoom) && view.zoom > 0)) throw new Error('"view" needs "orthographic" (true or false) and a positive "zoom"');
}

// Parses and checks a session file's text; throws an Error saying what is wrong.
export function parseSession(text) {
  let doc;
  try {
    doc = JSON.parse(text);
  } catch (e) {
    throw new Error(`the file is not JSON (${e.message})`);
  }
  if (!doc || doc.format !== SESSION_FORMAT) throw new Error(`the file is not a Featureline session (no "format": "${SESSION_FORMAT}")`);
  if (doc.version !== SESSION_VERSION) throw new Error(`session version ${doc.version} is not supported (this page reads version ${SESSION_VERSION})`);
  if (!doc.mesh || typeof doc.mesh.name !== 'string' || !Number.isInteger(doc.mesh.vertices)) throw new Error('the session names no mesh');
  if (!Array.isArray(doc.lines)) throw new Error('the session has no "lines" list');
  doc.lines.forEach((l, i) => {
    if (!Array.isArray(l.keys) || !l.keys.every((k) => Number.isInteger(k) && k >= 0 && k < doc.mesh.vertices))
      throw new Error(`line ${i + 1}: keys must be vertex ids from 0 to ${doc.mesh.vertices - 1}`);
    if (l.trace != null && (l.trace !== true || l.keys.length !== 1)) throw new Error(`line ${i + 1}: "trace" is true on a line of one key, or absent`);
  });
  if (doc.options != null && typeof doc.options !== 'object') throw new Error('"options" must be an object');
  if (doc.view != null) checkView(doc.view);
  return doc;
}

// The up axis the user chose for a file, remembered per file name in this browser.
const UP_AXIS_KEY = 'featureline.upAxis.';
export function rememberedUpAxis(fileName) {
  try {
    const v = globalThis.localStorage?.getItem(UP_AXIS_KEY + fileName);
    return v === 'y' || v === 'z' ? v : null;
  } catch {
    return null; // storage disabled: no memory, no harm
  }
}

export function rememberUpAxis(fileName, axis) {
  try {
    globalThis.localStorage?.setItem(UP_AXIS_KEY + fileName, axis);
  } catch {
    // storage disabled
  }
}
