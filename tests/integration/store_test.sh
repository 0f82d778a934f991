#!/usr/bin/env bash
# Durable sessions of one featureline-server, the real binary driven with curl:
# restarted with the same --data-dir it keeps its sessions (identical lines) and remembers
# deletes; eviction costs a rebuild, not the session; a full store (--store-max-mb) and an
# unreachable Redis answer 503 with their codes and keep nothing; idle uploads expire from the
# store and the 404 says so, also after a restart. With a real redis-server: a restart
# leaves no request failing on a stale pooled connection; a Redis restarted empty makes sessions
# answer 404 "lost by the upload store" (not "deleted"); a SIGSTOPped Redis opens the circuit
# breaker (cached sessions answer, uploads fail at once); /readyz follows the store.
#
#   SERVER=build/server/featureline-server SHARED=../shared bash tests/integration/store_test.sh
#
# Prints "ok   NAME" / "FAIL NAME" lines and "N passed, N failed"; exits 1 on any failure.
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), SERVER, SHARED, MESHES, VR, VG, JOBS

for tool in curl jq node ss; do command -v "$tool" >/dev/null || { echo "FAIL $tool is not installed"; exit 1; }; done
[ -x "$SERVER" ] || { echo "FAIL no server binary at $SERVER"; exit 1; }
for f in dragon_25k.off armadillo_29k.obj bunny_closed.off; do
  [ -f "$MESHES/$f" ] || { echo "FAIL missing test mesh $MESHES/$f"; exit 1; }
done
FACTOR=$(time_factor "$SERVER")
CURL_MAX=$((60 * FACTOR))
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-store.XXXXXX")
T=$TMP
trap cleanup EXIT
trap 'exit 130' INT TERM
DATA="$T/data"

upload() {  # upload SERVER_NAME FILE -> ID
  http "$T/up.json" --data-binary @"$2" -H 'Content-Type: application/octet-stream' "${SRV_BASE[$1]}/v1/meshes"
  ID=$(jq -r '.mesh_id // empty' "$T/up.json" 2>/dev/null)
}
line() {  # line SERVER_NAME ID KEYS -> LINE (the answer without timings), STATUS
  http "$T/line.json" -X POST -H 'Content-Type: application/json' -d "{\"keys\": $3}" "${SRV_BASE[$1]}/v1/meshes/$2/feature-lines"
  LINE=$(jq -c 'del(.stats.timings_ms)' "$T/line.json" 2>/dev/null)
}
metric() { curl -s --max-time 5 "${SRV_BASE[$1]}/metrics" | awk -v m="$2" '$1 == m { print $2 }'; }

# ---- a restart with the same --data-dir keeps the sessions ---------------------------------------
start_server a --data-dir "$DATA" --quiet || exit 1
check "the banner names the store" grep -q "uploads kept in dir:$DATA" "$T/a.out"
upload a samples/ridge_field.off; RIDGE=$ID
line a "$RIDGE" '[701, 963, 1184]'; check_eq "a line before the restart" "$STATUS" 200
RIDGE_LINE=$LINE
http "$T/desc1.json" "${SRV_BASE[a]}/v1/meshes/$RIDGE"
upload a "$MESHES/dragon_25k.off"; DRAGON=$ID
check "the upload is on disk, whole, with no temporary file left" \
  bash -c "[ -s '$DATA/uploads/$RIDGE' ] && [ -z \"\$(ls -A '$DATA/tmp')\" ]"
stop_server a
check_eq "the first server stops on SIGTERM" "$STOP_RC" 0

start_server b --data-dir "$DATA" --quiet || exit 1
line b "$RIDGE" '[701, 963, 1184]'
check_eq "after the restart the session answers" "$STATUS" 200
check_eq "after the restart the line is identical" "$LINE" "$RIDGE_LINE"
http "$T/desc2.json" "${SRV_BASE[b]}/v1/meshes/$RIDGE"
expect "after the restart the description answers" 200 - GET "/v1/meshes/$RIDGE" "$T/desc2.json"
check_eq "the description is the same (but its expiry countdown)" \
  "$(jq -c 'del(.expires_in_s, .load_ms, .timings_ms)' "$T/desc2.json")" "$(jq -c 'del(.expires_in_s, .load_ms, .timings_ms)' "$T/desc1.json")"
check_eq "one rebuild from the store" "$(metric b featureline_store_rebuilds_total)" 1
http "$T/del.json" -X DELETE "${SRV_BASE[b]}/v1/meshes/$DRAGON"
check_eq "DELETE: 204" "$STATUS" 204
check "DELETE removes the stored upload" test ! -e "$DATA/uploads/$DRAGON"
http "$T/gone.json" "${SRV_BASE[b]}/v1/meshes/$DRAGON"
expect "the deleted mesh" 404 not_found GET "/v1/meshes/$DRAGON" "$T/gone.json"
check "its 404 says deleted" grep -q "was deleted" "$T/gone.json"
http "$T/del2.json" -X DELETE "${SRV_BASE[b]}/v1/meshes/$DRAGON"
check_eq "DELETE again: 404" "$STATUS" 404
stop_server b
start_server c --data-dir "$DATA" --quiet || exit 1
http "$T/gone2.json" "${SRV_BASE[c]}/v1/meshes/$DRAGON"
check "after another restart the 404 still says deleted" grep -q "was deleted" "$T/gone2.json"
http "$T/unknown.json" "${SRV_BASE[c]}/v1/meshes/0123456789abcdef0123456789abcdef"
check "an id never issued: 'no mesh with id'" grep -q "no mesh with id" "$T/unknown.json"
http "$T/traversal.json" "${SRV_BASE[c]}/v1/meshes/..%2F..%2Fetc%2Fpasswd"
check_eq "a path-like id is just unknown" "$STATUS" 404
stop_server c

# ---- eviction costs a rebuild, not the session ------------------------------------------------------
# dragon_25k and armadillo_29k prepared take 3.4 and 4.0 MB: a 6 MB cache holds one.
start_server small --data-dir "$T/data2" --cache-mb 6 --quiet || exit 1
upload small "$MESHES/dragon_25k.off"; FIRST=$ID
line small "$FIRST" '[10, 200, 400]'; FIRST_LINE=$LINE
upload small "$MESHES/armadillo_29k.obj"
check "the second upload evicted the first" test "$(metric small featureline_cache_evictions_total)" -ge 1
line small "$FIRST" '[10, 200, 400]'
check_eq "the evicted session answers (rebuilt)" "$STATUS" 200
check_eq "with an identical line" "$LINE" "$FIRST_LINE"
check "it was rebuilt from the store" test "$(metric small featureline_store_rebuilds_total)" -ge 1
stop_server small

# ---- restarted with a cache too small for a stored mesh: 503 cache_too_small, remembered ------------
start_server tiny --data-dir "$T/data2" --cache-mb 2 --quiet || exit 1
http "$T/tiny1.json" "${SRV_BASE[tiny]}/v1/meshes/$FIRST"
expect "a stored mesh a 2 MiB cache cannot hold" 503 cache_too_small GET "/v1/meshes/$FIRST" "$T/tiny1.json"
check "... says so and what would serve it" grep -q "cannot be prepared within this server's memory.*larger --cache-mb" "$T/tiny1.json"
check_eq "... with Retry-After: 60" "$(header "$T/tiny1.json" Retry-After)" 60
line tiny "$FIRST" '[10, 200, 400]'
check_eq "a line on it: the same 503, remembered (not read again)" "$STATUS/$(error_code "$T/line.json")" "503/cache_too_small"
http "$T/tinydel.json" -X DELETE "${SRV_BASE[tiny]}/v1/meshes/$FIRST"
check_eq "it can still be deleted: 204" "$STATUS" 204
http "$T/tiny2.json" "${SRV_BASE[tiny]}/v1/meshes/$FIRST"
check "then it is gone: 404 deleted" grep -q "was deleted" "$T/tiny2.json"
stop_server tiny

# ---- a full store and an unreachable Redis: 503, nothing kept -------------------------------------------
start_server full --data-dir "$T/data3" --store-max-mb 2 --quiet || exit 1
upload full samples/ridge_field.off
check_eq "a small upload fits the 2 MiB store" "$STATUS" 201
upload full "$MESHES/bunny_closed.off"
expect "an upload the store cannot hold (2.7 MB)" 503 storage_full POST /v1/meshes "$T/up.json"
check "it says Retry-After" test -n "$(header "$T/up.json" Retry-After)"
check_eq "nothing of it is kept (one upload on disk)" "$(ls "$T/data3/uploads" | wc -l)" 1
check_eq "no session of it is cached" "$(metric full featureline_cache_entries)" 1
stop_server full

free_port=$(free_port_block 1) || { fail "a free port for the unreachable store"; exit 1; }
start_server noredis --store "redis://127.0.0.1:$free_port" --quiet || exit 1
upload noredis samples/ridge_field.off
expect "an upload while Redis is unreachable" 503 storage_unavailable POST /v1/meshes "$T/up.json"
http "$T/nr.json" "${SRV_BASE[noredis]}/v1/meshes/0123456789abcdef0123456789abcdef"
expect "a lookup that needs Redis while it is unreachable" 503 storage_unavailable GET /v1/meshes/0123456789abcdef0123456789abcdef "$T/nr.json"
http "$T/nrh.json" "${SRV_BASE[noredis]}/healthz"
check_eq "the server itself stays up (healthz 200)" "$STATUS" 200
http "$T/nrr.json" "${SRV_BASE[noredis]}/readyz"
expect "but it is not ready (readyz)" 503 storage_unavailable GET /readyz "$T/nrr.json"
stop_server noredis

# ---- Redis restarted, restarted empty, hung: readiness, no stale-connection 503s, "lost", the breaker -----
REDIS_PID=""
start_redis() {  # start_redis DATA_DIR: on $REDIS_PORT, append-only file in DATA_DIR; sets REDIS_PID
  mkdir -p "$1"
  redis-server --port "$REDIS_PORT" --bind 127.0.0.1 --dir "$1" --appendonly yes --appendfsync always --save "" \
    --maxmemory-policy noeviction --loglevel warning >>"$T/redis.log" 2>&1 &
  REDIS_PID=$!
  for _ in $(seq 1 100); do redis-cli -p "$REDIS_PORT" ping 2>/dev/null | grep -q PONG && return 0; sleep 0.1; done
  fail "redis-server starts on port $REDIS_PORT" "$(tail -n 5 "$T/redis.log")"
  return 1
}
stop_redis() {  # SIGCONT first: a stopped Redis would not act on SIGTERM
  [ -n "$REDIS_PID" ] || return 0
  kill -CONT "$REDIS_PID" 2>/dev/null
  stop_pids 50 "$REDIS_PID"
  wait "$REDIS_PID" 2>/dev/null
  REDIS_PID=""
}
store_cleanup() { stop_redis; cleanup; }
trap store_cleanup EXIT
readyz() {  # readyz SERVER_NAME OUT: sets STATUS
  http "$2" "${SRV_BASE[$1]}/readyz"
}
REDIS_PORT=$(free_port_block 1) || { fail "a free port for Redis"; exit 1; }

start_server memonly --quiet || exit 1
readyz memonly "$T/rz_mem.json"
expect "readyz without a store" 200 - GET /readyz "$T/rz_mem.json"
check_eq "... names no store" "$(jq -c '[.status, .store]' "$T/rz_mem.json")" '["ready",null]'
http "$T/plain.json" -H 'X-Featureline-Front: hand-off' -H 'Content-Type: application/octet-stream' --data-binary @samples/ridge_field.off "${SRV_BASE[memonly]}/v1/meshes"
check_eq "a hand-off asked of a replica without a shared store: it prepares the upload itself (201)" \
  "$STATUS/$(header "$T/plain.json" X-Accel-Redirect)/$(metric memonly featureline_uploads_handed_off_total)" "201//0"
stop_server memonly

start_redis "$T/redis-a" || exit 1
start_server rs --store "redis://127.0.0.1:$REDIS_PORT" || exit 1
readyz rs "$T/rz1.json"
expect "readyz with Redis up" 200 - GET /readyz "$T/rz1.json"
check_eq "... names the store and no data loss" "$(jq -c '[.store, .store_data_losses]' "$T/rz1.json")" "[\"redis 127.0.0.1:$REDIS_PORT/0\",0]"
# Concurrent uploads leave several connections in the server's pool.
for i in 1 2 3 4 5 6; do
  curl -s -o "$T/par$i.json" -w '%{http_code}' --max-time "$CURL_MAX" --data-binary @samples/ridge_field.off \
    -H 'Content-Type: application/octet-stream' "${SRV_BASE[rs]}/v1/meshes" >"$T/par$i.code" &
  BG_PIDS+=($!)
done
wait "${BG_PIDS[@]}" 2>/dev/null
check_eq "6 concurrent uploads: 201 each" "$(cat "$T"/par?.code | tr -d '\n')" "201201201201201201"
KEPT=$(jq -r .mesh_id "$T/par1.json")
line rs "$KEPT" '[701, 963, 1184]'; KEPT_LINE=$LINE

# Behind the front (deploy/nginx.conf.template): an upload asked to be handed off is stored, not
# prepared, and handed back; the replica the front sends it on to prepares it and answers as an
# upload. A mesh that cannot be prepared is removed from the store with the usual error.
handoff() {  # handoff FILE: sets HANDED (the id in the X-Accel-Redirect) and STATUS
  http "$T/ho.json" --data-binary @"$1" -H 'Content-Type: application/octet-stream' -H 'X-Featureline-Front: hand-off' \
    "${SRV_BASE[rs]}/v1/meshes"
  HANDED=$(header "$T/ho.json" X-Accel-Redirect | sed -n 's|^/_featureline/uploaded/\([0-9a-f]\{32\}\)$|\1|p')
}
inserts=$(metric rs featureline_cache_inserts_total)
handoff samples/ridge_field.off
check_eq "a hand-off: 200, empty, X-Accel-Redirect to /_featureline/uploaded/ID" "$STATUS/$(wc -c <"$T/ho.json")/${#HANDED}" "200/0/32"
check_eq "... stored in Redis, not prepared" "$(redis-cli -p "$REDIS_PORT" --raw exists "featureline:upload:$HANDED")/$(metric rs featureline_cache_inserts_total)" "1/$inserts"
http "$T/taken.json" -H 'X-Featureline-Front: uploaded' "${SRV_BASE[rs]}/v1/meshes/$HANDED"
expect "the owner's half of the hand-off" 201 - POST /v1/meshes "$T/taken.json"
check_eq "... the upload's answer: its id, Location, the mesh's counts" \
  "$(jq -r '[.mesh_id, .vertices] | @tsv' "$T/taken.json") $(header "$T/taken.json" Location)" \
  "$HANDED	$(jq -r .vertices "$T/par1.json") /v1/meshes/$HANDED"
check_eq "... prepared once, counted as taken over (not a rebuild)" \
  "$(metric rs featureline_cache_inserts_total)/$(metric rs featureline_uploads_handed_off_total)/$(metric rs featureline_uploads_taken_over_total)" \
  "$((inserts + 1))/1/1"
line rs "$HANDED" '[701, 963, 1184]'
check_eq "a line on it: the same line as on a direct upload of the mesh" "$STATUS/$LINE" "200/$KEPT_LINE"
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n' >"$T/broken.off"
handoff "$T/broken.off"
check_eq "a malformed mesh is handed off too (its head and format pass)" "$STATUS/${#HANDED}" "200/32"
http "$T/taken2.json" -H 'X-Featureline-Front: uploaded' "${SRV_BASE[rs]}/v1/meshes/$HANDED"
expect "its owner cannot prepare it" 400 malformed_mesh POST /v1/meshes "$T/taken2.json"
check_eq "... and removes it from Redis" "$(redis-cli -p "$REDIS_PORT" --raw exists "featureline:upload:$HANDED")" 0

# Restarted with its data (append-only file): the pooled connections are dead, nothing may fail.
stop_redis; start_redis "$T/redis-a" || exit 1
codes=""
for i in 1 2 3 4 5 6 7 8; do upload rs samples/ridge_field.off; codes="$codes$STATUS "; done
check_eq "after a Redis restart, 8 uploads in a row: 201 each (no 503 from stale connections)" "$codes" "201 201 201 201 201 201 201 201 "
check_eq "no request failed: no 503 in the access log" "$(grep -c ' 503 ' "$T/rs.log")" 0
line rs "$KEPT" '[701, 963, 1184]'
check_eq "a session from before the restart answers, identical" "$STATUS/$LINE" "200/$KEPT_LINE"
readyz rs "$T/rz2.json"
check_eq "a restart that kept the data is no data loss" "$(jq .store_data_losses "$T/rz2.json")" 0

# Restarted empty: the sessions are lost by the store, not deleted; new uploads work.
stop_redis; start_redis "$T/redis-empty" || exit 1
http "$T/lost1.json" "${SRV_BASE[rs]}/v1/meshes/$KEPT"
expect "a session whose upload Redis lost" 404 not_found GET "/v1/meshes/$KEPT" "$T/lost1.json"
check "... says the store lost it and to upload again (not 'deleted')" grep -q "was lost by the upload store.*upload it again" "$T/lost1.json"
line rs "$KEPT" '[701, 963, 1184]'
check "a line on it afterwards: the same 404 reason" grep -q "was lost by the upload store" "$T/line.json"
http "$T/lost2.json" "${SRV_BASE[rs]}/v1/meshes/0123456789abcdef0123456789abcdef"
check "an id this replica never had: 404 that says the store lost its data" grep -q "no mesh with id.*lost its data" "$T/lost2.json"
readyz rs "$T/rz3.json"
expect "readyz after the data loss" 200 - GET /readyz "$T/rz3.json"
check_eq "... counts one data loss and says when" "$(jq -c '[.store_data_losses, (.store_last_data_loss | test("^20[0-9-]+T[0-9:]+Z$"))]' "$T/rz3.json")" "[1,true]"
check_eq "... and so does /metrics" "$(metric rs featureline_store_data_losses_total)" 1
upload rs samples/ridge_field.off; AFTER=$ID
check_eq "an upload after the loss: 201" "$STATUS" 201

# Hung (SIGSTOP): the breaker opens after consecutive timeouts; the cached session keeps answering,
# uploads fail at once with 503, readiness says not ready; after SIGCONT the probe closes it.
line rs "$AFTER" '[701, 963, 1184]'; AFTER_LINE=$LINE
kill -STOP "$REDIS_PID"
for _ in $(seq 1 10); do
  line rs "$AFTER" '[701, 963, 1184]'
  [ "$(metric rs featureline_store_breaker_open)" = 1 ] && break
done
check_eq "the breaker opened while Redis is stopped" "$(metric rs featureline_store_breaker_open)" 1
lines_ok=0
for _ in $(seq 1 20); do line rs "$AFTER" '[701, 963, 1184]'; [ "$STATUS/$LINE" = "200/$AFTER_LINE" ] && lines_ok=$((lines_ok + 1)); done
check_eq "with the breaker open, 20 lines on the cached session: 200 and identical" "$lines_ok" 20
upload rs samples/ridge_field.off
expect "an upload with the breaker open" 503 storage_unavailable POST /v1/meshes "$T/up.json"
check "... fails at once, without waiting for Redis (says so)" grep -q "fail at once" "$T/up.json"
check "... with Retry-After" test -n "$(header "$T/up.json" Retry-After)"
readyz rs "$T/rz4.json"
expect "readyz with the breaker open" 503 storage_unavailable GET /readyz "$T/rz4.json"
http "$T/hz_open.json" "${SRV_BASE[rs]}/healthz"
check_eq "healthz (liveness) stays 200" "$STATUS" 200
kill -CONT "$REDIS_PID"
for _ in $(seq 1 $((30 * FACTOR))); do readyz rs "$T/rz5.json"; [ "$STATUS" = 200 ] && break; sleep 0.2; done
check_eq "after SIGCONT the probe closes the breaker: readyz 200" "$STATUS" 200
upload rs samples/ridge_field.off
check_eq "... and uploads work again" "$STATUS" 201

# Redis gone: not ready.
stop_redis
readyz rs "$T/rz6.json"
expect "readyz with Redis down" 503 storage_unavailable GET /readyz "$T/rz6.json"
stop_server rs

# ---- idle uploads expire from the store; the 404 says so, also after a restart ----------------------------
start_server ttl --data-dir "$T/data4" --ttl-s 2 --quiet || exit 1
upload ttl samples/ridge_field.off; SHORT=$ID
# The store keeps an upload 1 s beyond the 2 s TTL and is swept every 5 s: poll (bounded).
for _ in $(seq 1 $((40 * FACTOR))); do
  [ -e "$T/data4/uploads/$SHORT" ] || break
  sleep 0.5
done
check "the idle upload left the store" test ! -e "$T/data4/uploads/$SHORT"
http "$T/exp.json" "${SRV_BASE[ttl]}/v1/meshes/$SHORT"
expect "the expired mesh" 404 not_found GET "/v1/meshes/$SHORT" "$T/exp.json"
check "its 404 says expired" grep -q "expired after 2 s without use" "$T/exp.json"
stop_server ttl
start_server ttl2 --data-dir "$T/data4" --ttl-s 2 --quiet || exit 1
http "$T/exp2.json" "${SRV_BASE[ttl2]}/v1/meshes/$SHORT"
check "after a restart the 404 still says expired" grep -q "expired after" "$T/exp2.json"
stop_server ttl2

run_validations
finish
