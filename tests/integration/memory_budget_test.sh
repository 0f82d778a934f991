#!/usr/bin/env bash
# Memory per request, as an attacker would spend it: bodies built by this script against the
# real server with a small cache (--cache-mb 64). Each case checks the answers' status and error
# code, that the server's peak resident memory (VmHWM) stays within 3 x the cache budget + 64 MB,
# and that a normal client still gets its lines.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
FACTOR=$(time_factor "$SERVER")
CURL_MAX=$((60 * FACTOR))
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-memory.XXXXXX")
trap cleanup EXIT
CACHE_MB=64
PEAK_LIMIT_KB=$(((3 * CACHE_MB + 64) * 1024))
LIMIT_TEXT="3 x --cache-mb + 64 MB"
if [ "$FACTOR" -gt 1 ]; then
  # A sanitizer build: AddressSanitizer keeps freed blocks in a quarantine (256 MB by default)
  # and adds shadow memory, so its resident memory measures ASan, not the server. Keep the
  # quarantine small and allow twice the budget; the Release build is held to the budget itself.
  export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=16"
  PEAK_LIMIT_KB=$((2 * PEAK_LIMIT_KB))
  LIMIT_TEXT="2 x (3 x --cache-mb + 64 MB) under a sanitizer"
fi
peak_kb() { sed -n 's/^VmHWM:[[:space:]]*\([0-9]*\) kB$/\1/p' "/proc/$1/status"; }

start_server main --cache-mb $CACHE_MB --quiet --preload samples/ridge_field.off || { finish; exit 1; }
B=${SRV_BASE[main]}
PID=${SRV_PID[main]}
id=$(sed -n 's/^preloaded .* as mesh \([0-9a-f]*\)$/\1/p' "$TMP/main.out")
LINE='{"keys": [701, 963, 1184]}'

# normal_lines N OUT: N line requests one after another, each retried (up to 20 times, 0.25 s
# apart) while the server sheds load with 503; OUT gets each final status.
normal_lines() {
  local n=$1 out=$2 i try code
  : >"$out"
  for i in $(seq 1 "$n"); do
    for try in $(seq 1 20); do
      code=$(curl -s -o /dev/null -w '%{http_code}' --max-time "$CURL_MAX" -X POST -H 'Content-Type: application/json' -d "$LINE" "$B/v1/meshes/$id/feature-lines")
      [ "$code" = 503 ] || break
      sleep 0.25
    done
    echo "$code" >>"$out"
  done
}

# burst NAME FILE COUNT: COUNT concurrent feature-line requests with FILE as body, while a normal
# client asks for lines; every hostile answer must be 413 or 503 (never 200 or 5xx other than 503).
burst() {
  local name=$1 file=$2 count=$3 i
  normal_lines 10 "$TMP/$name.normal" &
  local normal=$!
  BG_PIDS+=("$normal")
  for i in $(seq 1 "$count"); do
    curl -s -o "$TMP/$name.$i.json" -w '%{http_code}\n' --max-time "$CURL_MAX" -X POST -H 'Content-Type: application/json' \
      --data-binary @"$file" "$B/v1/meshes/$id/feature-lines" >"$TMP/$name.$i.code" &
    BG_PIDS+=("$!")
  done
  for i in $(seq 1 "$count"); do wait "${BG_PIDS[-$i]}" 2>/dev/null; done
  wait "$normal" 2>/dev/null
  local bad
  bad=$(cat "$TMP/$name".*.code | grep -vcE '^(413|503)$')
  check_eq "$name: every one of $count answers is 413 or 503" "$bad" 0
  check_eq "$name: the 413s say payload_too_large" \
    "$(for i in $(seq 1 "$count"); do [ "$(cat "$TMP/$name.$i.code")" = 413 ] && jq -r .error.code "$TMP/$name.$i.json"; done | sort -u | grep -v payload_too_large)" ""
  check_eq "$name: a normal client meanwhile gets every line (200)" "$(sort -u "$TMP/$name.normal")" 200
  local peak; peak=$(peak_kb "$PID")
  echo "#    $name: peak resident memory $((peak / 1024)) MB (limit $((PEAK_LIMIT_KB / 1024)) MB)"
  check "$name: peak resident memory within $LIMIT_TEXT" [ "$peak" -lt "$PEAK_LIMIT_KB" ]
}

# 4 MiB of tiny containers: about 100 bytes of DOM per 3 bytes of text.
python3 -c "
import sys
n = (4 * 1024 * 1024 - 20) // 3
sys.stdout.write('{\"lines\": [' + ','.join(['{}'] * n) + ']}')" >"$TMP/containers.json"
burst "64 bodies of 4 MiB of {}" "$TMP/containers.json" 64
http "$TMP/one.json" -X POST -H 'Content-Type: application/json' --data-binary @"$TMP/containers.json" "$B/v1/meshes/$id/feature-lines"
check_eq "one such body alone: 413" "$STATUS" 413
check "... naming what is too large" grep -q 'JSON values (.* objects and arrays) in 4194' "$TMP/one.json"

# Deep nesting: refused by depth before any DOM is built.
python3 -c "import sys; sys.stdout.write('{\"keys\": ' + '[' * 100000 + ']' * 100000 + '}')" >"$TMP/deep.json"
http "$TMP/deep.out" -X POST -H 'Content-Type: application/json' --data-binary @"$TMP/deep.json" "$B/v1/meshes/$id/feature-lines"
check_eq "100,000 levels of nesting: 413" "$STATUS" 413
check "... saying how deep" grep -q 'nests 100001 levels deep; at most 64' "$TMP/deep.out"

# Files that expand: each answered within a bound, named by what is too large, within the
# same peak. The budget is 64 MiB: at most 493,447 triangles (136 B each prepared).
MESHES="$ROOT/tests/support/hostile_meshes.py"
UPLOAD_MAX=$((20 * FACTOR))
upload() {  # upload NAME FILE: STATUS, the answer in $TMP/NAME.json and the seconds it took
  local start; start=$(now_s)
  http "$TMP/$1.json" --max-time "$UPLOAD_MAX" -X POST -H 'Content-Type: application/octet-stream' --data-binary @"$2" "$B/v1/meshes"
  SECONDS_TAKEN=$(elapsed_since "$start")
  echo "#    $1: $STATUS in $SECONDS_TAKEN s ($(stat -c %s "$2") bytes)"
}
python3 "$MESHES" repeated-ply 400000 "$TMP/repeated.ply"
upload "one triangle 400,000 times (PLY)" "$TMP/repeated.ply"
check_eq "... 201: the repeats are dropped, not given vertex copies" "$STATUS" 201
check_eq "... one face kept, 399,999 repeats reported" "$(jq -c '[.faces, .repeated_faces, .vertices]' "$TMP/one triangle 400,000 times (PLY).json")" "[1,399999,3]"
python3 "$MESHES" repeated-ply 2000000 "$TMP/repeated2m.ply"
upload "one triangle 2,000,000 times (PLY)" "$TMP/repeated2m.ply"
check_eq "... 413" "$STATUS" 413
check "... naming the triangle limit" grep -q 'more than 493447 triangles' "$TMP/one triangle 2,000,000 times (PLY).json"
python3 "$MESHES" repeated-glb 40 "$TMP/repeated40.glb"
upload "40 primitives sharing one accessor of 10,000 repeats (GLB)" "$TMP/repeated40.glb"
check_eq "... 201, one face kept" "$STATUS/$(jq -c '[.faces, .repeated_faces]' "$TMP/40 primitives sharing one accessor of 10,000 repeats (GLB).json")" "201/[1,399999]"
python3 "$MESHES" repeated-glb 800 "$TMP/repeated800.glb"
upload "800 primitives sharing one accessor (GLB, 8 M triangles declared)" "$TMP/repeated800.glb"
check_eq "... 413 before expanding" "$STATUS/$(error_code "$TMP/800 primitives sharing one accessor (GLB, 8 M triangles declared).json")" "413/payload_too_large"
check "... within a second or so" less_than "$SECONDS_TAKEN" "$((2 * FACTOR))"
python3 "$MESHES" draco 33554432 100 "$TMP/huge.drc"
upload "Draco header declaring 33.5 M faces" "$TMP/huge.drc"
check_eq "... 413 before decoding" "$STATUS" 413
check "... naming the triangle limit" grep -q 'Draco mesh has more than 493447 triangles' "$TMP/Draco header declaring 33.5 M faces.json"
python3 "$MESHES" draco 400000 200000 "$TMP/budget.drc"
upload "Draco header declaring 400,000 faces and 200,000 points" "$TMP/budget.drc"
check_eq "... 413: they could never be kept in 64 MiB" "$STATUS" 413
check "... saying what they would need" grep -q 'declares 400000 faces and 200000 vertices, which need more than 73 MiB prepared, more than the 64 MiB allowed' \
  "$TMP/Draco header declaring 400,000 faces and 200,000 points.json"
python3 "$MESHES" huge-off "$TMP/huge.off"
upload "a 1e300 coordinate" "$TMP/huge.off"
check_eq "... 400 malformed_mesh" "$STATUS/$(error_code "$TMP/a 1e300 coordinate.json")" "400/malformed_mesh"
check "... naming the vertex and the bound" grep -q 'vertex 1 has a coordinate of magnitude 1e+300, above the 1e15' "$TMP/a 1e300 coordinate.json"
peak=$(peak_kb "$PID")
echo "#    after the expanding files: peak resident memory $((peak / 1024)) MB (limit $((PEAK_LIMIT_KB / 1024)) MB)"
check "expanding files: peak resident memory within $LIMIT_TEXT" [ "$peak" -lt "$PEAK_LIMIT_KB" ]

http "$TMP/ok.json" -X POST -H 'Content-Type: application/json' -d "$LINE" "$B/v1/meshes/$id/feature-lines"
check_eq "afterwards a line answers 200" "$STATUS" 200
finish
