#!/usr/bin/env bash
# Integration test of featureline-server, driven with curl exactly as a user would: starts the
# real binary on free ports (--port 0 --port-file), uploads every shared test mesh, asks for
# feature lines as JSON and glTF, provokes every error status, sends hostile input, checks
# request smuggling, concurrency, deletion during use, CORS, /metrics, session expiry and
# eviction, and SIGTERM. Every JSON body is validated against api/openapi.yaml and every
# glTF/GLB answer with the Khronos validator (tests/integration/*.mjs).
#
#   SERVER=build/server/featureline-server SHARED=../shared bash tests/integration/server_test.sh
#
# Environment: SERVER (default build/server/featureline-server), SHARED (default ../shared
# beside the repository), JOBS (parallel validator runs, default nproc), TIME_FACTOR (scales
# the time limits; 3 by default for a sanitizer build), KEEP_TMP=1 keeps the work folder.
# Prints "ok   NAME" / "FAIL NAME" lines and "N passed, N failed"; exits 1 on any failure.
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), SERVER, SHARED, MESHES, VR, VG, JOBS

# ---- preconditions: fail loudly, never skip ----------------------------------------------------
for tool in curl jq node perl md5sum; do
  command -v "$tool" >/dev/null || { echo "FAIL $tool is not installed (run scripts/setup.sh)"; exit 1; }
done
for pkg in ajv ajv-formats yaml gltf-validator; do
  [ -d "$ROOT/node_modules/$pkg" ] || {
    echo "FAIL node_modules/$pkg is missing: run scripts/setup.sh (or npm ci at the repository root)"; exit 1; }
done
[ -x "$SERVER" ] || { echo "FAIL no server binary at $SERVER (build it, or set SERVER=...)"; exit 1; }
[ -f "$MESHES/SOURCES.md" ] || { echo "FAIL missing $MESHES/SOURCES.md: the shared test meshes are expected in \$SHARED/data/meshes (SHARED=$SHARED)"; exit 1; }
# Every mesh SOURCES.md lists must be there, with its as-stored counts for the checks below.
declare -A SRC_V=() SRC_F=()
while IFS='|' read -r _ file _ verts faces _; do
  file=$(printf %s "$file" | tr -d '` ')
  SRC_V[$file]=$(printf %s "$verts" | tr -d ', ')
  SRC_F[$file]=$(printf %s "$faces" | sed -E 's/^ *([0-9,]+).*/\1/' | tr -d ',')
done < <(grep -E '^\| `[^`]+` \|' "$MESHES/SOURCES.md")
[ "${#SRC_V[@]}" -ge 30 ] || { echo "FAIL could not read the mesh table of $MESHES/SOURCES.md"; exit 1; }
missing=()
for file in "${!SRC_V[@]}"; do [ -f "$MESHES/$file" ] || missing+=("$file"); done
if [ ${#missing[@]} -gt 0 ]; then
  echo "FAIL test meshes missing from $MESHES: ${missing[*]}"; exit 1
fi

# A sanitizer build is about 3x slower: scale every time limit.
FACTOR=$(time_factor "$SERVER")
CURL_MAX=$((60 * FACTOR))
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-it.XXXXXX")
trap cleanup EXIT
trap 'exit 130' INT TERM
T=$TMP
echo "# server $SERVER (time factor $FACTOR), meshes $MESHES"
started_at=$(now_s)

# The engine deadline scales with the time factor: a sanitizer build runs the engine 3-5x slower.
start_server main --deadline-s $((30 * FACTOR)) || { finish; exit 1; }
B=${SRV_BASE[main]}

healthz() {  # healthz SERVER_NAME LABEL
  http "$T/hz.json" "${SRV_BASE[$1]}/healthz"
  if [ "$STATUS" = 200 ]; then pass "$2"; validate_json "$2: body matches the contract" GET /healthz 200 "$T/hz.json"
  else fail "$2" "GET /healthz answered $STATUS" "$(tail -n 5 "${SRV_LOG[$1]}")"; fi
}

# ---- 1. every shared mesh uploads (201) or is refused cleanly (4xx) ------------------------------
echo "# 1. uploads"
declare -A ID=() DESC=()
for path in "$MESHES"/*; do
  name=$(basename "$path")
  ext=${name##*.}; ext=${ext,,}
  case $ext in obj | off | ply | stl | glb | gltf | drc) ;; *) continue ;; esac
  out="$T/upload.$name.json"
  http "$out" --data-binary @"$path" -H 'Content-Type: application/octet-stream' "$B/v1/meshes?format=$ext"
  case $STATUS in
    201)
      pass "upload $name: 201"
      id=$(jq -r .mesh_id "$out")
      ID[$name]=$id; DESC[$name]=$out
      check_eq "upload $name: Location names the new mesh" "$(header "$out" Location)" "/v1/meshes/$id"
      check_eq "upload $name: format echoed" "$(jq -r .format "$out")" "$ext"
      if [[ $ext == obj || $ext == off || $ext == ply ]]; then
        check_eq "upload $name: file_vertices, file_faces as in SOURCES.md" \
          "$(jq -r '"\(.file_vertices) \(.file_faces)"' "$out")" "${SRC_V[$name]:-?} ${SRC_F[$name]:-?}"
      fi ;;
    4??)
      code=$(error_code "$out")
      if [ -n "$code" ]; then pass "upload $name: refused cleanly ($STATUS $code: $(jq -r .error.message "$out" | head -c 100))"
      else fail "upload $name: 4xx carries an error body" "$(head -c 300 "$out")"; fi ;;
    *) fail "upload $name: 201 or a clear 4xx" "got $STATUS: $(head -c 300 "$out")" ;;
  esac
  [ "$STATUS" != 000 ] && validate_json "upload $name: body matches the contract" POST /v1/meshes "$STATUS" "$out"
  healthz main "healthz after uploading $name"
done

counts() { jq -r '"\(.vertices) \(.faces)"' "${DESC[$1]:-/dev/null}" 2>/dev/null; }
# Known counts after loading (STL/glTF/Draco welded by position; polygons fan-triangulated).
check_eq "fandisk.off: 6475 vertices, 12946 faces" "$(counts fandisk.off)" "6475 12946"
check_eq "Box.glb: welded to 8 vertices, 12 faces" "$(counts Box.glb)" "8 12"
check_eq "Box_Draco.glb: welded to 8 vertices, 12 faces" "$(counts Box_Draco.glb)" "8 12"
check_eq "bunny_gltf.drc: 34834 vertices, 69451 faces" "$(counts bunny_gltf.drc)" "34834 69451"
check_eq "bunny_closed.off: 34835 vertices, 69666 faces" "$(counts bunny_closed.off)" "34835 69666"
check_eq "igea.ply (triangle strips): 134345 vertices, 268686 faces" "$(counts igea.ply)" "134345 268686"
check_eq "chamfer-cube.off: polygons fan-triangulated to 44" "$(counts chamfer-cube.off)" "24 44"
check_eq "spot_control_mesh.obj: polygons fan-triangulated to 372" "$(counts spot_control_mesh.obj)" "188 372"
check_eq "deg_faces.obj: the face with a repeated vertex dropped" \
  "$(jq -r '"\(.faces) \(.dropped_faces)"' "${DESC[deg_faces.obj]:-/dev/null}" 2>/dev/null)" "3 1"
check_eq "multiple_tetrahedrons.obj: 5 components" "$(jq -r .components "${DESC[multiple_tetrahedrons.obj]:-/dev/null}" 2>/dev/null)" 5

# The format from the Content-Type, and sniffed from the bytes.
http "$T/ct.json" --data-binary @"$MESHES/cube.obj" -H 'Content-Type: model/obj' "$B/v1/meshes"
expect "upload with Content-Type model/obj" 201 - POST /v1/meshes "$T/ct.json"
check_eq "Content-Type model/obj read as obj" "$(jq -r .format "$T/ct.json")" obj
http "$T/sniff.json" --data-binary @"$MESHES/fandisk.off" -H 'Content-Type: application/octet-stream' "$B/v1/meshes"
expect "upload as octet-stream without format" 201 - POST /v1/meshes "$T/sniff.json"
check_eq "octet-stream OFF sniffed as off" "$(jq -r .format "$T/sniff.json")" off
http "$T/sniff2.json" --data-binary @"$MESHES/Box.glb" -H 'Content-Type: application/octet-stream' "$B/v1/meshes"
expect "upload GLB as octet-stream without format" 201 - POST /v1/meshes "$T/sniff2.json"
check_eq "octet-stream GLB sniffed as glb" "$(jq -r .format "$T/sniff2.json")" glb

# A .gltf with its .bin as multipart/form-data (curl -F, a browser's FormData): Box.glb split
# into Box.gltf, whose buffer is "Box 0.bin".
python3 - "$MESHES/Box.glb" "$T" <<'PY'
import json, struct, sys
data = open(sys.argv[1], 'rb').read()
json_length = struct.unpack('<I', data[12:16])[0]
doc = json.loads(data[20:20 + json_length])
bin_length = struct.unpack('<I', data[20 + json_length:24 + json_length])[0]
doc['buffers'][0]['uri'] = 'Box%200.bin'
open(sys.argv[2] + '/Box.gltf', 'w').write(json.dumps(doc))
open(sys.argv[2] + '/Box 0.bin', 'wb').write(data[28 + json_length:28 + json_length + bin_length])
PY
http "$T/files.json" -F "files=@$T/Box.gltf" -F "files=@\"$T/Box 0.bin\"" "$B/v1/meshes"
expect "upload a .gltf with its .bin (multipart)" 201 - POST /v1/meshes "$T/files.json"
check_eq "... packed into one GLB: Box's 8 vertices, 12 faces" "$(jq -c '[.format, .vertices, .faces]' "$T/files.json")" '["glb",8,12]'
http "$T/files2.json" -F "files=@$T/Box.gltf" "$B/v1/meshes"
expect "a .gltf without the .bin it names" 400 malformed_mesh POST /v1/meshes "$T/files2.json"
check "... naming the missing file" grep -q 'Box 0.bin' "$T/files2.json"
http "$T/files3.json" -F "files=@$T/Box.gltf" -F "more=@$T/Box.gltf;filename=Other.gltf" "$B/v1/meshes"
expect "two .gltf files in one upload" 415 unsupported_format POST /v1/meshes "$T/files3.json"

# Binary STL, written from fandisk.off (no STL among the shared meshes): welded back to 6475.
perl -e '
  local $/; open my $f, "<", $ARGV[0] or die; my $s = <$f>; $s =~ s/#[^\n]*//g;
  my @t = split " ", $s; shift(@t) eq "OFF" or die "not OFF";
  my ($nv, $nf) = splice(@t, 0, 3); my @v = map { [splice(@t, 0, 3)] } 1 .. $nv;
  binmode STDOUT; print sprintf("%-80s", "featureline integration test: fandisk.off as binary STL");
  print pack("V", $nf);
  for (1 .. $nf) { my ($n, @i) = splice(@t, 0, 4); print pack("f<3", 0, 0, 0); print pack("f<3", @{$v[$_]}) for @i; print pack("v", 0) }
' "$MESHES/fandisk.off" >"$T/fandisk.stl"
http "$T/stl.json" --data-binary @"$T/fandisk.stl" -H 'Content-Type: model/stl' "$B/v1/meshes"
expect "upload binary STL (fandisk)" 201 - POST /v1/meshes "$T/stl.json"
check_eq "binary STL welded to 6475 vertices, 12946 faces" "$(jq -r '"\(.vertices) \(.faces)"' "$T/stl.json")" "6475 12946"

# ---- 2. describe, delete ------------------------------------------------------------------------
echo "# 2. session lifecycle"
http "$T/life.json" --data-binary @"$MESHES/cube.obj" -H 'Content-Type: model/obj' "$B/v1/meshes"
life=$(jq -r .mesh_id "$T/life.json")
http "$T/get.json" "$B/v1/meshes/$life"
expect "GET description" 200 - GET "/v1/meshes/$life" "$T/get.json"
check_eq "description matches the upload's" "$(jq -c 'del(.expires_in_s)' "$T/get.json")" "$(jq -c 'del(.expires_in_s)' "$T/life.json")"
http "$T/del.out" -X DELETE "$B/v1/meshes/$life"
check_eq "DELETE: 204" "$STATUS" 204
check "DELETE: no body" test ! -s "$T/del.out"
http "$T/get2.json" "$B/v1/meshes/$life"
expect "GET after DELETE" 404 not_found GET "/v1/meshes/$life" "$T/get2.json"
http "$T/del2.json" -X DELETE "$B/v1/meshes/$life"
expect "DELETE twice" 404 not_found DELETE "/v1/meshes/$life" "$T/del2.json"

# ---- 3. feature lines on fandisk ----------------------------------------------------------------
echo "# 3. feature lines"
F=${ID[fandisk.off]:-missing}
FL="/v1/meshes/$F/feature-lines"
lines() {  # lines OUT REQUEST_FILE [CURL_ARGS...] -- posts to $FL
  local out=$1 req=$2; shift 2
  http "$out" -H 'Content-Type: application/json' --data-binary @"$req" "$@" "$B$FL${QUERY:-}"
}
echo '{"keys": [10, 200, 400]}' >"$T/r1.json"
validate_request "request {keys: [10, 200, 400]} matches the contract" POST "$FL" "$T/r1.json"
lines "$T/l1.json" "$T/r1.json"
expect "feature line 10,200,400" 200 - POST "$FL" "$T/l1.json"
check_eq "keys echoed" "$(jq -c .keys "$T/l1.json")" "[10,200,400]"
check_eq "closed false echoed" "$(jq .closed "$T/l1.json")" false
check "refined line has more than 2 points" [ "$(jq '.refined.points | length' "$T/l1.json")" -gt 2 ]
check_eq "refined points, faces, barycentric in step" \
  "$(jq '(.refined.points|length) == (.refined.faces|length) and (.refined.faces|length) == (.refined.barycentric|length)' "$T/l1.json")" true
check_eq "initial line runs from key 10 to key 400" "$(jq -c '[.initial.vertices[0], .initial.vertices[-1]]' "$T/l1.json")" "[10,400]"

# Points as keys: the exact positions of the key vertices, from the answer's initial line.
jq '{keys: [.initial as $i | (10, 200, 400) as $k | {point: $i.points[$i.vertices | index($k)]}]}' "$T/l1.json" >"$T/r2.json"
validate_request "request with point keys matches the contract" POST "$FL" "$T/r2.json"
lines "$T/l2.json" "$T/r2.json"
expect "feature line through points" 200 - POST "$FL" "$T/l2.json"
check_eq "point keys snapped to their vertices" "$(jq -c .keys "$T/l2.json")" "[10,200,400]"
check_eq "point keys give the same refined line" "$(jq -c .refined.points "$T/l2.json")" "$(jq -c .refined.points "$T/l1.json")"
jq '{keys: [10, {point: (.initial as $i | $i.points[$i.vertices | index(200)] | map(. + 1e-6))}, 400]}' "$T/l1.json" >"$T/r2b.json"
lines "$T/l2b.json" "$T/r2b.json"
expect "mixed vertex and nudged point keys" 200 - POST "$FL" "$T/l2b.json"
check_eq "nudged point snapped to the nearest vertex" "$(jq -c .keys "$T/l2b.json")" "[10,200,400]"

# keep_initial_below 0: the first line always keeps the snake's line (on this fandisk line the
# never-worse test would keep the initial line), so "refined" shows only the refine option.
echo '{"lines": [{"keys": [10, 200], "options": {"keep_initial_below": 0}}, {"keys": [200, 400], "options": {"refine": false}}]}' >"$T/r3.json"
validate_request "batch request matches the contract" POST "$FL" "$T/r3.json"
lines "$T/l3.json" "$T/r3.json"
expect "batch of 2 lines" 200 - POST "$FL" "$T/l3.json"
check_eq "batch answers 2 lines in order" "$(jq -c '[.lines[].keys]' "$T/l3.json")" "[[10,200],[200,400]]"
check_eq "refine false honoured in the batch" "$(jq -c '[.lines[].stats.refined]' "$T/l3.json")" "[true,false]"

# Options by their old names (before they became member paths), still accepted, answer as the new names do.
echo '{"lines": [{"keys": [10, 200], "options": {"initial": "geodesic", "rings": 3, "snake": {"iterations": 40}}},
  {"keys": [10, 200], "options": {"initial": {"method": "geodesic"}, "strip": {"rings": 3}, "snake": {"max_iterations": 40}}}]}' >"$T/r3o.json"
validate_request "a request by old and new option names matches the contract" POST "$FL" "$T/r3o.json"
lines "$T/l3o.json" "$T/r3o.json"
expect "a line by old option names and one by the new" 200 - POST "$FL" "$T/l3o.json"
check_eq "old and new names give the same line" "$(jq -c '[.lines[] | [.initial.method, .refined.length]] | unique | length' "$T/l3o.json")" 1

echo '{"keys": [10, 200, 400], "closed": true}' >"$T/r4.json"
validate_request "closed request matches the contract" POST "$FL" "$T/r4.json"
lines "$T/l4.json" "$T/r4.json"
expect "closed loop 10,200,400" 200 - POST "$FL" "$T/l4.json"
check_eq "closed true echoed" "$(jq .closed "$T/l4.json")" true
check_eq "closed loop's initial line passes every key" "$(jq '.initial.vertices as $v | [10, 200, 400] | all(. as $k | $v | index($k) != null)' "$T/l4.json")" true

# One key traced: fandisk's vertex 2000 lies on a convex crease chain of 66 edges that ends at a
# junction of three creases at each end (vertices 1537 and 1267).
echo '{"keys": [2000], "trace": true}' >"$T/t1.json"
validate_request "traced request matches the contract" POST "$FL" "$T/t1.json"
lines "$T/lt1.json" "$T/t1.json"
expect "line traced from key 2000" 200 - POST "$FL" "$T/lt1.json"
check_eq "traced: the crease chain between two junctions" \
  "$(jq -c '[.closed, (.initial.vertices | length), .initial.method, .trace.sign, .trace.on_crease, [.trace.ends[].reason], .keys]' "$T/lt1.json")" \
  '[false,67,"trace","ridge",true,["junction","junction"],[1537,1267]]'
check_eq "traced: both junctions reported, not followed" "$(jq -c '[.trace.junctions[] | [.vertex, .branches, .followed]] | sort' "$T/lt1.json")" \
  '[[1267,3,false],[1537,3,false]]'
echo '{"keys": [2000, 2001], "trace": true}' >"$T/t2.json"
lines "$T/lt2.json" "$T/t2.json"
expect "trace from two keys" 400 invalid_request POST "$FL" "$T/lt2.json"
check "... saying a trace starts from one key" grep -q 'exactly one key' "$T/lt2.json"
echo '{"keys": [2000], "trace": "yes"}' >"$T/t3.json"
lines "$T/lt3.json" "$T/t3.json"
expect "trace not a boolean" 400 invalid_request POST "$FL" "$T/lt3.json"
echo '{"keys": [2500], "trace": true}' >"$T/t4.json"
lines "$T/lt4.json" "$T/t4.json"
expect "trace on a flat face" 422 unprocessable_geometry POST "$FL" "$T/lt4.json"
check "... saying there is nothing to trace" grep -q 'no ridge, valley or crease to trace at vertex' "$T/lt4.json"
echo '{"keys": [2000], "trace": true, "options": {"trace": {"max_edges": 10, "step": 11}}}' >"$T/t5.json"
lines "$T/lt5.json" "$T/t5.json"
expect "trace option out of range" 400 invalid_request POST "$FL" "$T/lt5.json"
check "... naming options.trace.step" grep -q 'options.trace.step' "$T/lt5.json"
QUERY='?format=glb' lines "$T/gt1.glb" "$T/t1.json"
check_eq "traced line as GLB: 200" "$STATUS" 200
validate_gltf "traced line as GLB: passes the glTF validator" "$T/gt1.glb"

is_glb() { [ "$(head -c 4 "$1")" = glTF ]; }
QUERY='?format=glb' lines "$T/g1.glb" "$T/r1.json"
check_eq "?format=glb: 200" "$STATUS" 200
check_eq "?format=glb: Content-Type" "$(header "$T/g1.glb" Content-Type)" model/gltf-binary
check "?format=glb: GLB magic" is_glb "$T/g1.glb"
validate_gltf "?format=glb: passes the glTF validator" "$T/g1.glb"
# With the fitted curve: its JSON passes the contract, and its GLB node passes the validator.
echo '{"keys": [10, 200, 400], "options": {"fitted": {"enabled": true}}}' >"$T/rf.json"
lines "$T/lf.json" "$T/rf.json"
expect "a line with its fitted curve" 200 - POST "$FL" "$T/lf.json"
check "... has fitted points" test "$(jq '.lines[0].fitted.points // .fitted.points | length' "$T/lf.json" 2>/dev/null)" -ge 2
QUERY='?format=glb' lines "$T/gf.glb" "$T/rf.json"
check "... as GLB: a node fitted_curve_0" grep -qa 'fitted_curve_0' "$T/gf.glb"
validate_gltf "... as GLB: passes the glTF validator" "$T/gf.glb"
lines "$T/g2.glb" "$T/r3.json" -H 'Accept: model/gltf-binary'
check_eq "Accept model/gltf-binary (batch): 200" "$STATUS" 200
check_eq "Accept model/gltf-binary: Content-Type" "$(header "$T/g2.glb" Content-Type)" model/gltf-binary
check "Accept model/gltf-binary: GLB magic" is_glb "$T/g2.glb"
validate_gltf "Accept model/gltf-binary: passes the glTF validator" "$T/g2.glb"
lines "$T/g3.gltf" "$T/r4.json" -H 'Accept: model/gltf+json'
check_eq "Accept model/gltf+json (closed): 200" "$STATUS" 200
check_eq "Accept model/gltf+json: Content-Type" "$(header "$T/g3.gltf" Content-Type)" model/gltf+json
check_eq "Accept model/gltf+json: a glTF 2.0 document" "$(jq -r .asset.version "$T/g3.gltf" 2>/dev/null)" 2.0
validate_gltf "Accept model/gltf+json: passes the glTF validator" "$T/g3.gltf"
QUERY='?format=json' lines "$T/l5.json" "$T/r1.json" -H 'Accept: model/gltf-binary'
expect "?format=json wins over Accept" 200 - POST "$FL" "$T/l5.json"
check_eq "?format=json answers JSON" "$(header "$T/l5.json" Content-Type)" application/json
QUERY='?format=stl' lines "$T/l6.json" "$T/r1.json"
expect "?format=stl on feature-lines" 400 invalid_request POST "$FL" "$T/l6.json"
check "... naming the formats lines can be" grep -q 'format must be json, glb, gltf, obj, ply, polylines, csv' "$T/l6.json"
QUERY='?format=obj' lines "$T/l7.obj" "$T/r1.json"
check_eq "?format=obj on feature-lines: 200" "$STATUS" 200
check_eq "?format=obj: Content-Type model/obj" "$(header "$T/l7.obj" Content-Type)" model/obj
check_eq "?format=obj: one l record per line" "$(grep -c '^l ' "$T/l7.obj")" 1
QUERY='?format=polylines' lines "$T/l8.txt" "$T/r1.json"
check_eq "?format=polylines: one polyline, its count first" "$(awk '{ print (NF - 1) / 3 == $1 }' "$T/l8.txt")" 1
# The contract: glTF answers hold the lines only (to overlay on mesh.glb): no triangles, a
# LINE_STRIP per initial and refined line, and a node feature_line_<i> per line.
check_eq "glTF answer holds no triangle primitive" \
  "$(jq '[.meshes[].primitives[] | select((.mode // 4) == 4)] | length' "$T/g3.gltf" 2>/dev/null)" 0
check_eq "glTF answer holds the initial and refined lines (a closed request: LINE_LOOP)" \
  "$(jq '[.meshes[].primitives[] | select(.mode == 2 or .mode == 3)] | length' "$T/g3.gltf" 2>/dev/null)" 2
check_eq "glTF answer has the node feature_line_0" "$(jq '[.nodes[] | select(.name == "feature_line_0")] | length' "$T/g3.gltf" 2>/dev/null)" 1

# ---- 3b. segmentation ---------------------------------------------------------------------------
echo "# 3b. segmentation"
http "$T/sample.json" -H 'Content-Type: application/octet-stream' --data-binary @samples/ridge_field.off "$B/v1/meshes?format=off"
expect "upload the bundled sample" 201 - POST /v1/meshes "$T/sample.json"
S=$(jq -r .mesh_id "$T/sample.json")
SEG="/v1/meshes/$S/segmentation"
for mode in snap remesh; do
  echo "{\"lines\": [{\"keys\": [820, 860]}], \"mode\": \"$mode\"}" >"$T/seg_$mode.req"
  validate_request "segmentation request ($mode) matches the contract" POST "$SEG" "$T/seg_$mode.req"
  http "$T/seg_$mode.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_$mode.req" "$B$SEG"
  expect "segmentation along a border-to-border line ($mode)" 200 - POST "$SEG" "$T/seg_$mode.json"
  check_eq "$mode: two parts" "$(jq '.segments | length' "$T/seg_$mode.json")" 2
  check_eq "$mode: part areas add up to the total" "$(jq '((.segments|map(.area)|add) - .total_area) | fabs < 1e-9' "$T/seg_$mode.json")" true
done
check_eq "snap: a label per face of the mesh" "$(jq '.labels | length' "$T/seg_snap.json")" 3200
check_eq "remesh: a label per face of the remeshed mesh" "$(jq '(.labels | length) == (.remeshed.faces | length)' "$T/seg_remesh.json")" true
check_eq "remesh: original vertices kept, new ones appended" "$(jq '.remeshed.vertices | length > 1681' "$T/seg_remesh.json")" true
http "$T/seg.glb" -H 'Content-Type: application/json' --data-binary @"$T/seg_snap.req" "$B$SEG?format=glb"
check_eq "segmentation ?format=glb: 200" "$STATUS" 200
validate_gltf "segmentation GLB passes the glTF validator" "$T/seg.glb"
echo '{"lines": [{"keys": [700, 705]}]}' >"$T/seg_open.req"
http "$T/seg_open.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_open.req" "$B$SEG"
expect "a line that closes no region" 422 unprocessable_geometry POST "$SEG" "$T/seg_open.json"
echo '{"lines": [{"keys": [820, 860]}], "mode": "sideways"}' >"$T/seg_bad.req"
http "$T/seg_bad.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_bad.req" "$B$SEG"
expect "an unknown segmentation mode" 400 invalid_request POST "$SEG" "$T/seg_bad.json"
# Lines computed before (a feature-line answer's refined faces and barycentrics) segment exactly
# as the requests that detect them, alone or mixed with a request; bad ones get exact errors.
echo '{"keys": [820, 860]}' >"$T/seg_line.req"
http "$T/seg_line.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_line.req" "$B/v1/meshes/$S/feature-lines"
check_eq "the line to segment with, detected once: 200" "$STATUS" 200
for mode in snap remesh; do
  jq -c --arg mode "$mode" '{lines: [{keys, closed, refined}], mode: $mode}' "$T/seg_line.json" >"$T/seg_computed_$mode.req"
  validate_request "segmentation request with a computed line ($mode) matches the contract" POST "$SEG" "$T/seg_computed_$mode.req"
  http "$T/seg_computed_$mode.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_computed_$mode.req" "$B$SEG"
  expect "segmentation along a computed line ($mode)" 200 - POST "$SEG" "$T/seg_computed_$mode.json"
  check_eq "$mode: a computed line gives the labels and parts of its request" \
    "$(jq -c '[.labels, [.segments[] | .area, .faces], .remeshed]' "$T/seg_computed_$mode.json")" \
    "$(jq -c '[.labels, [.segments[] | .area, .faces], .remeshed]' "$T/seg_$mode.json")"
done
check_eq "segments carry their colours (sRGB)" "$(jq -c '[.segments[].color | length == 3 and all(. >= 0 and . <= 1)] | all' "$T/seg_snap.json")" true
jq -c '{lines: [{keys, closed, refined: {faces: .refined.faces, barycentric: .refined.barycentric}}, {keys: [820, 860]}]}' \
  "$T/seg_line.json" >"$T/seg_mixed.req"
http "$T/seg_mixed.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_mixed.req" "$B$SEG"
expect "segmentation with a computed line and a line request" 200 - POST "$SEG" "$T/seg_mixed.json"
check_eq "mixed: the same two parts" "$(jq -c '[.segments[].area]' "$T/seg_mixed.json")" "$(jq -c '[.segments[].area]' "$T/seg_snap.json")"
jq -c '{lines: [{refined: {faces: (.refined.faces | .[1] = 3200), barycentric: .refined.barycentric}}]}' "$T/seg_line.json" >"$T/seg_badface.req"
http "$T/seg_badface.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_badface.req" "$B$SEG"
expect "a computed line with a face out of range" 400 invalid_request POST "$SEG" "$T/seg_badface.json"
check_eq "the error names the point and the face count" "$(jq -r .error.message "$T/seg_badface.json")" \
  "lines[0].refined, point 1: face 3200 is out of range (the mesh has 3200 faces)"
jq -c '{lines: [{refined: {faces: .refined.faces, barycentric: (.refined.barycentric | .[2] = [0.5, 0.5, 0.5])}}]}' "$T/seg_line.json" >"$T/seg_badbary.req"
http "$T/seg_badbary.json" -H 'Content-Type: application/json' --data-binary @"$T/seg_badbary.req" "$B$SEG"
expect "a computed line with barycentric coordinates not summing to 1" 400 invalid_request POST "$SEG" "$T/seg_badbary.json"
check_eq "the error names the point" "$(jq -r .error.message "$T/seg_badbary.json")" \
  "lines[0].refined, point 2: barycentric coordinates must sum to 1"

# ---- 4. mesh.glb and curvature ------------------------------------------------------------------
echo "# 4. mesh.glb, curvature"
http "$T/mesh.glb" "$B/v1/meshes/$F/mesh.glb"
check_eq "GET mesh.glb: 200" "$STATUS" 200
check_eq "GET mesh.glb: Content-Type" "$(header "$T/mesh.glb" Content-Type)" model/gltf-binary
check "GET mesh.glb: GLB magic" is_glb "$T/mesh.glb"
validate_gltf "GET mesh.glb: passes the glTF validator" "$T/mesh.glb"
# The page's compact form: KHR_mesh_quantization, valid glTF, far smaller; the float GLB stays
# the default. Its positions are checked against the prepared mesh in tests/api/gltf_compact_test.
http "$T/compact.glb" "$B/v1/meshes/$F/mesh.glb?compact=1"
check_eq "GET mesh.glb?compact=1: 200" "$STATUS" 200
check "GET mesh.glb?compact=1: GLB magic" is_glb "$T/compact.glb"
validate_gltf "GET mesh.glb?compact=1: passes the glTF validator" "$T/compact.glb"
check "mesh.glb?compact=1 is under 40% of mesh.glb" \
  awk -v a="$(wc -c <"$T/compact.glb")" -v b="$(wc -c <"$T/mesh.glb")" 'BEGIN { exit !(a < 0.4 * b) }'
http "$T/compact_bad.json" "$B/v1/meshes/$F/mesh.glb?compact=yes"
expect "mesh.glb?compact=yes" 400 invalid_request GET "/v1/meshes/$F/mesh.glb" "$T/compact_bad.json"
http "$T/reup.json" --data-binary @"$T/mesh.glb" -H 'Content-Type: model/gltf-binary' "$B/v1/meshes"
expect "mesh.glb uploads again" 201 - POST /v1/meshes "$T/reup.json"
check_eq "re-uploaded mesh.glb keeps 6475 vertices, 12946 faces" "$(jq -r '"\(.vertices) \(.faces)"' "$T/reup.json")" "6475 12946"
http "$T/curv.json" "$B/v1/meshes/$F/curvature"
expect "GET curvature (JSON)" 200 - GET "/v1/meshes/$F/curvature" "$T/curv.json"
check_eq "curvature: one value per vertex" "$(jq -c '[.vertices, (.curvature | length)]' "$T/curv.json")" "[6475,6475]"
http "$T/features.json" "$B/v1/meshes/$F/features"
expect "GET features" 200 - GET "/v1/meshes/$F/features" "$T/features.json"
check_eq "features: fandisk's 34 crease chains, as the CLI finds them" "$(jq '.crease_chains|length' "$T/features.json")" 34
http "$T/features5.json" "$B/v1/meshes/$F/features?max_crease_chains=5&corner_angle=180"
check_eq "features with query options: 5 chains" "$(jq '.crease_chains|length' "$T/features5.json")" 5
http "$T/features-bad.json" "$B/v1/meshes/$F/features?corner_angel=10"
expect "features with a misspelt option: 400 naming it" 400 invalid_request GET "/v1/meshes/$F/features" "$T/features-bad.json"
check "... naming it" grep -q 'unknown option \\"corner_angel\\"' "$T/features-bad.json"
http "$T/features-range.json" "$B/v1/meshes/$F/features?spacing=-1"
expect "features with an option out of range: 400" 400 invalid_request GET "/v1/meshes/$F/features" "$T/features-range.json"
http "$T/curv.bin" -H 'Accept: application/octet-stream' "$B/v1/meshes/$F/curvature"
check_eq "GET curvature (octet-stream): 200" "$STATUS" 200
check_eq "curvature octet-stream: Content-Type" "$(header "$T/curv.bin" Content-Type)" application/octet-stream
check_eq "curvature octet-stream: 4 bytes per vertex" "$(wc -c <"$T/curv.bin")" $((4 * 6475))
first=$(od -An -t f4 -N 4 --endian=little "$T/curv.bin" | tr -d ' ')
check "curvature octet-stream: first float matches the JSON" \
  awk -v a="$first" -v b="$(jq '.curvature[0]' "$T/curv.json")" 'BEGIN { d = a - b; if (d < 0) d = -d; s = (b < 0 ? -b : b); exit !(d <= 1e-6 * (s + 1)) }'

# ---- 5. every error status ----------------------------------------------------------------------
echo "# 5. errors"
post_json() {  # post_json OUT BODY [URL]
  printf '%s' "$2" >"$T/body.json"
  http "$1" -H 'Content-Type: application/json' --data-binary @"$T/body.json" "${3:-$B$FL}"
}
post_json "$T/e1.json" '{"keys": [10, 20'
expect "malformed JSON" 400 invalid_json POST "$FL" "$T/e1.json"
post_json "$T/e1b.json" ''
expect "empty JSON body" 400 invalid_json POST "$FL" "$T/e1b.json"
post_json "$T/e2.json" '{"keys": [10, 6475]}'
expect "key out of range" 400 invalid_request POST "$FL" "$T/e2.json"
check "key out of range: message names the vertex" grep -q 6475 "$T/e2.json"
post_json "$T/e3.json" '{"keys": [10, 20], "options": {"snake": {"alpah": 1}}}'
expect "unknown option field" 400 invalid_request POST "$FL" "$T/e3.json"
check "unknown option field: message names it" grep -q alpah "$T/e3.json"
post_json "$T/e3o.json" '{"keys": [10, 20], "options": {"rings": 3, "strip": {"rings": 3}}}'
expect "an option by its old and its new name" 400 invalid_request POST "$FL" "$T/e3o.json"
check_eq "... naming both" "$(jq -r .error.message "$T/e3o.json")" \
  '"options.rings" and "options.strip.rings" name the same option: give only "options.strip.rings"'
post_json "$T/e3b.json" '{"keys": [10, 20], "colour": "red"}'
expect "unknown top-level field" 400 invalid_request POST "$FL" "$T/e3b.json"
post_json "$T/e4.json" '{"keys": 10}'
expect "keys not an array" 400 invalid_request POST "$FL" "$T/e4.json"
post_json "$T/e4b.json" '{"keys": [10, -3]}'
expect "negative key" 400 invalid_request POST "$FL" "$T/e4b.json"
post_json "$T/e4c.json" '{"keys": [10, {"point": [0, "x", 0]}]}'
expect "point with a non-number" 400 invalid_request POST "$FL" "$T/e4c.json"
post_json "$T/e4d.json" "{\"lines\": [$(printf '{"keys": [10, 20]},%.0s' $(seq 1 64)) {\"keys\": [10, 20]}]}"
expect "batch of 65 lines" 400 invalid_request POST "$FL" "$T/e4d.json"
post_json "$T/e4e.json" '[10, 20]'
expect "body is an array" 400 invalid_request POST "$FL" "$T/e4e.json"

nobody=0123456789abcdef0123456789abcdef
http "$T/n1.json" "$B/v1/meshes/$nobody"
expect "GET unknown id" 404 not_found GET "/v1/meshes/$nobody" "$T/n1.json"
http "$T/n2.json" -X DELETE "$B/v1/meshes/$nobody"
expect "DELETE unknown id" 404 not_found DELETE "/v1/meshes/$nobody" "$T/n2.json"
post_json "$T/n3.json" '{"keys": [1, 2]}' "$B/v1/meshes/$nobody/feature-lines"
expect "feature-lines on unknown id" 404 not_found POST "/v1/meshes/$nobody/feature-lines" "$T/n3.json"
http "$T/n4.json" "$B/v1/meshes/$nobody/mesh.glb"
expect "mesh.glb of unknown id" 404 not_found GET "/v1/meshes/$nobody/mesh.glb" "$T/n4.json"
http "$T/n5.json" "$B/v1/meshes/$nobody/curvature"
expect "curvature of unknown id" 404 not_found GET "/v1/meshes/$nobody/curvature" "$T/n5.json"
http "$T/n6.json" "$B/v1/meshes/not-an-id"
expect "GET malformed id" 404 not_found GET "/v1/meshes/{mesh_id}" "$T/n6.json"
for route in /v1/nothing /v2/meshes /v1/meshes/$F/nothing; do
  http "$T/n7.json" "$B$route"
  check_eq "unknown route $route: 404" "$STATUS" 404
  check_eq "unknown route $route: error code not_found" "$(error_code "$T/n7.json")" not_found
  validate_schema "unknown route $route: body is an Error" Error "$T/n7.json"
done

http "$T/c1.json" -H 'Transfer-Encoding: chunked' -H 'Content-Type: model/obj' --data-binary @"$MESHES/cube.obj" "$B/v1/meshes"
expect "chunked upload" 411 length_required POST /v1/meshes "$T/c1.json"
http "$T/c2.json" -X POST -H 'Content-Type: model/obj' "$B/v1/meshes"
expect "upload without Content-Length" 411 length_required POST /v1/meshes "$T/c2.json"
http "$T/c3.json" -X POST -H 'Content-Type: model/obj' -H 'Content-Length: 0' "$B/v1/meshes"
expect "empty upload" 400 malformed_mesh POST /v1/meshes "$T/c3.json"

http "$T/u1.json" --data-binary @"$MESHES/cube.obj" -H 'Content-Type: application/octet-stream' "$B/v1/meshes?format=xyz"
expect "upload ?format=xyz" 415 unsupported_format POST /v1/meshes "$T/u1.json"
http "$T/u2.json" --data-binary @"$MESHES/cube.obj" -H 'Content-Type: text/csv' "$B/v1/meshes"
expect "upload as text/csv" 415 unsupported_format POST /v1/meshes "$T/u2.json"
gzip -c -n <"$MESHES/cube.obj" >"$T/cube.obj.gz"
http "$T/u3.json" --data-binary @"$T/cube.obj.gz" -H 'Content-Type: model/obj' -H 'Content-Encoding: gzip' "$B/v1/meshes"
expect "upload with Content-Encoding gzip" 415 unsupported_format POST /v1/meshes "$T/u3.json"
http "$T/u4.json" --data-binary @"$MESHES/cube.obj" "$B/v1/meshes"
expect "upload as a form (curl's default Content-Type)" 415 unsupported_format POST /v1/meshes "$T/u4.json"
http "$T/u5.json" -H 'Content-Type: text/plain' --data-binary @"$T/r1.json" "$B$FL"
expect "feature-lines as text/plain" 415 unsupported_format POST "$FL" "$T/u5.json"
http "$T/u6.json" --data-binary 'not a mesh at all, just words' -H 'Content-Type: application/octet-stream' "$B/v1/meshes"
expect "octet-stream that sniffs as nothing" 415 unsupported_format POST /v1/meshes "$T/u6.json"

# 4 MiB limit of feature-line requests.
{ printf '{"keys": [10, 20], "closed": false%*s}' $((5 << 20)) ''; } >"$T/huge.json"
http "$T/p1.json" -H 'Content-Type: application/json' --data-binary @"$T/huge.json" "$B$FL"
expect "feature-lines request of 5 MiB" 413 payload_too_large POST "$FL" "$T/p1.json"

TET=${ID[multiple_tetrahedrons.obj]:-missing}
post_json "$T/g422.json" '{"keys": [0, 4]}' "$B/v1/meshes/$TET/feature-lines"
expect "keys on two different tetrahedra" 422 unprocessable_geometry POST "/v1/meshes/$TET/feature-lines" "$T/g422.json"
http "$T/g422b.json" --data-binary @"$MESHES/degenerate_mesh.obj" -H 'Content-Type: model/obj' "$B/v1/meshes"
expect "upload of a single zero-area triangle" 422 unprocessable_geometry POST /v1/meshes "$T/g422b.json"

# 413 for an upload over --max-upload-mb.
start_server small --max-upload-mb 1
S=${SRV_BASE[small]:-http://127.0.0.1:1}
head -c $((2 << 20)) "$MESHES/igea.ply" >"$T/2mb.ply"
http "$T/big.json" --data-binary @"$T/2mb.ply" -H 'Content-Type: application/x-ply' "$S/v1/meshes"
expect "upload of 2 MiB with --max-upload-mb 1" 413 payload_too_large POST /v1/meshes "$T/big.json"
healthz small "healthz after the refused upload"

# 503 with Retry-After: one engine thread, a queue of one, 40 concurrent long lines on igea.
start_server busy --threads 1 --queue 1 --quiet
Z=${SRV_BASE[busy]:-http://127.0.0.1:1}
http "$T/busy-up.json" --data-binary @"$MESHES/igea.ply" -H 'Content-Type: application/x-ply' "$Z/v1/meshes"
expect "upload igea to the busy server" 201 - POST /v1/meshes "$T/busy-up.json"
ZI=$(jq -r .mesh_id "$T/busy-up.json")
echo '{"keys": [0, 134000, 67000]}' >"$T/long.json"
pids=()
for i in $(seq 1 40); do
  curl -s --max-time "$CURL_MAX" -o "$T/busy.$i.json" -D "$T/busy.$i.json.hdr" -w '%{http_code}' \
    -H 'Content-Type: application/json' --data-binary @"$T/long.json" "$Z/v1/meshes/$ZI/feature-lines" >"$T/busy.$i.status" 2>/dev/null &
  pids+=($!); BG_PIDS+=($!)
done
wait "${pids[@]}"
n200=0; n503=0; other=""
for i in $(seq 1 40); do
  st=$(cat "$T/busy.$i.status")
  case $st in
    200) n200=$((n200 + 1)) ;;
    503) n503=$((n503 + 1))
         retry=$(header "$T/busy.$i.json" Retry-After)
         [[ $retry =~ ^[0-9]+$ ]] || other+=" #$i:503-without-Retry-After"
         [ "$(error_code "$T/busy.$i.json")" = overloaded ] || other+=" #$i:503-code-$(error_code "$T/busy.$i.json")" ;;
    *) other+=" #$i:$st" ;;
  esac
  [ "$st" != 000 ] && validate_json "concurrent request #$i ($st): body matches the contract" POST "/v1/meshes/$ZI/feature-lines" "$st" "$T/busy.$i.json"
done
echo "#    40 concurrent requests: $n200 answered 200, $n503 answered 503"
check "overload: at least one 503 overloaded" [ "$n503" -ge 1 ]
check "overload: at least one request served" [ "$n200" -ge 1 ]
check_eq "overload: every 503 has Retry-After and code overloaded, nothing else than 200/503" "$other" ""
healthz busy "healthz after the overload"
http "$T/busy-metrics.txt" "$Z/metrics"
check "metrics count the queue_full rejections" \
  grep -qE '^featureline_rejected_requests_total\{reason="queue_full"\} [1-9]' "$T/busy-metrics.txt"

# Deadlines cancel engine work (engine/cancellation.h): one engine thread, a 1 s deadline, a
# batch of 64 lines at the option caps (api/options_table.cpp), each a serpentine through 26 keys
# of about 640 edges (about 2.5 s per line in Release on a loaded 2-core machine, so minutes in
# all). It is refused at the deadline, and the engine thread is free again at once: the next line
# is answered 200 (without cancellation it queued behind the batch and missed its deadline).
start_server deadline --threads 1 --deadline-s "$FACTOR" --quiet
D=${SRV_BASE[deadline]:-http://127.0.0.1:1}
http "$T/dl-up.json" -H 'Content-Type: application/octet-stream' --data-binary @samples/ridge_field.off "$D/v1/meshes?format=off"
expect "upload the sample to the deadline server" 201 - POST /v1/meshes "$T/dl-up.json"
DI=$(jq -r .mesh_id "$T/dl-up.json")
jq -n '[range(1; 40; 3)] | to_entries | map((.value * 41) as $row | if .key % 2 == 0 then [$row + 1, $row + 39] else [$row + 39, $row + 1] end) | add
  | {lines: [range(64) as $i | {keys: ., options: {strip: {rings: 8, max_edge_distortion: 100}, min_piece_edges: 2,
     snake: {max_iterations: 500, tolerance: 0, spacing: 0.25, kappa: 1, exponent: 4, max_step: 1, resample_every: 1}}}]}' >"$T/dl-slow.json"
http "$T/dl-slow.out" -H 'Content-Type: application/json' --data-binary @"$T/dl-slow.json" "$D/v1/meshes/$DI/feature-lines"
expect "64 lines at the option caps against a deadline of $FACTOR s" 503 deadline_exceeded POST "/v1/meshes/$DI/feature-lines" "$T/dl-slow.out"
echo '{"keys": [701, 963, 1184]}' >"$T/dl-fast.json"
http "$T/dl-fast.out" -H 'Content-Type: application/json' --data-binary @"$T/dl-fast.json" "$D/v1/meshes/$DI/feature-lines"
expect "the next line right after it (the engine thread was freed)" 200 - POST "/v1/meshes/$DI/feature-lines" "$T/dl-fast.out"

# ---- 6. hostile input ---------------------------------------------------------------------------
echo "# 6. hostile input"
gltf_with_uri() {
  jq -n --arg uri "$1" '{asset: {version: "2.0"}, buffers: [{uri: $uri, byteLength: 36}],
    bufferViews: [{buffer: 0, byteOffset: 0, byteLength: 36}],
    accessors: [{bufferView: 0, componentType: 5126, count: 3, type: "VEC3", min: [0, 0, 0], max: [1, 1, 0]}],
    meshes: [{primitives: [{attributes: {POSITION: 0}}]}], nodes: [{mesh: 0}], scenes: [{nodes: [0]}], scene: 0}'
}
for uri in /etc/passwd file:///etc/passwd ../../../../etc/passwd; do
  gltf_with_uri "$uri" >"$T/evil.gltf"
  http "$T/evil.json" --data-binary @"$T/evil.gltf" -H 'Content-Type: model/gltf+json' "$B/v1/meshes"
  expect "glTF with buffer uri $uri" 400 malformed_mesh POST /v1/meshes "$T/evil.json"
  check "glTF with buffer uri $uri: no file content in the answer" bash -c "! grep -q 'root:' '$T/evil.json'"
done
printf 'mtllib /etc/passwd\nusemtl root\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$T/mtl.obj"
http "$T/mtl.json" --data-binary @"$T/mtl.obj" -H 'Content-Type: model/obj' "$B/v1/meshes"
check "OBJ with mtllib /etc/passwd: 201 or a 4xx" [ "$STATUS" = 201 -o "${STATUS:0:1}" = 4 ]
check "OBJ with mtllib /etc/passwd: no file content in the answer" bash -c "! grep -q 'root:' '$T/mtl.json'"
validate_json "OBJ with mtllib: body matches the contract" POST /v1/meshes "$STATUS" "$T/mtl.json"

# Random-looking bytes (deterministic: compressed fandisk) under every format.
gzip -c -n -9 <"$MESHES/fandisk.off" | head -c 65536 >"$T/noise.bin"
for fmt in obj off ply stl glb gltf drc; do
  http "$T/noise.json" --data-binary @"$T/noise.bin" -H 'Content-Type: application/octet-stream' "$B/v1/meshes?format=$fmt"
  check "random bytes as $fmt: 4xx ($STATUS $(error_code "$T/noise.json"))" [ "${STATUS:0:1}" = 4 ]
  validate_json "random bytes as $fmt: body matches the contract" POST /v1/meshes "$STATUS" "$T/noise.json"
done
healthz main "healthz after the random uploads"

for cut in 100000 2000000; do
  head -c $cut "$MESHES/igea.ply" >"$T/cut.ply"
  http "$T/cut.json" --data-binary @"$T/cut.ply" -H 'Content-Type: application/x-ply' "$B/v1/meshes"
  expect "binary PLY cut at $cut bytes" 400 malformed_mesh POST /v1/meshes "$T/cut.json"
done
for cut in 84 300000; do
  head -c $cut "$T/fandisk.stl" >"$T/cut.stl"
  http "$T/cut.json" --data-binary @"$T/cut.stl" -H 'Content-Type: model/stl' "$B/v1/meshes"
  expect "binary STL cut at $cut bytes" 400 malformed_mesh POST /v1/meshes "$T/cut.json"
done
{ head -c 80 "$T/fandisk.stl"; printf '\xf0\xff\xff\xff'; } >"$T/liar.stl"
t0=$(now_s)
http "$T/liar.json" --data-binary @"$T/liar.stl" -H 'Content-Type: model/stl' "$B/v1/meshes"
took=$(elapsed_since "$t0")
expect "binary STL claiming 0xFFFFFFF0 triangles in 84 bytes" 400 malformed_mesh POST /v1/meshes "$T/liar.json"
check "lying STL refused in under 2 s (took $took s)" less_than "$took" 2
printf 'OFF\n2000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >"$T/liar.off"
t0=$(now_s)
http "$T/liar.json" --data-binary @"$T/liar.off" -H 'Content-Type: model/x-off' "$B/v1/meshes"
took=$(elapsed_since "$t0")
expect "OFF header claiming 2000000000 vertices" 400 malformed_mesh POST /v1/meshes "$T/liar.json"
check "lying OFF refused in under 2 s (took $took s)" less_than "$took" 2
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n' >"$T/liar.ply"
t0=$(now_s)
http "$T/liar.json" --data-binary @"$T/liar.ply" -H 'Content-Type: application/x-ply' "$B/v1/meshes"
took=$(elapsed_since "$t0")
expect "PLY header claiming 4000000000 vertices" 400 malformed_mesh POST /v1/meshes "$T/liar.json"
check "lying PLY refused in under 2 s (took $took s)" less_than "$took" 2
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n' >"$T/badidx.obj"
http "$T/badidx.json" --data-binary @"$T/badidx.obj" -H 'Content-Type: model/obj' "$B/v1/meshes"
check "OBJ face index out of range: 4xx ($STATUS $(error_code "$T/badidx.json"))" [ "${STATUS:0:1}" = 4 ]
validate_json "OBJ face index out of range: body matches the contract" POST /v1/meshes "$STATUS" "$T/badidx.json"
healthz main "healthz after the hostile uploads"

# ---- 7. no request smuggling after an early refusal --------------------------------------------
echo "# 7. request smuggling"
# raw_exchange OUT PAUSE HEAD BODY: raw_send (lib.sh) to the small server.
raw_exchange() { raw_send "${S##*:}" "$@"; }
smuggled=$'GET /healthz HTTP/1.1\r\nHost: smuggled\r\n\r\n'
head_big=$'POST /v1/meshes HTTP/1.1\r\nHost: test\r\nContent-Type: model/obj\r\nContent-Length: 2097152\r\n\r\n'
for pause in 0 0.5; do
  what="oversized upload with a request in its body (body sent after ${pause} s)"
  raw_exchange "$T/smuggle.txt" "$pause" "$head_big" "$smuggled"
  check_eq "$what: exactly one response" "$(responses "$T/smuggle.txt")" 1
  check_eq "$what: it is the 413" "$(head -n 1 "$T/smuggle.txt" | cut -d' ' -f2)" 413
  check "$what: the connection is closed at once (closed after $CLOSE_S s)" less_than "$CLOSE_S" 2
  first_body "$T/smuggle.txt" >"$T/smuggle.body.json"
  validate_json "$what: body matches the contract" POST /v1/meshes 413 "$T/smuggle.body.json"
done
head_chunked=$'POST /v1/meshes HTTP/1.1\r\nHost: test\r\nContent-Type: model/obj\r\nTransfer-Encoding: chunked\r\n\r\n'
raw_exchange "$T/smuggle2.txt" 0.5 "$head_chunked" "$(printf '%x' ${#smuggled})"$'\r\n'"$smuggled"$'\r\n0\r\n\r\n'
check_eq "chunked upload with a request in its body: exactly one response" "$(responses "$T/smuggle2.txt")" 1
check_eq "chunked upload with a request in its body: it is the 411" "$(head -n 1 "$T/smuggle2.txt" | cut -d' ' -f2)" 411
healthz small "healthz after the smuggling attempts"
# A request line the library cannot parse: its "method" must not reach /metrics as a label.
( trap '' PIPE; exec 3<>"/dev/tcp/127.0.0.1/${S##*:}" &&
  printf 'EVIL"}\x07 /x HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n' >&3 && timeout $((5 * FACTOR)) cat <&3 ) >"$T/evil.txt" 2>/dev/null
check_eq "an unparseable request line answers 400" "$(head -n 1 "$T/evil.txt" | cut -d' ' -f2)" 400
first_body "$T/evil.txt" >"$T/evil.json"
validate_schema "unparseable request line: body is an Error" Error "$T/evil.json"
http "$T/small-metrics.txt" "$S/metrics"
metrics_clean() {  # only printable ASCII, and only known methods as labels
  ! LC_ALL=C grep -qaP '[^\x20-\x7e]' "$1" && ! LC_ALL=C grep -qaP 'method="(?!(GET|POST|DELETE|OPTIONS|HEAD|PUT|PATCH|other)")' "$1"
}
check "metrics stay valid exposition text (printable ASCII, known methods)" metrics_clean "$T/small-metrics.txt"

# ---- 8. parallel clients ------------------------------------------------------------------------
echo "# 8. 16 parallel clients"
pids=()
for i in $(seq 1 16); do
  curl -s --max-time "$CURL_MAX" -o "$T/par.$i.json" -w '%{http_code}' -H 'Content-Type: application/json' \
    --data-binary @"$T/r1.json" "$B$FL" >"$T/par.$i.status" 2>/dev/null &
  pids+=($!); BG_PIDS+=($!)
done
wait "${pids[@]}"
bad=""; differ=""
jq -S 'del(.stats.timings_ms)' "$T/l1.json" >"$T/par.ref"
for i in $(seq 1 16); do
  st=$(cat "$T/par.$i.status")
  [ "$st" = 200 ] || bad+=" #$i:$st"
  jq -S 'del(.stats.timings_ms)' "$T/par.$i.json" 2>/dev/null | cmp -s - "$T/par.ref" || differ+=" #$i"
  [ "$st" != 000 ] && validate_json "parallel request #$i: body matches the contract" POST "$FL" "$st" "$T/par.$i.json"
done
check_eq "16 parallel requests all answer 200" "$bad" ""
check_eq "16 parallel answers identical to the sequential one (apart from timings)" "$differ" ""
check_eq "16 parallel answers: same refined points" \
  "$(for i in $(seq 1 16); do jq -c .refined.points "$T/par.$i.json" | md5sum; done | sort -u | wc -l)" 1

# ---- 9. delete while a request runs -------------------------------------------------------------
echo "# 9. delete during use"
IG=${ID[igea.ply]:-missing}
jq -n '{lines: [range(0; 64) | {keys: [(. * 1000), (134000 - . * 997), (67000 + . * 500)]}]}' >"$T/slow.json"
validate_request "slow batch request matches the contract" POST "/v1/meshes/$IG/feature-lines" "$T/slow.json"
curl -s --max-time "$CURL_MAX" -o "$T/slow.out.json" -w '%{http_code}' -H 'Content-Type: application/json' \
  --data-binary @"$T/slow.json" "$B/v1/meshes/$IG/feature-lines" >"$T/slow.status" 2>/dev/null &
slow=$!; BG_PIDS+=($!)
running=0
for i in $(seq 1 $((100 * FACTOR))); do
  curl -s --max-time 5 "$B/metrics" | grep -qE '^featureline_pool_running [1-9]' && { running=1; break; }
  sleep 0.05
done
check "slow request is running on the engine" [ $running = 1 ]
http "$T/del3.out" -X DELETE "$B/v1/meshes/$IG"
check_eq "DELETE while the request runs: 204" "$STATUS" 204
check "the slow request was still running when DELETE answered" kill -0 "$slow"
wait "$slow"
check_eq "the slow request still answers 200" "$(cat "$T/slow.status")" 200
check_eq "the slow request answers all 64 lines" "$(jq '.lines | length' "$T/slow.out.json" 2>/dev/null)" 64
validate_json "slow request: body matches the contract" POST "/v1/meshes/$IG/feature-lines" "$(cat "$T/slow.status")" "$T/slow.out.json"
http "$T/gone.json" "$B/v1/meshes/$IG"
expect "GET after delete during use" 404 not_found GET "/v1/meshes/$IG" "$T/gone.json"
post_json "$T/gone2.json" '{"keys": [0, 1000]}' "$B/v1/meshes/$IG/feature-lines"
expect "feature-lines after delete during use" 404 not_found POST "/v1/meshes/$IG/feature-lines" "$T/gone2.json"

# ---- 10. CORS -----------------------------------------------------------------------------------
echo "# 10. CORS"
start_server cors --cors-origin http://app.example --quiet
C=${SRV_BASE[cors]:-http://127.0.0.1:1}
http "$T/pre.out" -X OPTIONS -H 'Origin: http://app.example' -H 'Access-Control-Request-Method: POST' \
  -H 'Access-Control-Request-Headers: content-type' "$C/v1/meshes"
check_eq "preflight from the allowed origin: 204" "$STATUS" 204
check_eq "preflight: Access-Control-Allow-Origin" "$(header "$T/pre.out" Access-Control-Allow-Origin)" http://app.example
check "preflight: Access-Control-Allow-Methods has POST and DELETE" \
  bash -c "grep -i '^Access-Control-Allow-Methods:' '$T/pre.out.hdr' | grep -q POST && grep -i '^Access-Control-Allow-Methods:' '$T/pre.out.hdr' | grep -q DELETE"
check "preflight: Access-Control-Allow-Headers has Content-Type" \
  bash -c "grep -i '^Access-Control-Allow-Headers:' '$T/pre.out.hdr' | grep -qi content-type"
http "$T/pre2.out" -X OPTIONS -H 'Origin: http://app.example' -H 'Access-Control-Request-Method: POST' "$C/v1/meshes/$nobody/feature-lines"
check_eq "preflight on feature-lines: 204 with Allow-Origin" "$STATUS $(header "$T/pre2.out" Access-Control-Allow-Origin)" "204 http://app.example"
http "$T/cg.json" -H 'Origin: http://app.example' "$C/healthz"
check_eq "GET from the allowed origin carries Access-Control-Allow-Origin" "$(header "$T/cg.json" Access-Control-Allow-Origin)" http://app.example
validate_json "CORS GET /healthz: body matches the contract" GET /healthz 200 "$T/cg.json"
http "$T/ce.json" -H 'Origin: http://app.example' "$C/v1/meshes/$nobody"
check_eq "an error for the allowed origin carries Access-Control-Allow-Origin" "$STATUS $(header "$T/ce.json" Access-Control-Allow-Origin)" "404 http://app.example"
validate_json "CORS 404: body matches the contract" GET "/v1/meshes/$nobody" "$STATUS" "$T/ce.json"
http "$T/co.json" -H 'Origin: http://evil.example' "$C/healthz"
check_eq "GET from another origin: no Access-Control-Allow-Origin" "$(header "$T/co.json" Access-Control-Allow-Origin)" ""
http "$T/pre3.out" -X OPTIONS -H 'Origin: http://evil.example' -H 'Access-Control-Request-Method: POST' "$C/v1/meshes"
check_eq "preflight from another origin: 204 without CORS headers" \
  "$STATUS $(grep -ic '^Access-Control-' "$T/pre3.out.hdr")" "204 0"
http "$T/cm.json" -H 'Origin: http://app.example' "$B/healthz"
check_eq "a server without --cors-origin sends no CORS header" "$(grep -ic '^Access-Control-' "$T/cm.json.hdr")" 0

# ---- 11. /metrics -------------------------------------------------------------------------------
echo "# 11. metrics"
http "$T/metrics.txt" "$B/metrics"
check_eq "/metrics: 200" "$STATUS" 200
check "/metrics: text/plain" bash -c "grep -i '^Content-Type:' '$T/metrics.txt.hdr' | grep -q 'text/plain'"
for pattern in \
  'featureline_http_requests_total\{route="/v1/meshes",method="POST",status="201"\} [1-9]' \
  'featureline_http_requests_total\{route="/v1/meshes/\{id\}/feature-lines",method="POST",status="200"\} [1-9]' \
  'featureline_http_requests_total\{route="/v1/meshes/\{id\}",method="DELETE",status="204"\} [1-9]' \
  'featureline_http_requests_total\{route="/healthz",method="GET",status="200"\} [1-9]' \
  'featureline_http_request_duration_seconds_bucket\{route="/v1/meshes",method="POST",le="\+Inf"\} [1-9]' \
  'featureline_cache_entries [0-9]' \
  'featureline_pool_queue_depth [0-9]' \
  'featureline_rejected_requests_total\{reason="[a-z_]+"\} [1-9]'; do
  check "/metrics has $(printf %s "$pattern" | sed 's/\\//g' | cut -c1-90)" grep -qE "^$pattern" "$T/metrics.txt"
done
check "/metrics (busy server) has featureline_rejected_requests_total after the 503s" \
  grep -qE '^featureline_rejected_requests_total\{reason="queue_full"\} [1-9]' "$T/busy-metrics.txt"

# ---- 12. expiry and eviction --------------------------------------------------------------------
echo "# 12. expiry, eviction"
start_server ttl --ttl-s 2 --quiet --preload "$MESHES/cube.obj"
X=${SRV_BASE[ttl]:-http://127.0.0.1:1}
pre_id=$(sed -n 's/^preloaded .* as mesh \([0-9a-f]\{32\}\)$/\1/p' "$T/ttl.out")
check "--preload prints the mesh id" [ -n "$pre_id" ]
http "$T/t1.json" --data-binary @"$MESHES/cube.obj" -H 'Content-Type: model/obj' "$X/v1/meshes"
expect "upload to the --ttl-s 2 server" 201 - POST /v1/meshes "$T/t1.json"
check "expires_in_s is at most 2" awk -v e="$(jq .expires_in_s "$T/t1.json")" 'BEGIN { exit !(e <= 2 && e > 0) }'
tid=$(jq -r .mesh_id "$T/t1.json")
sleep 3
http "$T/t2.json" "$X/v1/meshes/$tid"
expect "GET after 3 s idle" 404 not_found GET "/v1/meshes/$tid" "$T/t2.json"
check "expiry message says it expired" grep -q expired "$T/t2.json"
http "$T/t3.json" "$X/v1/meshes/$pre_id"
expect "a preloaded mesh never expires" 200 - GET "/v1/meshes/$pre_id" "$T/t3.json"
check_eq "a preloaded mesh's expires_in_s is null" "$(jq .expires_in_s "$T/t3.json")" null

mem=$(jq .memory_bytes "${DESC[bunny_closed.off]:-/dev/null}" 2>/dev/null)
[[ $mem =~ ^[0-9]+$ ]] || mem=11287088
budget=$(( (mem * 3 / 2 + (1 << 20) - 1) >> 20 ))   # room for one bunny, not two
start_server evict --cache-mb "$budget" --quiet
E=${SRV_BASE[evict]:-http://127.0.0.1:1}
http "$T/v1.json" --data-binary @"$MESHES/bunny_closed.off" -H 'Content-Type: model/x-off' "$E/v1/meshes"
expect "first bunny into a $budget MiB cache" 201 - POST /v1/meshes "$T/v1.json"
http "$T/v2.json" --data-binary @"$MESHES/bunny_closed.off" -H 'Content-Type: model/x-off' "$E/v1/meshes"
expect "second bunny into a $budget MiB cache" 201 - POST /v1/meshes "$T/v2.json"
check "two bunnies (memory_bytes $(jq .memory_bytes "$T/v1.json") + $(jq .memory_bytes "$T/v2.json")) exceed $budget MiB, one fits" \
  awk -v a="$(jq .memory_bytes "$T/v1.json")" -v b="$(jq .memory_bytes "$T/v2.json")" -v m="$budget" \
  'BEGIN { exit !(a + b > m * 1048576 && b <= m * 1048576) }'
http "$T/v3.json" "$E/v1/meshes/$(jq -r .mesh_id "$T/v1.json")"
expect "GET the first bunny" 404 not_found GET "/v1/meshes/$(jq -r .mesh_id "$T/v1.json")" "$T/v3.json"
check "eviction message says it was evicted" grep -q evicted "$T/v3.json"
http "$T/v4.json" "$E/v1/meshes/$(jq -r .mesh_id "$T/v2.json")"
expect "GET the second bunny" 200 - GET "/v1/meshes/$(jq -r .mesh_id "$T/v2.json")" "$T/v4.json"
http "$T/v5.json" --data-binary @"$MESHES/igea.ply" -H 'Content-Type: application/x-ply' "$E/v1/meshes"
expect "a mesh larger than the whole cache" 413 payload_too_large POST /v1/meshes "$T/v5.json"

# ---- 13. SIGTERM --------------------------------------------------------------------------------
echo "# 13. SIGTERM"
for name in main small busy cors ttl evict; do
  [ -n "${SRV_PID[$name]:-}" ] || continue
  stop_server "$name" TERM
  check_eq "server '$name' exits with status 0 on SIGTERM" "$STOP_RC" 0
  check "server '$name' stops within 5 s (took $STOP_SECONDS s)" less_than "$STOP_SECONDS" $((5 * FACTOR))
  check "server '$name' prints \"stopped\"" grep -q stopped "${SRV_LOG[$name]}"
done
sanitizer=$(grep -l -E 'ERROR: (Address|Leak|Thread)Sanitizer|runtime error:' "$T"/*.log 2>/dev/null)
if [ -z "$sanitizer" ]; then pass "no sanitizer reports in the servers' logs"
else fail "no sanitizer reports in the servers' logs" "$(grep -h -A8 -E 'ERROR: (Address|Leak|Thread)Sanitizer|runtime error:' $sanitizer | head -n 40)"; fi
echo "# requests done in $(elapsed_since "$started_at") s"

# ---- validators ---------------------------------------------------------------------------------
run_validations
echo "# total $(elapsed_since "$started_at") s"
finish
