# Helpers for the server's integration tests (sourced first by every *_test.sh that runs the
# server: source "$(dirname "${BASH_SOURCE[0]}")/lib.sh").
#
# Sourcing it also sets where things are, and makes the repository the working directory:
#   HERE (this folder), ROOT (the repository), SERVER (default build/server/featureline-server),
#   SHARED (default ../shared beside the repository), MESHES ($SHARED/data/meshes), VR and VG
#   (the response and glTF validators), JOBS (parallel validator runs, default nproc).
#
#   check NAME COMMAND...      runs COMMAND; prints "ok   NAME" or "FAIL NAME"
#   pass NAME / fail NAME [DETAIL...]
#   free_port_block COUNT      prints a port P with P..P+COUNT-1 unused, for programs that cannot
#                              listen on port 0 and report it (Redis, nginx)
#   start_server NAME [FLAGS...]  starts $SERVER on a free port (--port 0 --port-file), waits
#                              until /healthz answers; sets SRV_BASE[NAME], SRV_PID[NAME],
#                              SRV_LOG[NAME] (stderr: access log, "stopped", sanitizer reports)
#   http OUT CURL_ARGS...      one request with curl: body to OUT, headers to OUT.hdr; sets STATUS
#   header OUT NAME            a response header's value (last one if repeated)
#   expect NAME STATUS CODE METHOD PATH OUT
#                              checks the status (and error code unless CODE is "-") of the last
#                              http call and queues OUT for validation against api/openapi.yaml
#   validate_json NAME METHOD PATH STATUS FILE / validate_schema NAME SCHEMA FILE /
#   validate_request NAME METHOD PATH FILE / validate_gltf NAME FILE
#                              queue a validator run; run_validations runs the queue in
#                              parallel (one node process per distinct body) and reports each
#   raw_send PORT OUT PAUSE HEAD BODY
#                              sends HEAD (and BODY after PAUSE seconds) on one raw connection,
#                              reads until the server closes (OUT); sets CLOSE_S (seconds from the
#                              last write to the close, "timeout" after 10 s * FACTOR)
#   responses FILE / first_body FILE
#                              status lines in a raw exchange / the body of its first response
#   finish                     prints the summary; the exit status is 1 when anything failed
#
# Needs: bash 4, curl, jq, node (with node_modules from scripts/setup.sh).

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT" || exit 1
SERVER=${SERVER:-$ROOT/build/server/featureline-server}
SHARED=${SHARED:-$ROOT/../shared}
MESHES="$SHARED/data/meshes"
VR="$HERE/validate_response.mjs"
VG="$HERE/validate_gltf.mjs"
JOBS=${JOBS:-$(nproc 2>/dev/null || echo 2)}

PASSED=0
FAILED=0
FAILED_NAMES=()
declare -A SRV_BASE=() SRV_PID=() SRV_LOG=()
BG_PIDS=()
VAL_COUNT=0
declare -A VAL_SEEN=()

pass() { PASSED=$((PASSED + 1)); echo "ok   $1"; }
fail() {
  local name=$1; shift
  FAILED=$((FAILED + 1)); FAILED_NAMES+=("$name")
  echo "FAIL $name"
  local line
  for line in "$@"; do printf '       | %s\n' "$line"; done
}
check() {
  local name=$1; shift
  if "$@"; then pass "$name"; else fail "$name" "command: $*"; fi
}
# check_eq NAME GOT WANT
check_eq() {
  if [ "$2" = "$3" ]; then pass "$1"; else fail "$1" "got:  $(printf %s "$2" | head -c 300)" "want: $3"; fi
}

now_s() { date +%s.%N; }
elapsed_since() { awk -v a="$1" -v b="$(now_s)" 'BEGIN { printf "%.2f", b - a }'; }
# less_than A B: A < B for decimals
less_than() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a < b) }'; }

# ---- ports ----------------------------------------------------------------------------------

# Ports are drawn below the kernel's ephemeral range: an outgoing connection of a test running in
# parallel can take any free port inside it between our check and the bind (Redis once failed with
# "Address already in use" that way). Every socket state counts, not only listeners.
free_port_block() {
  local count=$1 low high p q busy
  read -r low high </proc/sys/net/ipv4/ip_local_port_range 2>/dev/null || { low=32768; high=60999; }
  local from=10000 to=$((low - count))
  if [ "$to" -le $((from + 1000)) ]; then from=$((high + 1)); to=$((65535 - count)); fi
  for _ in $(seq 1 100); do
    p=$((from + (RANDOM * 32768 + RANDOM) % (to - from)))
    busy=0
    for q in $(seq "$p" $((p + count - 1))); do ss -Htan "( sport = :$q )" | grep -q . && { busy=1; break; }; done
    [ $busy = 0 ] && { echo "$p"; return 0; }
  done
  return 1
}

# ---- servers --------------------------------------------------------------------------------

start_server() {
  local name=$1; shift
  local port_file="$TMP/$name.port"
  rm -f "$port_file"
  "$SERVER" --port 0 --port-file "$port_file" "$@" >"$TMP/$name.out" 2>"$TMP/$name.log" &
  local pid=$!
  SRV_PID[$name]=$pid
  SRV_LOG[$name]="$TMP/$name.log"
  local start; start=$(now_s)
  local limit=$((20 * FACTOR))
  while :; do
    if ! kill -0 "$pid" 2>/dev/null; then
      fail "server '$name' starts ($*)" "it exited; its stderr:" "$(tail -n 20 "$TMP/$name.log")"
      unset 'SRV_PID[$name]'
      return 1
    fi
    local port=""
    [ -s "$port_file" ] && port=$(tr -dc 0-9 <"$port_file")
    if [ -n "$port" ] && curl -s -o /dev/null --max-time 2 "http://127.0.0.1:$port/healthz"; then
      SRV_BASE[$name]="http://127.0.0.1:$port"
      return 0
    fi
    if ! less_than "$(elapsed_since "$start")" "$limit"; then
      fail "server '$name' starts ($*)" "no answer on /healthz after $limit s"
      return 1
    fi
    sleep 0.1
  done
}

# stop_server NAME [SIGNAL]: signals the server and waits (up to 10 s * FACTOR) for it to exit;
# sets STOP_RC (its exit status, or "timeout") and STOP_SECONDS.
stop_server() {
  local name=$1 sig=${2:-TERM}
  local pid=${SRV_PID[$name]:-}
  STOP_RC=none; STOP_SECONDS=0
  [ -n "$pid" ] || return 0
  local start; start=$(now_s)
  kill "-$sig" "$pid" 2>/dev/null
  local limit=$((10 * FACTOR))
  while kill -0 "$pid" 2>/dev/null && less_than "$(elapsed_since "$start")" "$limit"; do sleep 0.05; done
  STOP_SECONDS=$(elapsed_since "$start")
  if kill -0 "$pid" 2>/dev/null; then
    STOP_RC=timeout
    kill -KILL "$pid" 2>/dev/null
  fi
  wait "$pid" 2>/dev/null
  local rc=$?
  [ "$STOP_RC" = timeout ] || STOP_RC=$rc
  unset 'SRV_PID[$name]'
}

# Kills what this script started (servers and background requests), by process id.
# stop_pids TRIES PID...: SIGTERM to each, up to TRIES x 0.1 s for all to exit, then SIGKILL.
# in_private_mounts COMMAND...: COMMAND in a mount namespace of its own (its mounts are seen by
# nobody else and go with it). unshare --propagation private makes / private, which fails
# ("cannot change root filesystem propagation") where / is not a mount point: a chroot into a
# folder, as on a fresh machine made by debootstrap. There COMMAND runs chrooted into a
# recursive bind mount of / made private in the new namespace, from the same directory.
root_is_mount_point() { awk '$5 == "/" { found = 1 } END { exit !found }' /proc/self/mountinfo; }
in_private_mounts() {
  if root_is_mount_point; then
    unshare --mount --propagation private "$@"
    return
  fi
  local rebound rc
  rebound=$(mktemp -d /var/tmp/featureline-root.XXXXXX)
  unshare --mount --propagation unchanged /bin/bash -c '
    mount --rbind / "$1" && mount --make-rprivate "$1" || exit 97
    rebound=$1 dir=$2; shift 2
    exec chroot "$rebound" /bin/bash -c "cd \"\$0\" && exec \"\$@\"" "$dir" "$@"' _ "$rebound" "$PWD" "$@"
  rc=$?
  rmdir "$rebound"
  return $rc
}

stop_pids() {
  local tries=$1 pid; shift
  for pid in "$@"; do kill -TERM "$pid" 2>/dev/null; done
  for _ in $(seq 1 "$tries"); do
    local alive=0
    for pid in "$@"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [ $alive = 0 ] && break
    sleep 0.1
  done
  for pid in "$@"; do kill -KILL "$pid" 2>/dev/null; done
}

cleanup() {
  local pid
  for pid in "${BG_PIDS[@]}"; do kill "$pid" 2>/dev/null; done
  stop_pids 30 "${SRV_PID[@]}"
  wait 2>/dev/null
  if [ -n "${TMP:-}" ] && [ -d "$TMP" ]; then
    if [ "${KEEP_TMP:-0}" = 1 ]; then echo "(kept $TMP)"; else rm -rf "$TMP"; fi
  fi
}

# ---- requests -------------------------------------------------------------------------------

http() {
  local out=$1; shift
  STATUS=$(curl -s --max-time "$CURL_MAX" -o "$out" -D "$out.hdr" -w '%{http_code}' "$@" 2>"$out.curlerr")
  [ -n "$STATUS" ] || STATUS=000
}

header() {
  grep -i "^$2:" "$1.hdr" 2>/dev/null | tail -n 1 | cut -d: -f2- | tr -d '\r' | sed 's/^ *//'
}

error_code() { jq -r '.error.code // empty' "$1" 2>/dev/null; }

# expect NAME STATUS CODE METHOD PATH OUT
expect() {
  local name=$1 want=$2 code=$3 method=$4 path=$5 out=$6
  if [ "$STATUS" = "$want" ]; then
    pass "$name: $want"
  else
    fail "$name: $want" "got status $STATUS" "body: $(head -c 300 "$out" 2>/dev/null)" "$(cat "$out.curlerr" 2>/dev/null)"
  fi
  if [ "$code" != - ]; then
    check_eq "$name: error code $code" "$(error_code "$out")" "$code"
  fi
  if [ "$STATUS" != 000 ] && [ -s "$out" ]; then
    validate_json "$name: body matches the contract" "$method" "$path" "$STATUS" "$out"
  fi
}

# ---- raw connections ------------------------------------------------------------------------

raw_send() {
  local port=$1 out=$2 pause=$3 head=$4 body=$5
  (
    trap '' PIPE
    exec 3<>"/dev/tcp/127.0.0.1/$port" || exit 1
    if [ "$pause" = 0 ]; then printf '%s%s' "$head" "$body" >&3 2>/dev/null
    else printf '%s' "$head" >&3 2>/dev/null; sleep "$pause"; printf '%s' "$body" >&3 2>/dev/null; fi
    t0=$(now_s)
    timeout $((10 * FACTOR)) cat <&3 >"$out"
    rc=$?
    if [ $rc = 124 ]; then echo timeout; else elapsed_since "$t0"; fi
  ) >"$out.close" 2>/dev/null
  CLOSE_S=$(cat "$out.close")
  CLOSE_S=${CLOSE_S:-no-connection}
}
first_body() {  # the body of the first response in a raw exchange (by its Content-Length)
  perl -e 'local $/; my $s = <STDIN>; my ($h, $b) = split /\r\n\r\n/, $s, 2;
           my ($n) = $h =~ /^Content-Length:\s*(\d+)/mi; print substr($b // "", 0, $n // 0)' <"$1"
}
responses() { LC_ALL=C grep -aoE 'HTTP/1\.[01] [0-9]{3} ' "$1" | wc -l; }  # status lines, wherever they start

# ---- validator queue ------------------------------------------------------------------------

queue_validation() {  # queue_validation NAME DEDUPE_KEY ARGS...
  local name=$1 key=$2; shift 2
  if [ -n "$key" ] && [ -n "${VAL_SEEN[$key]:-}" ]; then return 0; fi
  [ -n "$key" ] && VAL_SEEN[$key]=1
  VAL_COUNT=$((VAL_COUNT + 1))
  local dir="$TMP/val"
  mkdir -p "$dir"
  printf '%s\n' "$name" >"$dir/$VAL_COUNT.name"
  printf '%s\n' "$@" >"$dir/$VAL_COUNT.args"
}

# The body is copied (later requests may reuse the file name); identical bodies checked against
# the same operation and status are validated once.
validate_json() {
  local name=$1 method=$2 path=$3 status=$4 file=$5
  local copy="$TMP/val/body.$((VAL_COUNT + 1)).json"
  mkdir -p "$TMP/val"
  local template
  template=$(printf %s "$path" | sed -E 's/\?.*//; s#/v1/meshes/[^/]+#/v1/meshes/{mesh_id}#')
  local key="json $method $template $status $(md5sum <"$file" | cut -c1-32)"
  [ -n "${VAL_SEEN[$key]:-}" ] && return 0
  cp "$file" "$copy"
  queue_validation "$name" "$key" "$VR" "$method" "$template" "$status" "$copy"
}
validate_schema() {
  local copy="$TMP/val/body.$((VAL_COUNT + 1)).json"
  mkdir -p "$TMP/val"; cp "$3" "$copy"
  queue_validation "$1" "" "$VR" --schema "$2" "$copy"
}
validate_request() {
  local copy="$TMP/val/body.$((VAL_COUNT + 1)).json"
  mkdir -p "$TMP/val"; cp "$4" "$copy"
  queue_validation "$1" "" "$VR" --request "$2" "$3" "$copy"
}
validate_gltf() {
  local ext=${2##*.}
  local copy="$TMP/val/body.$((VAL_COUNT + 1)).$ext"
  mkdir -p "$TMP/val"; cp "$2" "$copy"
  queue_validation "$1" "" "$VG" "$copy"
}

run_validations() {
  local dir="$TMP/val"
  [ "$VAL_COUNT" -gt 0 ] || return 0
  echo "# running $VAL_COUNT validator calls, $JOBS at a time"
  # xargs runs them in parallel; each writes NAME.out and NAME.rc.
  seq 1 "$VAL_COUNT" | xargs -P "$JOBS" -I{} bash -c '
    mapfile -t args <"$1/$2.args"
    node "${args[@]}" >"$1/$2.out" 2>&1
    echo $? >"$1/$2.rc"' _ "$dir" {}
  local i
  for i in $(seq 1 "$VAL_COUNT"); do
    local name; name=$(cat "$dir/$i.name")
    if [ "$(cat "$dir/$i.rc" 2>/dev/null)" = 0 ]; then
      pass "$name"
    else
      local out; out=$(head -n 12 "$dir/$i.out")
      fail "$name" "validator: $(tr '\n' ' ' <"$dir/$i.args")" "$out"
    fi
  done
}

finish() {
  echo
  echo "$PASSED passed, $FAILED failed"
  if [ "$FAILED" -gt 0 ]; then
    local n
    for n in "${FAILED_NAMES[@]}"; do echo "  failed: $n"; done
    return 1
  fi
  return 0
}

# time_factor SERVER: how much to scale every time limit: $TIME_FACTOR when set, 3 for a
# sanitizer build of SERVER (about 3x slower), else 1.
time_factor() {
  if [ -n "${TIME_FACTOR:-}" ]; then echo "$TIME_FACTOR"
  elif ldd "$1" 2>/dev/null | grep -qE 'libasan|libubsan|libtsan'; then echo 3
  else echo 1; fi
}
