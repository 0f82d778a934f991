// The HTTP API (api/openapi.yaml), as the page uses it. Every error the server sends has the
// body {"error": {"code", "message"}}; it becomes an ApiError carrying status, code and the
// server's own message.

// The API's origin: the page's own (the server serves the page), or ?api=http://host:port
// while developing the page elsewhere (the server then needs --cors-origin).
export const API_BASE = (() => {
  const api = new URLSearchParams(globalThis.location?.search ?? '').get('api');
  return api ? api.replace(/\/+$/, '') : '';
})();

export class ApiError extends Error {
  // retryAfter: seconds the server asked to wait (503 with Retry-After), else null.
  constructor(status, code, message, retryAfter = null) {
    super(message);
    this.name = 'ApiError';
    this.status = status;
    this.code = code;
    this.retryAfter = retryAfter;
  }
  get isNetwork() {
    return this.status === 0 && this.code === 'network';
  }
  // Worth trying again unchanged: the server was busy or could not be reached.
  get isTransient() {
    return this.isNetwork || this.status === 503;
  }
  // The mesh id is unknown to the server (expired, evicted, deleted).
  get isMeshGone() {
    return this.status === 404 && this.code === 'not_found';
  }
  toString() {
    return this.status ? `${this.message} (HTTP ${this.status}${this.code ? ` ${this.code}` : ''})` : this.message;
  }
}

function retryAfterSeconds(value) {
  if (value == null || value === '') return null;
  const s = Number(value);
  if (Number.isFinite(s)) return Math.max(0, s);
  const date = Date.parse(value); // Retry-After may also be an HTTP date
  return Number.isFinite(date) ? Math.max(0, (date - Date.now()) / 1000) : null;
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Runs `attempt` again when it fails transiently: after the server's Retry-After (capped at
// 10 s) for a 503, after 1 s, 2 s, ... when the server could not be reached. onRetry({error,
// attempt, delayS}) is told before each wait so the page can say what is happening.
export async function withRetry(attempt, { tries = 4, onRetry } = {}) {
  for (let n = 1; ; ++n) {
    try {
      return await attempt();
    } catch (e) {
      if (!(e instanceof ApiError) || !e.isTransient || n >= tries) throw e;
      const delayS = Math.min(10, e.retryAfter ?? n);
      onRetry?.({ error: e, attempt: n, delayS });
      await sleep(delayS * 1000);
    }
  }
}

// An ApiError from a non-2xx answer's text: the server's JSON message when there is one.
function errorFromText(status, statusText, text, retryAfter = null) {
  const retry = retryAfterSeconds(retryAfter);
  try {
    const body = JSON.parse(text);
    if (body && body.error && typeof body.error.message === 'string')
      return new ApiError(status, body.error.code || '', body.error.message, retry);
  } catch {
    // not JSON: fall through
  }
  const snippet = (text || '').trim().slice(0, 200);
  return new ApiError(status, '', snippet || statusText || `HTTP ${status}`, retry);
}

function networkError(what, detail) {
  const where = API_BASE || globalThis.location?.origin || 'the server';
  return new ApiError(0, 'network', `${what}: could not reach ${where} (network error${detail ? `: ${detail}` : ''})`);
}

async function errorFromResponse(response) {
  let text = '';
  try {
    text = await response.text();
  } catch {
    // ignore: the status alone is reported
  }
  return errorFromText(response.status, response.statusText, text, response.headers.get('Retry-After'));
}

async function request(path, init) {
  let response;
  try {
    response = await fetch(API_BASE + path, init);
  } catch (e) {
    if (e.name === 'AbortError') throw e;
    throw networkError('no answer', e.message);
  }
  if (!response.ok) throw await errorFromResponse(response);
  return response;
}

export const MESH_FORMATS = ['obj', 'off', 'ply', 'stl', 'glb', 'gltf', 'drc'];

export function formatOfFileName(name) {
  const ext = (name.split('.').pop() || '').toLowerCase();
  return MESH_FORMATS.includes(ext) ? ext : null;
}

// A .gltf and the files it names, as the server takes them together: one part per file.
function filesForm(files) {
  const form = new FormData();
  for (const file of files) form.append('files', file, file.name);
  return form;
}

// POST /v1/meshes with the file's raw bytes, or with an array of files (a .gltf and its .bin
// files) as multipart/form-data, with upload progress (XMLHttpRequest, since fetch has no
// upload progress). Resolves to the MeshDescription.
export function uploadMesh(body, { format, onProgress } = {}) {
  const files = Array.isArray(body) ? body : null;
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    const query = format && !files ? `?format=${encodeURIComponent(format)}` : '';
    xhr.open('POST', `${API_BASE}/v1/meshes${query}`);
    if (!files) xhr.setRequestHeader('Content-Type', 'application/octet-stream');
    xhr.responseType = 'text';
    if (onProgress) {
      xhr.upload.onprogress = (e) => onProgress({ loaded: e.loaded, total: e.lengthComputable ? e.total : 0, phase: 'upload' });
      xhr.upload.onload = () => onProgress({ loaded: 1, total: 1, phase: 'prepare' });
    }
    xhr.onload = () => {
      if (xhr.status === 201 || xhr.status === 200) {
        try {
          resolve(JSON.parse(xhr.responseText));
        } catch {
          reject(new ApiError(xhr.status, '', 'the server answered the upload with something that is not JSON'));
        }
      } else {
        reject(errorFromText(xhr.status, xhr.statusText, xhr.responseText, xhr.getResponseHeader('Retry-After')));
      }
    };
    xhr.onerror = () => reject(networkError('the upload failed', 'or the server closed the connection'));
    xhr.onabort = () => reject(new ApiError(0, 'aborted', 'the upload was cancelled'));
    xhr.send(files ? filesForm(files) : body);
  });
}

// Every option with its type, default, limits and description (the server's option tables).
export async function optionTables() {
  return (await request('/v1/options')).json();
}

export async function describeMesh(meshId) {
  return (await request(`/v1/meshes/${meshId}`)).json();
}

// The server's indexed mesh in its compact form (?compact=1: 16-bit positions and curvature,
// no normals, small indices; api/openapi.yaml). onProgress({received, total}) counts the bytes as the page gets
// them (decompressed when the server sends gzip, so `total` is the caller's estimate, or the
// Content-Length when the answer is not compressed). Resolves to {bytes, wireBytes, encoding}.
export async function meshGlb(meshId, { onProgress, expectedBytes = 0 } = {}) {
  const response = await request(`/v1/meshes/${meshId}/mesh.glb?compact=1`, { headers: { Accept: 'model/gltf-binary' } });
  const encoding = response.headers.get('Content-Encoding') || 'identity';
  const length = Number(response.headers.get('Content-Length')) || 0;
  const total = encoding === 'identity' && length ? length : expectedBytes;
  if (!response.body?.getReader) {
    const bytes = await response.arrayBuffer();
    return { bytes, wireBytes: length || bytes.byteLength, encoding };
  }
  const reader = response.body.getReader();
  const chunks = [];
  let received = 0;
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    chunks.push(value);
    received += value.byteLength;
    onProgress?.({ received, total });
  }
  const bytes = new Uint8Array(received);
  let at = 0;
  for (const c of chunks) bytes.set(c, at), (at += c.byteLength);
  return { bytes: bytes.buffer, wireBytes: length || received, encoding };
}

// The server's signed per-vertex curvature field (api/openapi.yaml says which), little-endian
// float32. Its scale is the server's business: the page only compares and ranks values.
export async function curvature(meshId) {
  const bytes = await (await request(`/v1/meshes/${meshId}/curvature`, { headers: { Accept: 'application/octet-stream' } })).arrayBuffer();
  const n = bytes.byteLength >>> 2;
  const out = new Float32Array(n);
  const view = new DataView(bytes);
  for (let i = 0; i < n; ++i) out[i] = view.getFloat32(4 * i, true);
  return out;
}

function postJson(path, body, { accept = 'application/json', signal } = {}) {
  return request(path, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json', Accept: accept },
    body: JSON.stringify(body),
    signal,
  });
}

// One LineRequest -> one FeatureLine; {"lines": [...]} -> {"lines": [...]}.
export async function detectFeatureLines(meshId, body, { signal } = {}) {
  return (await postJson(`/v1/meshes/${meshId}/feature-lines`, body, { signal })).json();
}

// The lines as a file the server writes: ?format=glb, obj, ply or polylines (api/openapi.yaml).
// Resolves to the Response (the caller reads it as bytes or text).
export function featureLinesFile(meshId, body, format) {
  return postJson(`/v1/meshes/${meshId}/feature-lines?format=${encodeURIComponent(format)}`, body, { accept: '*/*' });
}

// POST /v1/meshes/{id}/segmentation {"lines": [LineRequest or ComputedLine...], "mode"} ->
// {"labels": [per face], "segments": [{label, faces, area, boundary_length, color}], "warnings": [],
//  "remeshed": {vertices, faces, source_faces} in remesh mode}. A ComputedLine ({keys, closed,
// refined: {faces, barycentric}}) is a line the page already has: the server does not detect it again.
export async function segmentation(meshId, body) {
  return (await postJson(`/v1/meshes/${meshId}/segmentation`, body)).json();
}

// The segmented mesh as GLB (one primitive per segment). Resolves to a Blob, or rejects
// when the server has no GLB answer for segmentation.
export async function segmentationGlb(meshId, body) {
  const response = await postJson(`/v1/meshes/${meshId}/segmentation?format=glb`, body, { accept: 'model/gltf-binary' });
  const type = (response.headers.get('Content-Type') || '').toLowerCase();
  if (!type.startsWith('model/gltf-binary'))
    throw new ApiError(response.status, 'no_glb', 'this server does not answer the segmented mesh as GLB');
  return response.blob();
}

// The bundled samples the server serves beside the page (web/build.mjs writes the list).
export async function sampleList() {
  const response = await fetch('samples/index.json');
  if (!response.ok) throw new Error(`HTTP ${response.status}`);
  return (await response.json()).samples;
}

export async function sampleBytes(file) {
  const response = await fetch(file);
  if (!response.ok) throw new Error(`HTTP ${response.status} for ${file}`);
  return response.arrayBuffer();
}
