#!/usr/bin/env bash
# Proves that the integration-test validators accept what they should and refuse what they
# should: api/openapi.yaml compiles and its examples are valid; the real engine output
# (fixtures/) passes; mutated documents (missing required field, wrong type, extra property,
# wrong enum) fail with exit status 1 and name the field; usage errors exit 2; a valid GLB
# passes and truncated or corrupted ones fail.
#
# Needs node (18 or newer). Installs the npm packages from package-lock.json when missing.
# Closes with "N passed, N failed"; exits 1 when anything failed.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
FIX="$HERE/fixtures"
VR="$HERE/validate_response.mjs"
VG="$HERE/validate_gltf.mjs"

command -v node >/dev/null || { echo "validators_test: node is not installed" >&2; exit 1; }
if [[ ! -d "$ROOT/node_modules/ajv" || ! -d "$ROOT/node_modules/gltf-validator" \
      || ! -d "$ROOT/node_modules/yaml" || ! -d "$ROOT/node_modules/ajv-formats" ]]; then
  (cd "$ROOT" && npm ci --no-audit --no-fund)
fi

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok   - $1"; }
not_ok() { failed=$((failed + 1)); echo "FAIL - $1"; sed 's/^/       | /' "$WORK/out"; }

# expect STATUS DESCRIPTION [--grep TEXT] -- COMMAND...: runs COMMAND, checks its exit status
# and (optionally) that its output mentions TEXT.
expect() {
  local want="$1" what="$2" text=""
  shift 2
  if [[ "$1" == --grep ]]; then text="$2"; shift 2; fi
  [[ "$1" == -- ]] && shift
  local got=0
  "$@" >"$WORK/out" 2>&1 || got=$?
  if [[ "$got" != "$want" ]]; then
    echo "       (exit status $got, expected $want)" >>"$WORK/out"
    not_ok "$what"
  elif [[ -n "$text" ]] && ! grep -qF -- "$text" "$WORK/out"; then
    echo "       (output does not mention: $text)" >>"$WORK/out"
    not_ok "$what"
  else
    ok "$what"
  fi
}

# mutate IN OUT 'JS statements on d': writes OUT, the JSON of IN changed by the statements.
mutate() {
  node -e '
    const fs = require("fs");
    const d = JSON.parse(fs.readFileSync(process.argv[1], "utf8"));
    (new Function("d", process.argv[3]))(d);
    fs.writeFileSync(process.argv[2], JSON.stringify(d));
  ' "$1" "$2" "$3"
}

FL='/v1/meshes/{mesh_id}/feature-lines'
LINE="$FIX/feature_line.json"
MESH="$FIX/mesh_description.json"

echo "# the spec"
expect 0 "api/openapi.yaml compiles (strict), \$refs resolve, examples valid" -- node "$VR" --check-spec

echo "# feature-line responses"
expect 0 "engine output (fixture) is a valid 200 FeatureLine" -- node "$VR" POST "$FL" 200 "$LINE"
expect 0 "concrete path matches its template" -- node "$VR" POST /v1/meshes/0123456789abcdef0123456789abcdef/feature-lines 200 "$LINE"
mutate "$LINE" "$WORK/batch.json" 'const l = JSON.parse(JSON.stringify(d)); for (const k of Object.keys(d)) delete d[k]; d.lines = [l, l];'
expect 0 "batch of two engine outputs is valid" -- node "$VR" POST "$FL" 200 "$WORK/batch.json"

mutate "$LINE" "$WORK/m1.json" 'delete d.stats.timings_ms.snake;'
expect 1 "missing required stats.timings_ms.snake fails" --grep 'missing required property "snake"' -- node "$VR" POST "$FL" 200 "$WORK/m1.json"
mutate "$LINE" "$WORK/m2.json" 'delete d.keys;'
expect 1 "missing required top-level keys fails" --grep '"keys"' -- node "$VR" POST "$FL" 200 "$WORK/m2.json"
mutate "$LINE" "$WORK/m3.json" 'd.refined.length = String(d.refined.length);'
expect 1 "refined.length as a string fails" --grep '/refined/length: must be number' -- node "$VR" POST "$FL" 200 "$WORK/m3.json"
mutate "$LINE" "$WORK/m4.json" 'd.closed = "false";'
expect 1 "closed as a string fails" --grep '/closed: must be boolean' -- node "$VR" POST "$FL" 200 "$WORK/m4.json"
mutate "$LINE" "$WORK/m5.json" 'd.initial.points[3] = [1, 2];'
expect 1 "a 2-component point fails" --grep '/initial/points/3' -- node "$VR" POST "$FL" 200 "$WORK/m5.json"
mutate "$LINE" "$WORK/m6.json" 'd.extra = 1;'
expect 1 "extra top-level property fails" --grep 'unexpected property "extra"' -- node "$VR" POST "$FL" 200 "$WORK/m6.json"
mutate "$LINE" "$WORK/m7.json" 'd.stats.timings_ms.io = 0.1;'
expect 1 "extra nested property fails" --grep 'unexpected property "io"' -- node "$VR" POST "$FL" 200 "$WORK/m7.json"
mutate "$LINE" "$WORK/m8.json" 'd.initial.method = "magic";'
expect 1 "unknown initial.method fails" --grep '/initial/method: must be one of' -- node "$VR" POST "$FL" 200 "$WORK/m8.json"
mutate "$LINE" "$WORK/m9.json" 'd.refined.faces[0] = -1;'
expect 1 "negative face id fails" --grep '/refined/faces/0' -- node "$VR" POST "$FL" 200 "$WORK/m9.json"
mutate "$LINE" "$WORK/m10.json" 'd.stats.fallbacks = [{segment: 0, from: "marching", to: "feature-path"}];'
expect 1 "fallback without reason fails" --grep 'missing required property "reason"' -- node "$VR" POST "$FL" 200 "$WORK/m10.json"
mutate "$LINE" "$WORK/m11.json" 'd.stats.fallbacks = [{segment: 0, from: "marching", to: "feature-path", reason: "overshot the end key"}];'
expect 0 "fallback with every field is valid" -- node "$VR" POST "$FL" 200 "$WORK/m11.json"
mutate "$LINE" "$WORK/m13.json" 'd.stats.pieces_detail[0].kept = "smoothed";'
expect 1 "unknown pieces_detail kept fails" --grep '/stats/pieces_detail/0/kept' -- node "$VR" POST "$FL" 200 "$WORK/m13.json"
mutate "$LINE" "$WORK/m14.json" 'delete d.stats.pieces_detail[0].reason;'
expect 1 "piece report without reason fails" --grep 'missing required property "reason"' -- node "$VR" POST "$FL" 200 "$WORK/m14.json"
mutate "$LINE" "$WORK/m12.json" 'const l = JSON.parse(JSON.stringify(d)); delete l.refined; for (const k of Object.keys(d)) delete d[k]; d.lines = [l];'
expect 1 "batch whose line misses refined fails" --grep '/lines/0' -- node "$VR" POST "$FL" 200 "$WORK/m12.json"
printf '{"keys": [1, 2], ' >"$WORK/trunc.json"
expect 1 "truncated JSON fails" --grep 'not valid JSON' -- node "$VR" POST "$FL" 200 "$WORK/trunc.json"
: >"$WORK/empty.json"
expect 1 "empty body fails" --grep 'empty' -- node "$VR" POST "$FL" 200 "$WORK/empty.json"

echo "# mesh descriptions, health, curvature, errors"
expect 0 "mesh description is a valid 201 upload answer" -- node "$VR" POST /v1/meshes 201 "$MESH"
expect 0 "mesh description is a valid 200 GET answer" -- node "$VR" GET '/v1/meshes/{mesh_id}' 200 "$MESH"
mutate "$MESH" "$WORK/d1.json" 'd.mesh_id = d.mesh_id.toUpperCase();'
expect 1 "uppercase mesh_id fails" --grep '/mesh_id' -- node "$VR" POST /v1/meshes 201 "$WORK/d1.json"
mutate "$MESH" "$WORK/d2.json" 'delete d.curvature.percentiles.p99;'
expect 1 "missing curvature.percentiles.p99 fails" --grep 'missing required property "p99"' -- node "$VR" POST /v1/meshes 201 "$WORK/d2.json"
mutate "$MESH" "$WORK/d6.json" 'd.curvature.method = "quadric";'
expect 1 "unknown curvature.method fails" --grep '/curvature/method' -- node "$VR" POST /v1/meshes 201 "$WORK/d6.json"
mutate "$MESH" "$WORK/d3.json" 'd.vertices = 1681.5;'
expect 1 "fractional vertex count fails" --grep '/vertices: must be integer' -- node "$VR" POST /v1/meshes 201 "$WORK/d3.json"
mutate "$MESH" "$WORK/d4.json" 'd.surface_area = 12.5;'
expect 1 "extra property surface_area fails" --grep 'unexpected property "surface_area"' -- node "$VR" GET '/v1/meshes/{mesh_id}' 200 "$WORK/d4.json"
mutate "$MESH" "$WORK/d5.json" 'd.format = "3ds";'
expect 1 "unknown format fails" --grep '/format' -- node "$VR" GET '/v1/meshes/{mesh_id}' 200 "$WORK/d5.json"

echo '{"status": "ok", "meshes": 0, "uptime_s": 0.5}' >"$WORK/h.json"
expect 0 "health answer is valid" -- node "$VR" GET /healthz 200 "$WORK/h.json"
echo '{"status": "degraded", "meshes": 0, "uptime_s": 0.5}' >"$WORK/h2.json"
expect 1 "health status other than ok fails" --grep '/status' -- node "$VR" GET /healthz 200 "$WORK/h2.json"
echo '{"vertices": 3, "curvature": [0.5, -1, 0]}' >"$WORK/c.json"
expect 0 "curvature JSON is valid" -- node "$VR" GET '/v1/meshes/{mesh_id}/curvature' 200 "$WORK/c.json"
echo '{"vertices": 3, "curvature": [0.5, null, 0]}' >"$WORK/c2.json"
expect 1 "curvature with null (a NaN written by the engine) fails" --grep '/curvature/1' -- node "$VR" GET '/v1/meshes/{mesh_id}/curvature' 200 "$WORK/c2.json"

echo '{"error": {"code": "not_found", "message": "no such mesh"}}' >"$WORK/e1.json"
expect 0 "not_found error is a valid 404" -- node "$VR" DELETE '/v1/meshes/{mesh_id}' 404 "$WORK/e1.json"
expect 1 "not_found code on a 503 fails" --grep '/error/code' -- node "$VR" POST "$FL" 503 "$WORK/e1.json"
echo '{"error": {"code": "malformed_mesh", "message": "OFF: bad header"}}' >"$WORK/e2.json"
expect 0 "malformed_mesh is a valid upload 400" -- node "$VR" POST /v1/meshes 400 "$WORK/e2.json"
echo '{"error": {"code": "not_found", "message": "x", "detail": 1}}' >"$WORK/e3.json"
expect 1 "error with an extra property fails" --grep 'unexpected property "detail"' -- node "$VR" GET '/v1/meshes/{mesh_id}' 404 "$WORK/e3.json"
echo '{"error": "not_found"}' >"$WORK/e4.json"
expect 1 "error as a plain string fails" --grep '/error: must be object' -- node "$VR" GET '/v1/meshes/{mesh_id}' 404 "$WORK/e4.json"
echo '{"error": {"code": "method_not_allowed", "message": "method not allowed on this route"}}' >"$WORK/e5.json"
expect 0 "405 body validates against the Error schema (--schema)" -- node "$VR" --schema Error "$WORK/e5.json"

echo "# request bodies"
expect 0 "request with every option is valid" -- node "$VR" --request POST "$FL" "$FIX/line_request.json"
mutate "$FIX/line_request.json" "$WORK/r0.json" 'const l = JSON.parse(JSON.stringify(d)); for (const k of Object.keys(d)) delete d[k]; d.lines = [l, {keys: [1, 2]}];'
expect 0 "batch request is valid" -- node "$VR" --request POST "$FL" "$WORK/r0.json"
mutate "$FIX/line_request.json" "$WORK/r1.json" 'd.keys = [701];'
expect 1 "one key fails" --grep '/keys' -- node "$VR" --request POST "$FL" "$WORK/r1.json"
mutate "$FIX/line_request.json" "$WORK/r1t.json" 'd.keys = [701]; delete d.closed; d.trace = true;'
expect 0 "one key with trace is valid" -- node "$VR" --request POST "$FL" "$WORK/r1t.json"
mutate "$FIX/line_request.json" "$WORK/r2t.json" 'd.keys = [701, 963]; delete d.closed; d.trace = true;'
expect 1 "two keys with trace fail" --grep '/keys' -- node "$VR" --request POST "$FL" "$WORK/r2t.json"
mutate "$FIX/line_request.json" "$WORK/r2.json" 'd.options.snake.iterationz = 5;'
expect 1 "unknown snake option fails" --grep 'unexpected property "iterationz"' -- node "$VR" --request POST "$FL" "$WORK/r2.json"
mutate "$FIX/line_request.json" "$WORK/r3.json" 'd.options.strip.rings = 9;'
expect 1 "strip.rings out of range fails" --grep '/options/strip/rings' -- node "$VR" --request POST "$FL" "$WORK/r3.json"
# Old option names (before they became member paths) are accepted until the next release.
mutate "$FIX/line_request.json" "$WORK/r3o.json" 'd.options = {initial: "marching", weights: {alpha: 1, delta: 0.25}, curvature_term: "similar-to-end", max_line_edges: 500, rings: 3, flattening: "conformal", snake: {iterations: 100}};'
expect 0 "request with the old option names is valid" -- node "$VR" --request POST "$FL" "$WORK/r3o.json"
mutate "$FIX/line_request.json" "$WORK/r3r.json" 'd.options = {rings: 9};'
expect 1 "old rings out of range fails" --grep '/options/rings' -- node "$VR" --request POST "$FL" "$WORK/r3r.json"
mutate "$FIX/line_request.json" "$WORK/r3i.json" 'd.options.initial = 5;'
expect 1 "initial neither an object nor a method fails" --grep '/options/initial' -- node "$VR" --request POST "$FL" "$WORK/r3i.json"
mutate "$FIX/line_request.json" "$WORK/r8.json" 'd.options.keep_initial_below = 1.5;'
expect 1 "keep_initial_below out of range fails" --grep '/options/keep_initial_below' -- node "$VR" --request POST "$FL" "$WORK/r8.json"
mutate "$FIX/line_request.json" "$WORK/r4.json" 'd.keys[1] = {point: [0, 0]};'
expect 1 "2-component point key fails" --grep '/keys/1' -- node "$VR" --request POST "$FL" "$WORK/r4.json"
mutate "$FIX/line_request.json" "$WORK/r5.json" 'd.keys[0] = -3;'
expect 1 "negative vertex key fails" --grep '/keys/0' -- node "$VR" --request POST "$FL" "$WORK/r5.json"
mutate "$FIX/line_request.json" "$WORK/r6.json" 'const l = {keys: [1, 2]}; for (const k of Object.keys(d)) delete d[k]; d.lines = Array(65).fill(l);'
expect 1 "batch of 65 lines fails" --grep '/lines' -- node "$VR" --request POST "$FL" "$WORK/r6.json"
mutate "$FIX/line_request.json" "$WORK/r7.json" 'd.lines = [{keys: [1, 2]}];'
expect 1 "keys and lines together fail" -- node "$VR" --request POST "$FL" "$WORK/r7.json"

echo "# usage errors (exit 2)"
expect 2 "unknown path" --grep 'unknown path' -- node "$VR" GET /v2/nothing 200 "$LINE"
expect 2 "unknown method" --grep 'no PUT operation' -- node "$VR" PUT /v1/meshes 200 "$LINE"
expect 2 "undocumented status" --grep 'status not documented' -- node "$VR" GET /healthz 418 "$LINE"
expect 2 "status without a JSON body (204)" --grep 'documents no body' -- node "$VR" DELETE '/v1/meshes/{mesh_id}' 204 "$LINE"
expect 2 "binary-only response (mesh.glb)" --grep 'no application/json body' -- node "$VR" GET '/v1/meshes/{mesh_id}/mesh.glb' 200 "$LINE"
expect 2 "missing file" --grep 'cannot read' -- node "$VR" POST "$FL" 200 "$WORK/does-not-exist.json"
expect 2 "unknown schema name" -- node "$VR" --schema Nope "$LINE"
expect 2 "no arguments" --grep 'usage' -- node "$VR"

echo "# glTF"
GLB="$FIX/feature_line.glb"
expect 0 "engine GLB (mesh with _CURVATURE, LINE_STRIP with COLOR_0) has no errors" --grep '0 errors' -- node "$VG" "$GLB"
head -c 40000 "$GLB" >"$WORK/trunc.glb"
expect 1 "truncated GLB fails" --grep 'GLB_UNEXPECTED_END_OF_CHUNK_DATA' -- node "$VG" "$WORK/trunc.glb"
head -c 11 "$GLB" >"$WORK/header.glb"
expect 1 "GLB cut inside its header fails" --grep 'GLB_UNEXPECTED_END_OF_HEADER' -- node "$VG" "$WORK/header.glb"
# GLB <-> glTF JSON, so that the JSON can be corrupted semantically.
node -e '
  const fs = require("fs");
  const [src, gltfOut, badGlbOut] = process.argv.slice(1);
  const b = fs.readFileSync(src);
  const jsonLength = b.readUInt32LE(12);
  const doc = JSON.parse(b.subarray(20, 20 + jsonLength).toString("utf8"));
  const binStart = 20 + jsonLength;
  const bin = b.subarray(binStart + 8, binStart + 8 + b.readUInt32LE(binStart));
  // the same asset as .gltf with its buffer as a data URI
  const embedded = JSON.parse(JSON.stringify(doc));
  embedded.buffers[0].uri = "data:application/octet-stream;base64," + bin.toString("base64");
  fs.writeFileSync(gltfOut, JSON.stringify(embedded));
  // a GLB whose RGBA8 colours are no longer normalised (not allowed for COLOR_0)
  for (const mesh of doc.meshes) for (const p of mesh.primitives)
    if (p.attributes.COLOR_0 !== undefined) delete doc.accessors[p.attributes.COLOR_0].normalized;
  let json = Buffer.from(JSON.stringify(doc), "utf8");
  json = Buffer.concat([json, Buffer.alloc((4 - (json.length % 4)) % 4, 0x20)]);
  const header = Buffer.alloc(12), jsonHeader = Buffer.alloc(8), binHeader = Buffer.alloc(8);
  header.writeUInt32LE(0x46546c67, 0); header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + 8 + json.length + 8 + bin.length, 8);
  jsonHeader.writeUInt32LE(json.length, 0); jsonHeader.writeUInt32LE(0x4e4f534a, 4);
  binHeader.writeUInt32LE(bin.length, 0); binHeader.writeUInt32LE(0x004e4942, 4);
  fs.writeFileSync(badGlbOut, Buffer.concat([header, jsonHeader, json, binHeader, bin]));
' "$GLB" "$WORK/line.gltf" "$WORK/unnormalised.glb"
expect 0 "the same asset as .gltf (embedded buffer) has no errors" --grep '0 errors' -- node "$VG" "$WORK/line.gltf"
expect 1 "GLB with un-normalised RGBA8 COLOR_0 fails" --grep 'ERROR MESH_PRIMITIVE_ATTRIBUTES_ACCESSOR_INVALID_FORMAT' -- node "$VG" "$WORK/unnormalised.glb"
node -e '
  const fs = require("fs");
  const d = JSON.parse(fs.readFileSync(process.argv[1], "utf8"));
  d.accessors[0].count += 1000;  // reads past its buffer view
  fs.writeFileSync(process.argv[2], JSON.stringify(d));
' "$WORK/line.gltf" "$WORK/overrun.gltf"
expect 1 "glTF with an accessor past its buffer view fails" --grep 'ERROR ACCESSOR_TOO_LONG' -- node "$VG" "$WORK/overrun.gltf"
echo 'not a model' >"$WORK/text.bin"
expect 1 "a file that is no glTF fails" --grep 'refused' -- node "$VG" "$WORK/text.bin"
expect 2 "missing file" --grep 'cannot read' -- node "$VG" "$WORK/does-not-exist.glb"

echo "$passed passed, $failed failed"
[[ "$failed" == 0 ]]
