#!/usr/bin/env bash
# Hostile clients against the real featureline-server: amplifying uploads, non-UTF-8
# error text with a request smuggled in the body, duplicate Content-Length, Range, Expect:
# 100-continue, header floods, oversized bodies on JSON routes, slowloris, the connection limit,
# the listen backlog, and SIGTERM with a slow sender connected. Raw connections use bash's
# /dev/tcp; every error body is checked against api/openapi.yaml.
#
#   SERVER=build/server/featureline-server FEATURELINE=build/cli/featureline bash tests/integration/hostile_test.sh
#
# Environment as server_test.sh (SERVER, JOBS, TIME_FACTOR, KEEP_TMP). Prints "ok"/"FAIL" lines
# and "N passed, N failed"; exits 1 on any failure.
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), SERVER, SHARED, MESHES, VR, VG, JOBS
CORPUS="$ROOT/tests/fuzz/corpus"

for tool in curl jq node perl timeout; do
  command -v "$tool" >/dev/null || { echo "FAIL $tool is not installed (run scripts/setup.sh)"; exit 1; }
done
[ -x "$SERVER" ] || { echo "FAIL no server binary at $SERVER (build it, or set SERVER=...)"; exit 1; }
[ -f "$CORPUS/glb/regression_amplified_instances.glb" ] || { echo "FAIL missing $CORPUS/glb/regression_amplified_instances.glb"; exit 1; }
FACTOR=$(time_factor "$SERVER")
CURL_MAX=$((30 * FACTOR))
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-hostile.XXXXXX")
trap cleanup EXIT
trap 'exit 130' INT TERM
T=$TMP
started_at=$(now_s)
echo "# server $SERVER (time factor $FACTOR)"

# main: the default limits. hard: 4 connection workers, at most 8 connections, heads within 2 s,
# uploads up to 1 MiB.
start_server main || { finish; exit 1; }
start_server hard --http-threads 4 --max-connections 8 --head-timeout-s 2 --max-upload-mb 1 || { finish; exit 1; }
B=${SRV_BASE[main]}
H=${SRV_BASE[hard]}
HP=${H##*:}

status_of() { head -n 1 "$1" | cut -d' ' -f2; }
# raw_error NAME FILE STATUS CODE: one response, with this status and error code, valid against the contract
raw_error() {
  local name=$1 file=$2 status=$3 code=$4
  check_eq "$name: exactly one response" "$(responses "$file")" 1
  check_eq "$name: status $status" "$(status_of "$file")" "$status"
  first_body "$file" >"$file.json"
  check_eq "$name: error code $code" "$(jq -r '.error.code' "$file.json" 2>/dev/null)" "$code"
  check "$name: the connection is closed at once (after $CLOSE_S s)" less_than "$CLOSE_S" $((2 * FACTOR))
  validate_schema "$name: body is an Error" Error "$file.json"
}

# ---- 1. uploads that expand -----------------------------------------------------------------
echo "# 1. amplification"
# 22 KB: one 1,058-triangle grid as 100 primitives of one mesh, instanced by 300 nodes (~32 M triangles).
amplified="$CORPUS/glb/regression_amplified_instances.glb"
t0=$(now_s)
http "$T/amp.json" --data-binary @"$amplified" -H 'Content-Type: model/gltf-binary' "$B/v1/meshes"
took=$(elapsed_since "$t0")
expect "22 KB GLB expanding to 32 M triangles (default limits)" 413 payload_too_large POST /v1/meshes "$T/amp.json"
check_eq "its message says the scene expands past the default limit" \
  "$(jq -r .error.message "$T/amp.json" | grep -o 'expands to more than 7895160 triangles')" "expands to more than 7895160 triangles"
check "it is refused in under 2 s, before expanding (took $took s)" less_than "$took" $((2 * FACTOR))
http "$T/amp2.json" --data-binary @"$amplified" -H 'Content-Type: model/gltf-binary' "$H/v1/meshes"
expect "the same GLB with a 1 MiB upload limit" 413 payload_too_large POST /v1/meshes "$T/amp2.json"
check_eq "the limit follows the upload limit (1 MiB / 12 bytes)" \
  "$(jq -r .error.message "$T/amp2.json" | grep -o 'configured limit is [0-9]*')" "configured limit is 87381"
http "$T/small.json" --data-binary @"$CORPUS/glb/regression_small_instances.glb" -H 'Content-Type: model/gltf-binary' "$B/v1/meshes"
expect "a small instanced GLB within the limits" 201 - POST /v1/meshes "$T/small.json"
check_eq "its 4 translated instances of a 16-vertex grid give 64 vertices" "$(jq .vertices "$T/small.json")" 64

# The command line reads with the server's default limits, and takes the same flags.
if [ -x "${FEATURELINE:-}" ]; then
  out=$("$FEATURELINE" info "$amplified" 2>&1); rc=$?
  check_eq "featureline info on the amplified GLB exits 1" "$rc" 1
  check_eq "with the expansion message" "$(printf %s "$out" | grep -o 'expands to more than 7895160 triangles')" "expands to more than 7895160 triangles"
  out=$("$FEATURELINE" info "$amplified" --max-triangles 40000000 --max-vertices 1000 2>&1)
  check_eq "featureline --max-vertices 1000 refuses it on vertices" "$(printf %s "$out" | grep -o 'configured limit is 1000 (--max-vertices)')" "configured limit is 1000 (--max-vertices)"
else
  fail "featureline CLI checks" "set FEATURELINE to the featureline binary (ctest does)"
fi

# ---- 2. error text from client bytes; no request smuggled behind a refusal --------------------
echo "# 2. non-UTF-8 error text, smuggling"
smuggled=$'GET /healthz HTTP/1.1\r\nHost: smuggled\r\n\r\n'
head=$'POST /v1/meshes?format=%FF HTTP/1.1\r\nHost: t\r\nContent-Type: application/octet-stream\r\nContent-Length: '${#smuggled}$'\r\n\r\n'
raw_send "$HP" "$T/ff.txt" 0 "$head" "$smuggled"
raw_error "?format=%FF with a request as its body" "$T/ff.txt" 415 unsupported_format
check_eq "?format=%FF: the byte is escaped in the message" "$(jq -r .error.message "$T/ff.txt.json" | grep -o '\\xFF')" '\xFF'
raw_send "$HP" "$T/ff2.txt" 0.3 "$head" "$smuggled"
raw_error "?format=%FF, body sent 0.3 s later" "$T/ff2.txt" 415 unsupported_format
head=$'POST /v1/meshes HTTP/1.1\r\nHost: t\r\nContent-Type: model/\xff\xfe\r\nContent-Length: '${#smuggled}$'\r\n\r\n'
raw_send "$HP" "$T/ct.txt" 0 "$head" "$smuggled"
raw_error "Content-Type with bytes 0xFF 0xFE and a request as body" "$T/ct.txt" 415 unsupported_format
head=$'POST /v1/meshes HTTP/1.1\r\nHost: t\r\nContent-Type: model/obj\r\nContent-Length: 5\r\nContent-Length: '${#smuggled}$'\r\n\r\n'
raw_send "$HP" "$T/dup.txt" 0 "$head" "$smuggled"
raw_error "two Content-Length headers" "$T/dup.txt" 400 invalid_request
head=$'POST /v1/meshes/0123/feature-lines HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\nContent-Length: 5242880\r\n\r\n'
raw_send "$HP" "$T/big.txt" 0 "$head" "$smuggled"
raw_error "a 5 MiB body to a JSON route, refused before it is read" "$T/big.txt" 413 payload_too_large
head=$'POST /v1/meshes/0123/feature-lines HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n'
raw_send "$HP" "$T/chunk.txt" 0 "$head" "$(printf '%x' ${#smuggled})"$'\r\n'"$smuggled"$'\r\n0\r\n\r\n'
raw_error "a chunked body to a JSON route" "$T/chunk.txt" 411 length_required
head=$'POST /v1/meshes/0123/feature-lines HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\nContent-Encoding: gzip\r\nContent-Length: '${#smuggled}$'\r\n\r\n'
raw_send "$HP" "$T/gz.txt" 0 "$head" "$smuggled"
raw_error "a gzip body to a JSON route" "$T/gz.txt" 415 unsupported_format

# ---- 3. Expect: 100-continue, Range ---------------------------------------------------------
echo "# 3. Expect, Range"
head=$'POST /v1/meshes?format=xyz HTTP/1.1\r\nHost: t\r\nExpect: 100-continue\r\nContent-Length: 900000\r\n\r\n'
raw_send "$HP" "$T/exp.txt" 0 "$head" ""
raw_error "Expect: 100-continue with ?format=xyz" "$T/exp.txt" 415 unsupported_format
head=$'POST /v1/meshes HTTP/1.1\r\nHost: t\r\nExpect: 100-continue\r\nContent-Length: 2097152\r\n\r\n'
raw_send "$HP" "$T/exp2.txt" 0 "$head" ""
raw_error "Expect: 100-continue over the upload limit" "$T/exp2.txt" 413 payload_too_large
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$T/tri.obj"
http "$T/exp3.json" -H 'Expect: 100-continue' -H 'Content-Type: model/obj' --data-binary @"$T/tri.obj" "$H/v1/meshes"
expect "Expect: 100-continue for a good upload" 201 - POST /v1/meshes "$T/exp3.json"
http "$T/range.json" -H 'Range: bytes=1000-2000' "$B/healthz"
expect "GET /healthz with an unsatisfiable Range" 200 - GET /healthz "$T/range.json"
http "$T/range2.json" -H 'Range: bytes=0-3' "$B/v1/meshes/00000000000000000000000000000000"
expect "a Range on a missing mesh: the JSON error, whole" 404 not_found GET /v1/meshes/00000000000000000000000000000000 "$T/range2.json"

# ---- 4. header floods ------------------------------------------------------------------------
echo "# 4. header limits"
many=$(for i in $(seq 1 200); do printf 'X-Flood-%d: x\r\n' "$i"; done)
raw_send "$HP" "$T/many.txt" 0 $'GET /healthz HTTP/1.1\r\nHost: t\r\n'"$many"$'\r\n' ""
raw_error "200 header fields" "$T/many.txt" 431 headers_too_large
long=$(head -c 100000 /dev/zero | tr '\0' a)
raw_send "$HP" "$T/long.txt" 0 $'GET /healthz HTTP/1.1\r\nHost: t\r\nX-Long: '"$long"$'\r\n\r\n' ""
raw_error "a 100 KB header line" "$T/long.txt" 431 headers_too_large
raw_send "$HP" "$T/lf.txt" 0 $'GET /healthz HTTP/1.1\nHost: t\n\n' ""
raw_error "a request whose lines end in a bare LF" "$T/lf.txt" 400 invalid_request
check "... says why" grep -q 'must end with CR LF, not a bare LF' "$T/lf.txt.json"

# ---- 5. slow and idle clients, the upload buffer ----------------------------------------------------------------
echo "# 5. slowloris, connection limit, backlog"
# slow_client OUT SECONDS: a request head trickled one byte every 0.25 s for at most SECONDS.
slow_client() {
  local out=$1 seconds=$2
  (
    trap '' PIPE
    exec 3<>"/dev/tcp/127.0.0.1/$HP" || exit 1
    printf 'GET /healthz HTTP/1.1\r\nHost: t\r\nX-Slow: ' >&3
    t0=$(now_s)
    for _ in $(seq 1 $((seconds * 4))); do printf 'a' >&3 2>/dev/null || break; sleep 0.25; done &
    writer=$!
    timeout "$seconds" cat <&3 >"$out"
    echo "$(elapsed_since "$t0")" >"$out.took"
    kill "$writer" 2>/dev/null
  ) 2>/dev/null &
  BG_PIDS+=($!)
}
slow_pids=()
for i in 1 2 3; do slow_client "$T/slow$i.txt" $((8 * FACTOR)); slow_pids+=("${BG_PIDS[-1]}"); done
sleep 0.3
served=0
for i in 1 2 3 4 5; do
  t0=$(now_s)
  http "$T/during.json" --max-time 3 "$H/healthz"
  took=$(elapsed_since "$t0")
  [ "$STATUS" = 200 ] && less_than "$took" "$FACTOR" && served=$((served + 1))
  sleep 0.1
done
check_eq "3 slowloris clients on 4 workers: 5 of 5 other requests answered 200 within $FACTOR s" "$served" 5
for pid in "${slow_pids[@]}"; do wait "$pid" 2>/dev/null; done
for i in 1 2 3; do
  check_eq "slowloris $i is answered 408" "$(status_of "$T/slow$i.txt")" 408
  check "slowloris $i is cut off after the 2 s head deadline (took $(cat "$T/slow$i.txt.took") s)" \
    less_than "$(cat "$T/slow$i.txt.took")" $((4 * FACTOR))
done
first_body "$T/slow1.txt" >"$T/slow1.json"
validate_schema "408 body is an Error" Error "$T/slow1.json"

# 8 silent connections fill the limit of 8; the next one is answered 503 at once. (First the
# workers finish their lingering closes of the slowloris connections, at most 1 s.)
sleep 1.5
# wait_for FILE: up to 10 s * FACTOR for a background client to say it is ready.
wait_for() { local i; for i in $(seq 1 $((100 * FACTOR))); do [ -e "$1" ] && return 0; sleep 0.1; done; return 1; }
( exec 3<>"/dev/tcp/127.0.0.1/$HP" 4<>"/dev/tcp/127.0.0.1/$HP" 5<>"/dev/tcp/127.0.0.1/$HP" 6<>"/dev/tcp/127.0.0.1/$HP" \
       7<>"/dev/tcp/127.0.0.1/$HP" 8<>"/dev/tcp/127.0.0.1/$HP" 9<>"/dev/tcp/127.0.0.1/$HP" 10<>"/dev/tcp/127.0.0.1/$HP" &&
  touch "$T/idle.ready" && sleep $((3 * FACTOR)) ) 2>/dev/null &
idle=$!; BG_PIDS+=($idle)
wait_for "$T/idle.ready"
sleep 0.3  # the server accepts them
t0=$(now_s)
http "$T/full.json" "$H/healthz"
took=$(elapsed_since "$t0")
check_eq "a connection beyond --max-connections 8 is answered 503" "$STATUS" 503
check_eq "it says overloaded" "$(error_code "$T/full.json")" overloaded
check_eq "it has Retry-After: 1" "$(header "$T/full.json" Retry-After)" 1
check "it is answered at once (took $took s)" less_than "$took" "$FACTOR"
validate_schema "503 body is an Error" Error "$T/full.json"
kill "$idle" 2>/dev/null; wait "$idle" 2>/dev/null
sleep 0.3
http "$T/after.json" "$H/healthz"
check_eq "after the silent connections close, /healthz answers 200" "$STATUS" 200

# 4 new connections that send nothing hold the 4 workers; a request behind them is served once
# they give their workers up (after 1 s when others wait; the idle timeout alone is 5 s).
rm -f "$T/idle.ready"
( exec 3<>"/dev/tcp/127.0.0.1/$HP" 4<>"/dev/tcp/127.0.0.1/$HP" 5<>"/dev/tcp/127.0.0.1/$HP" 6<>"/dev/tcp/127.0.0.1/$HP" &&
  touch "$T/idle.ready" && sleep $((8 * FACTOR)) ) 2>/dev/null &
idle=$!; BG_PIDS+=($idle)
wait_for "$T/idle.ready"
sleep 0.3
t0=$(now_s)
http "$T/behind.json" --max-time $((10 * FACTOR)) "$H/healthz"
took=$(elapsed_since "$t0")
check_eq "4 silent new connections on 4 workers: a request behind them is answered" "$STATUS" 200
check "... once they yield their workers, well before the 5 s idle timeout (took $took s)" less_than "$took" "$((1 + 2 * FACTOR))"
kill "$idle" 2>/dev/null; wait "$idle" 2>/dev/null

# 6 keep-alive clients on 4 workers: 2 always wait for one. Answers say Connection: close while
# others wait; no connection is ever closed with a request read and unanswered.
http "$T/ka_up.json" --data-binary @samples/ridge_field.off -H 'Content-Type: model/x-off' "$H/v1/meshes"
ka_id=$(jq -r '.mesh_id // empty' "$T/ka_up.json")
ka=$(timeout $((150 * FACTOR)) python3 "$HERE/keepalive_clients.py" "$HP" 6 40 "/v1/meshes/$ka_id/feature-lines" '{"keys": [701, 963, 1184]}')
ka_rc=$?
echo "#    keep-alive clients: $ka"
check_eq "6 keep-alive clients x 40 lines on 4 workers: none lost, every answer 200 or 503 ($ka)" "$ka_rc" 0
check "... most answered" test "$(echo "$ka" | awk '{print $2}')" -ge 200

if command -v ss >/dev/null; then
  backlog=$(ss -Hltn "sport = :$HP" | awk '{print $3}' | head -n 1)
  check_eq "the listen backlog is 1024 (httplib: 5)" "$backlog" 1024
else
  fail "the listen backlog is 1024" "ss (iproute2) is not installed: run scripts/setup.sh"
fi

# Upload bodies being received are bounded in total (default 2 x --max-upload-mb = 2 MiB here).
stalled=()
for i in 1 2; do
  ( trap '' PIPE; exec 3<>"/dev/tcp/127.0.0.1/$HP" || exit 1
    printf 'POST /v1/meshes HTTP/1.1\r\nHost: t\r\nContent-Type: model/obj\r\nContent-Length: 1048576\r\n\r\nv 0 0 0\n' >&3
    touch "$T/stalled$i.ready"; sleep $((3 * FACTOR)) ) 2>/dev/null &
  stalled+=($!); BG_PIDS+=($!)
done
wait_for "$T/stalled1.ready" && wait_for "$T/stalled2.ready"
sleep 0.3  # the server reads their heads
http "$T/buf.json" --data-binary @"$T/tri.obj" -H 'Content-Type: model/obj' "$H/v1/meshes"
expect "an upload while two stalled 1 MiB uploads hold the 2 MiB upload buffer" 503 overloaded POST /v1/meshes "$T/buf.json"
for pid in "${stalled[@]}"; do kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null; done
sleep 0.5
http "$T/buf2.json" --data-binary @"$T/tri.obj" -H 'Content-Type: model/obj' "$H/v1/meshes"
expect "once they are gone, the upload is accepted" 201 - POST /v1/meshes "$T/buf2.json"

http "$T/metrics.txt" "$H/metrics"
check "metrics count the transport's refusals (headers_too_large)" \
  grep -qE '^featureline_rejected_requests_total\{reason="headers_too_large"\} [1-9]' "$T/metrics.txt"

# ---- 6. SIGTERM with a slow sender connected -------------------------------------------------
echo "# 6. SIGTERM"
slow_client "$T/slow_stop.txt" $((8 * FACTOR))
# An upload whose body stops halfway: the answer written while stopping says Connection: close.
( trap '' PIPE; exec 3<>"/dev/tcp/127.0.0.1/$HP" || exit 1
  printf 'POST /v1/meshes HTTP/1.1\r\nHost: t\r\nContent-Type: model/obj\r\nContent-Length: 1000\r\n\r\nv 0 0 0\n' >&3
  timeout $((8 * FACTOR)) cat <&3 >"$T/half.txt" ) 2>/dev/null &
half=$!; BG_PIDS+=($half)
sleep 0.5
stop_server hard TERM
check_eq "server 'hard' exits 0 on SIGTERM with slow clients connected" "$STOP_RC" 0
check "it stops within $((2 * FACTOR)) s, not waiting for them (took $STOP_SECONDS s)" less_than "$STOP_SECONDS" $((2 * FACTOR))
wait "$half" 2>/dev/null
check_eq "the half-sent upload is answered 400" "$(status_of "$T/half.txt")" 400
check "that answer says Connection: close" grep -qi '^Connection: close' "$T/half.txt"
stop_server main TERM
check_eq "server 'main' exits 0 on SIGTERM" "$STOP_RC" 0

sanitizer=$(grep -l -E 'ERROR: (Address|Leak|Thread)Sanitizer|runtime error:' "$T"/*.log 2>/dev/null)
if [ -z "$sanitizer" ]; then pass "no sanitizer reports in the servers' logs"
else fail "no sanitizer reports in the servers' logs" "$(grep -h -A8 -E 'ERROR: (Address|Leak|Thread)Sanitizer|runtime error:' $sanitizer | head -n 40)"; fi

run_validations
echo "# total $(elapsed_since "$started_at") s"
finish
