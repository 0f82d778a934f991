// The server writes the line files (OBJ, PLY, GLB, CSV; api/export_formats.h,
// api/gltf_export.h) and names the lines by their 0-based place in the request: `o line_0`, a
// PLY edge's `line` 0, the glTF node `feature_line_0`, a CSV row's `line` 0. The page counts from 1 and lets lines be renamed, so the
// downloaded files carry the page's names instead; nothing else in them changes. No three.js,
// no DOM (tests/web/modules_test.mjs checks it on the server's own output).

// An OBJ object name: one word (some readers stop at white space).
export function objName(name) {
  return String(name).trim().replace(/\s+/g, '_') || 'line';
}

// `o line_<i>` -> `o <names[i]>`.
export function nameObjLines(text, names) {
  return text.replace(/^o line_(\d+)$/gm, (record, i) => (names[i] === undefined ? record : `o ${objName(names[i])}`));
}

// The PLY's `line` property of each edge counted from 1, and a comment per line naming it.
export function namePlyLines(text, names) {
  const lines = text.split('\n');
  const headerEnd = lines.indexOf('end_header');
  if (headerEnd < 0) throw new Error('the PLY has no end_header');
  const countOf = (element) => Number(lines.slice(0, headerEnd).find((l) => l.startsWith(`element ${element} `))?.split(' ')[2]);
  const vertices = countOf('vertex');
  const edges = countOf('edge');
  if (!Number.isInteger(vertices) || !Number.isInteger(edges)) throw new Error('the PLY has no vertex or edge element');
  const firstEdge = headerEnd + 1 + vertices;
  for (let row = firstEdge; row < firstEdge + edges; ++row) {
    const [a, b, line] = lines[row].split(' ');
    lines[row] = `${a} ${b} ${Number(line) + 1}`;
  }
  const comments = ['comment the edges\' "line" counts from 1, as the page does:', ...names.map((n, i) => `comment line ${i + 1}: ${String(n).replace(/\s+/g, ' ')}`)];
  const elementRow = lines.findIndex((l) => l.startsWith('element vertex '));
  lines.splice(elementRow, 0, ...comments);
  return lines.join('\n');
}

const GLB_MAGIC = 0x46546c67; // "glTF"
const CHUNK_JSON = 0x4e4f534a;

// The GLB with its nodes and meshes `feature_line_<i>` renamed to names[i]; the binary chunk
// is copied as it is.
export function nameGlbLines(arrayBuffer, names) {
  const view = new DataView(arrayBuffer);
  if (view.getUint32(0, true) !== GLB_MAGIC || view.getUint32(16, true) !== CHUNK_JSON) throw new Error('not a GLB with a JSON chunk');
  const jsonLength = view.getUint32(12, true);
  const json = JSON.parse(new TextDecoder().decode(new Uint8Array(arrayBuffer, 20, jsonLength)));
  const rename = (item) => {
    const i = /^feature_line_(\d+)$/.exec(item.name ?? '')?.[1];
    if (i !== undefined && names[i] !== undefined) item.name = String(names[i]);
  };
  (json.nodes ?? []).forEach(rename);
  (json.meshes ?? []).forEach(rename);
  const text = new TextEncoder().encode(JSON.stringify(json));
  const padded = (text.length + 3) & ~3; // chunks are 4-byte aligned; JSON pads with spaces
  const rest = new Uint8Array(arrayBuffer, 20 + jsonLength);
  const out = new Uint8Array(12 + 8 + padded + rest.length);
  const outView = new DataView(out.buffer);
  outView.setUint32(0, GLB_MAGIC, true);
  outView.setUint32(4, view.getUint32(4, true), true);
  outView.setUint32(8, out.length, true);
  outView.setUint32(12, padded, true);
  outView.setUint32(16, CHUNK_JSON, true);
  out.set(text, 20);
  out.fill(0x20, 20 + text.length, 20 + padded);
  out.set(rest, 20 + padded);
  return out.buffer;
}

// A CSV field: quoted, its quotes doubled.
const csvField = (text) => `"${String(text).replace(/"/g, '""')}"`;

// The CSV's `line` column (0-based places) -> the lines' names.
export function nameCsvLines(text, names) {
  return text.replace(/^(\d+),/gm, (field, i) => (names[i] === undefined ? field : `${csvField(names[i])},`));
}

// The names written into a download of `format`: the text or bytes the server sent, renamed.
export function nameLinesInFile(format, content, names) {
  if (format === 'obj') return nameObjLines(content, names);
  if (format === 'ply') return namePlyLines(content, names);
  if (format === 'glb') return nameGlbLines(content, names);
  if (format === 'csv') return nameCsvLines(content, names);
  return content; // polylines: one coordinate list per text line, no names to write
}

// What each format is called and saved as (the file endings are api/export_formats.h's).
export const LINE_FILE_FORMATS = {
  glb: { extension: '.glb', type: 'model/gltf-binary', binary: true },
  obj: { extension: '.obj', type: 'model/obj', binary: false },
  ply: { extension: '.ply', type: 'text/plain', binary: false },
  polylines: { extension: '.polylines.txt', type: 'text/plain', binary: false },
  csv: { extension: '.csv', type: 'text/csv', binary: false },
};
