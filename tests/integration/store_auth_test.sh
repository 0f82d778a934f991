#!/usr/bin/env bash
# The Redis store with a password: the real featureline-server against a real redis-server
# started here with requirepass (given on standard input, as docker/ does) on a free loopback
# port. The password from FEATURELINE_REDIS_PASSWORD or percent-encoded in the --store URL
# (also an ACL user's) works: an upload survives a server restart, rebuilt from Redis. A wrong
# or missing password stops the server at start with exit 1 and a one-line error; found later
# (Redis restarted with another password, or started after the server) /readyz answers 503
# saying why, and a Redis back on the right password is used again (AUTH on every new
# connection). No password ever appears in what the servers print or answer.
#
#   SERVER=build/server/featureline-server SHARED=../shared bash tests/integration/store_auth_test.sh
#
# Prints "ok   NAME" / "FAIL NAME" lines and "N passed, N failed"; exits 1 on any failure.
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), SERVER, SHARED, MESHES, VR, VG, JOBS

for tool in curl jq node ss redis-server redis-cli timeout; do
  command -v "$tool" >/dev/null || { echo "FAIL $tool is not installed"; exit 1; }
done
[ -x "$SERVER" ] || { echo "FAIL no server binary at $SERVER"; exit 1; }
FACTOR=$(time_factor "$SERVER")
CURL_MAX=$((60 * FACTOR))
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-store-auth.XXXXXX")
T=$TMP
trap 'exit 130' INT TERM

# Random per run, so a leak cannot hide behind a string the code might know. PASSWORD has the
# characters a URL must percent-encode; the ACL user's is plain.
random_hex() { od -An -N12 -tx1 /dev/urandom | tr -d ' \n'; }
PASSWORD="fl/$(random_hex)@x:y%z"
ENCODED=$(jq -rn --arg s "$PASSWORD" '$s | @uri')
USER_PASSWORD="u$(random_hex)"
WRONG="wrong$(random_hex)"
OTHER="other$(random_hex)"

REDIS_PORT=$(free_port_block 1) || { echo "FAIL no free port for Redis"; exit 1; }
STORE="redis://127.0.0.1:$REDIS_PORT"

REDIS_PID=""
# start_redis PASSWORD: requirepass PASSWORD and the ACL user "ci" (keys featureline:* only), the
# append-only file in $T/redis (kept across restarts); sets REDIS_PID.
start_redis() {
  mkdir -p "$T/redis"
  printf 'requirepass "%s"\nuser ci on >%s ~featureline:* +@all\n' "$1" "$USER_PASSWORD" |
    redis-server --port "$REDIS_PORT" --bind 127.0.0.1 --dir "$T/redis" --appendonly yes --appendfsync always --save "" \
      --maxmemory-policy noeviction --loglevel warning - >>"$T/redis.log" 2>&1 &
  REDIS_PID=$!
  for _ in $(seq 1 100); do
    REDISCLI_AUTH="$1" redis-cli -p "$REDIS_PORT" ping 2>/dev/null | grep -q PONG && return 0
    sleep 0.1
  done
  fail "redis-server starts on port $REDIS_PORT" "$(tail -n 5 "$T/redis.log")"
  return 1
}
stop_redis() {
  [ -n "$REDIS_PID" ] || return 0
  stop_pids 50 "$REDIS_PID"
  wait "$REDIS_PID" 2>/dev/null
  REDIS_PID=""
}
store_cleanup() { stop_redis; cleanup; }
trap store_cleanup EXIT

upload() {  # upload SERVER_NAME -> ID, STATUS
  http "$T/up.json" --data-binary @samples/ridge_field.off -H 'Content-Type: application/octet-stream' "${SRV_BASE[$1]}/v1/meshes"
  ID=$(jq -r '.mesh_id // empty' "$T/up.json" 2>/dev/null)
}
line() {  # line SERVER_NAME ID -> LINE (the answer without timings), STATUS
  http "$T/line.json" -X POST -H 'Content-Type: application/json' -d '{"keys": [701, 963, 1184]}' \
    "${SRV_BASE[$1]}/v1/meshes/$2/feature-lines"
  LINE=$(jq -c 'del(.stats.timings_ms)' "$T/line.json" 2>/dev/null)
}
readyz() { http "$2" "${SRV_BASE[$1]}/readyz"; }  # readyz SERVER_NAME OUT
metric() { curl -s --max-time 5 "${SRV_BASE[$1]}/metrics" | awk -v m="$2" '$1 == m { print $2 }'; }

# refused_at_start NAME ARGS...: the server must exit by itself (bounded by timeout); sets RC,
# its output in $T/NAME.out and $T/NAME.log.
refused_at_start() {
  local name=$1; shift
  timeout $((20 * FACTOR)) "$SERVER" --port 0 "$@" >"$T/$name.out" 2>"$T/$name.log"
  RC=$?
}

# ---- the right password: from the environment, then in the URL; the session survives the restart ----
start_redis "$PASSWORD" || exit 1
FEATURELINE_REDIS_PASSWORD="$PASSWORD" start_server env --store "$STORE" || exit 1
readyz env "$T/rz_env.json"
expect "readyz with the password from FEATURELINE_REDIS_PASSWORD" 200 - GET /readyz "$T/rz_env.json"
check "the password is not on the server's command line" bash -c "! tr '\0' ' ' </proc/${SRV_PID[env]}/cmdline | grep -qF -- '$PASSWORD'"
upload env; KEPT=$ID
check_eq "an upload: 201" "$STATUS" 201
line env "$KEPT"; KEPT_LINE=$LINE
check_eq "a line on it: 200" "$STATUS" 200
stop_server env

start_server url --store "redis://:$ENCODED@127.0.0.1:$REDIS_PORT" || exit 1
check_eq "the banner shows the URL without its password" "$(grep '^uploads kept' "$T/url.out")" \
  "uploads kept in redis://***@127.0.0.1:$REDIS_PORT"
line url "$KEPT"
check_eq "restarted with the percent-encoded password in the URL, the session answers, identical" "$STATUS/$LINE" "200/$KEPT_LINE"
check_eq "... rebuilt from Redis" "$(metric url featureline_store_rebuilds_total)" 1
stop_server url

start_server acl --store "redis://ci:$USER_PASSWORD@127.0.0.1:$REDIS_PORT" || exit 1
upload acl
check_eq "an ACL user from the URL: an upload, 201" "$STATUS" 201
http "$T/acl_get.json" "${SRV_BASE[acl]}/v1/meshes/$KEPT"
check_eq "... and another server's session, 200" "$STATUS" 200
stop_server acl

# ---- wrong or missing password with Redis up: exit 1 at start, one clear line ---------------------
FEATURELINE_REDIS_PASSWORD="$WRONG" refused_at_start wrong --store "$STORE"
check_eq "a wrong password in FEATURELINE_REDIS_PASSWORD: exit 1 at start" "$RC" 1
check "... saying Redis refused the password and where it comes from" \
  grep -q "featureline-server: Redis at redis 127.0.0.1:$REDIS_PORT/0 refused the password (WRONGPASS.*FEATURELINE_REDIS_PASSWORD" "$T/wrong.log"
refused_at_start wrong_url --store "redis://:$WRONG@127.0.0.1:$REDIS_PORT"
check_eq "a wrong password in the URL: exit 1 at start" "$RC" 1
check "... saying Redis refused the password" grep -q "refused the password" "$T/wrong_url.log"
refused_at_start none --store "$STORE"
check_eq "no password: exit 1 at start" "$RC" 1
check "... saying Redis requires one and how to give it" \
  grep -q "requires a password and none was given: set FEATURELINE_REDIS_PASSWORD or give it in the store URL" "$T/none.log"
check_eq "... in one line" "$(wc -l <"$T/none.log")" 1
refused_at_start user_only --store "redis://ci@127.0.0.1:$REDIS_PORT"
check_eq "a user and no password: exit 1 at start" "$RC" 1
check "... saying so" grep -q "names a user but no password" "$T/user_only.log"

# ---- found while running: Redis restarted with another password, then with the right one again -----
FEATURELINE_REDIS_PASSWORD="$PASSWORD" start_server live --store "$STORE" || exit 1
line live "$KEPT"  # now in this server's memory
stop_redis; start_redis "$OTHER" || exit 1
readyz live "$T/rz_other.json"
expect "readyz after Redis restarted with another password" 503 storage_unavailable GET /readyz "$T/rz_other.json"
check "... says Redis refused the password" grep -q "refused the password" "$T/rz_other.json"
upload live
expect "an upload meanwhile" 503 storage_unavailable POST /v1/meshes "$T/up.json"
http "$T/hz_other.json" "${SRV_BASE[live]}/healthz"
check_eq "the server stays up (healthz 200)" "$STATUS" 200
line live "$KEPT"
check_eq "a session in its memory keeps answering, identical" "$STATUS/$LINE" "200/$KEPT_LINE"
stop_redis; start_redis "$PASSWORD" || exit 1
for _ in $(seq 1 $((30 * FACTOR))); do readyz live "$T/rz_back.json"; [ "$STATUS" = 200 ] && break; sleep 0.2; done
check_eq "Redis back on the right password: readyz 200 (a new connection, authenticated)" "$STATUS" 200
line live "$KEPT"
check_eq "... and the session from before answers, identical" "$STATUS/$LINE" "200/$KEPT_LINE"
stop_server live

# ---- found while running: no password, Redis started after the server ------------------------------
stop_redis
start_server late --store "$STORE" || exit 1
start_redis "$PASSWORD" || exit 1
readyz late "$T/rz_late.json"
expect "readyz of a server without a password once Redis, which wants one, is up" 503 storage_unavailable GET /readyz "$T/rz_late.json"
check "... says a password is required" grep -q "requires a password and none was given" "$T/rz_late.json"
stop_server late

# ---- no password in anything the servers printed or answered -------------------------------------
leaks=$(grep -rlF -e "$PASSWORD" -e "$ENCODED" -e "$USER_PASSWORD" -e "$WRONG" -e "$OTHER" "$T" --exclude=redis.log --exclude-dir=redis)
check_eq "no password in the servers' output, logs or answers" "$leaks" ""
check "(the servers did log: access lines and errors)" grep -q ' 503 ' "$T/live.log"

run_validations
finish
