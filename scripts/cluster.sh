#!/usr/bin/env bash
# The cluster on one machine without Docker: nginx (Debian's) in front on port P,
# Redis as the shared upload store, and N featureline-server replicas on loopback ports.
#
#   scripts/cluster.sh up     --port P [--replicas N] [--wipe] [--state-dir D] [-- SERVER FLAGS...]
#   scripts/cluster.sh status --port P [--state-dir D]
#   scripts/cluster.sh down   --port P [--wipe] [--state-dir D]
#
# Ports: Redis on P+1, replica I (1..N) on P+1+I (each checked free before it starts).
# State (pid files, logs, the rendered nginx.conf, Redis' append-only file and password) lives in
# D = ${XDG_STATE_HOME:-~/.local/state}/featureline/cluster-P; Redis' data persists across
# down/up unless --wipe. `up` starts only what is not running (it also restarts a dead replica)
# and stops replicas beyond --replicas that an earlier `up` started. A port held by another
# program is an error naming it; nginx workers left by a killed nginx master are stopped first.
# status prints one line per process: "nginx PID PORT", "redis PID PORT", "replica I PID PORT"
# (PID "-" when not running) for every replica started, and "nginx-orphan PID PORT" for each
# worker of a dead nginx master; it exits 0 when all run, 1 when some do not, 3 when none does.
# Started as root, nginx's workers run as nobody:nogroup (NGINX_USER overrides; root, with a
# warning, where nobody cannot reach their folder), with their
# temporary files in /var/tmp/featureline/nginx-P, which they can reach.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

usage() { sed -n '4,8p' "$0" | sed 's/^# *//' >&2; exit 2; }
die() { echo "cluster: $*" >&2; exit 1; }

command=${1:-}; [ $# -gt 0 ] && shift
port="" replicas=3 wipe=0 state="" server_flags=()
while [ $# -gt 0 ]; do
  case "$1" in
    --port) port=${2:-}; shift 2 ;;
    --replicas) replicas=${2:-}; shift 2 ;;
    --wipe) wipe=1; shift ;;
    --state-dir) state=${2:-}; shift 2 ;;
    --) shift; server_flags=("$@"); break ;;
    *) usage ;;
  esac
done
case "$command" in up|status|down) ;; *) usage ;; esac
[[ "$port" =~ ^[0-9]+$ ]] && [ "$port" -ge 1024 ] && [ "$port" -le 65000 ] || die "--port must be a number 1024-65000"
[[ "$replicas" =~ ^[0-9]+$ ]] && [ "$replicas" -ge 1 ] && [ "$replicas" -le 32 ] || die "--replicas must be 1-32"
state=${state:-${XDG_STATE_HOME:-$HOME/.local/state}/featureline/cluster-$port}
server_bin=${SERVER:-$root/build/server/featureline-server}
nginx_bin=${NGINX:-/usr/sbin/nginx}
redis_bin=${REDIS_SERVER:-/usr/bin/redis-server}
max_upload_mb=256
redis_port=$((port + 1))

# ---- processes ----------------------------------------------------------------------------------

# The live pid recorded for NAME whose command line contains WORD, or nothing (a stale pid file,
# or a pid the kernel has since given to another program, is not ours).
pid_of() {
  local file="$state/pids/$1.pid" pid
  [ -s "$file" ] || return 0
  pid=$(tr -dc 0-9 <"$file")
  [ -n "$pid" ] && [ -r "/proc/$pid/cmdline" ] && tr '\0' ' ' <"/proc/$pid/cmdline" | grep -q -- "$2" && echo "$pid"
  return 0
}
replica_port() { echo $((port + 1 + $1)); }
# The highest replica number started: the count recorded by the last `up`, or a replica pid file
# beyond it (an `up` with fewer replicas that was interrupted); status and down cover them all.
started_replicas() {
  local n=0 file i
  [ -s "$state/replicas" ] && n=$(tr -dc 0-9 <"$state/replicas")
  for file in "$state"/pids/replica-*.pid; do
    [ -e "$file" ] || continue
    i=${file##*/replica-}; i=${i%.pid}
    [[ "$i" =~ ^[0-9]+$ ]] && [ "$i" -gt "${n:-0}" ] && n=$i
  done
  echo "${n:-0}"
}

port_free() { ! ss -Htln "sport = :$1" 2>/dev/null | grep -q .; }
# What holds a port, for errors: "pid 123 (nginx)" when ss may show it.
port_holder() {
  local who; who=$(ss -Htlnp "sport = :$1" 2>/dev/null | grep -o 'users:(([^)]*' | head -n 1 | sed 's/users:((//')
  echo "${who:-a process this user cannot see}"
}

# nginx's master runs in a session of its own (it daemonizes with setsid) and its workers stay
# in it: when the master is killed, the workers live on, holding the port. They are found by the
# session id, which is the dead master's recorded pid, and by their title; nothing else is.
nginx_orphans() {
  local master file pid stat
  file="$state/pids/nginx.pid"
  [ -s "$file" ] || return 0
  master=$(tr -dc 0-9 <"$file")
  [ -n "$master" ] && [ -z "$(pid_of nginx nginx)" ] || return 0
  for stat in /proc/[0-9]*/stat; do
    pid=${stat#/proc/}; pid=${pid%/stat}
    # Fields after the command: state ppid pgrp session ...
    read -r -a fields < <(sed 's/^.*) //' "$stat" 2>/dev/null) || continue
    [ "${fields[3]:-}" = "$master" ] || continue
    tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null | grep -q '^nginx: ' && echo "$pid"
  done
  return 0
}
stop_nginx_orphans() {
  local pid
  for pid in $(nginx_orphans); do stop_pid "nginx worker (its master is gone)" "$pid"; done
}

# wait_until SECONDS COMMAND...: polls every 0.1 s, bounded.
wait_until() {
  local limit=$(($1 * 10)) i; shift
  for ((i = 0; i < limit; i++)); do "$@" && return 0; sleep 0.1; done
  return 1
}
http_ok() { curl -s -o /dev/null --max-time 2 -f "http://127.0.0.1:$1/healthz"; }
# Redis wants a password (on a shared machine any local user can reach a loopback port): made
# once, kept in the state folder readable by this user only, given to Redis on its standard
# input and to the replicas and redis-cli in their environment, never on a command line.
redis_password_file() { echo "$state/redis-password"; }
ensure_redis_password() {
  local file; file=$(redis_password_file)
  [ -s "$file" ] && return 0
  (umask 077; head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' >"$file.part" && mv "$file.part" "$file")
}
redis_password() { cat "$(redis_password_file)"; }
redis_ok() { REDISCLI_AUTH=$(redis_password) redis-cli -h 127.0.0.1 -p "$redis_port" ping 2>/dev/null | grep -q PONG; }

# stop_pid NAME PID: TERM, up to 10 s, then KILL; waits until the process is gone.
stop_pid() {
  local name=$1 pid=$2 i
  kill -TERM "$pid" 2>/dev/null || return 0
  for ((i = 0; i < 100; i++)); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$pid" 2>/dev/null; then
    echo "cluster: $name (pid $pid) ignored SIGTERM for 10 s; killing it" >&2
    kill -KILL "$pid" 2>/dev/null
    for ((i = 0; i < 50; i++)); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  fi
}

start_redis() {
  [ -n "$(pid_of redis redis-server)" ] && return 0
  port_free "$redis_port" || die "port $redis_port (Redis) is taken by $(port_holder "$redis_port")"
  mkdir -p "$state/redis"
  ensure_redis_password
  printf 'requirepass "%s"\n' "$(redis_password)" |
    "$redis_bin" "$root/deploy/redis.conf" --port "$redis_port" --bind 127.0.0.1 --protected-mode yes --dir "$state/redis" \
      --daemonize yes --pidfile "$state/pids/redis.pid" --logfile "$state/logs/redis.log" -
  wait_until 10 redis_ok || die "Redis did not answer on port $redis_port (see $state/logs/redis.log)"
}

start_replica() {
  local i=$1 p; p=$(replica_port "$1")
  [ -n "$(pid_of "replica-$i" featureline-server)" ] && return 0
  port_free "$p" || die "port $p (replica $i) is taken by $(port_holder "$p")"
  [ -x "$server_bin" ] || die "no server at $server_bin (build it: scripts/setup.sh)"
  # setsid: the replica outlives this script and its terminal; its pid is recorded for down.
  # nginx holds the clients and opens a connection per request in flight: each replica takes up
  # to 512 of them (256 workers) and still refuses engine work beyond its queue with 503.
  FEATURELINE_REDIS_PASSWORD=$(redis_password) setsid "$server_bin" --host 127.0.0.1 --port "$p" --store "redis://127.0.0.1:$redis_port" \
    --max-upload-mb "$max_upload_mb" --http-threads 256 "${server_flags[@]}" \
    </dev/null >"$state/logs/replica-$i.out" 2>>"$state/logs/replica-$i.log" &
  echo $! >"$state/pids/replica-$i.pid"
}

# Workers write request bodies and buffered answers there: as root they run as an unprivileged
# user, who may not traverse the state folder (often under a private home or mktemp folder).
# On disk, not under /run: that is a small tmpfs on many systems, and bodies reach 256 MB.
nginx_temp() {
  if [ "$(id -u)" = 0 ]; then echo "/var/tmp/featureline/nginx-$port"; else echo "$state/nginx-temp"; fi
}

# The workers' user, as root: nobody, when nobody can reach the temporary folder; where a
# folder above it is closed to others (a chroot whose root is 0700), root, with a warning.
nginx_workers_user() {
  [ "$(id -u)" = 0 ] && [ -z "${NGINX_USER:-}" ] || { echo "${NGINX_USER:-}"; return 0; }
  if runuser -u nobody -- test -w "$(nginx_temp)" 2>/dev/null; then echo "nobody nogroup"; return 0; fi
  echo "cluster: nginx's workers run as root: user nobody cannot reach $(nginx_temp) (a folder above it is closed to others)" >&2
  echo root
}

render_nginx_conf() {
  local servers=() i
  for ((i = 1; i <= replicas; i++)); do servers+=("127.0.0.1:$(replica_port "$i")"); done
  NGINX_USER=$(nginx_workers_user) NGINX_TEMP=$(nginx_temp) \
    "$root/deploy/render-nginx-conf.sh" "$state" "127.0.0.1:$port" "$max_upload_mb" "${servers[@]}" >"$state/nginx.conf"
}

start_nginx() {
  # Reachable by the workers whatever the caller's umask (077 under some CI shells).
  (umask 022 && mkdir -p "$(nginx_temp)")
  [ "$(id -u)" = 0 ] && [ -z "${NGINX_USER:-}" ] && chown nobody:nogroup "$(nginx_temp)"
  render_nginx_conf
  # -e: the error log from the first line on (nginx would otherwise open /var/log/nginx first).
  "$nginx_bin" -t -q -p "$state" -e "$state/logs/nginx-error.log" -c "$state/nginx.conf" ||
    die "nginx -t refused $state/nginx.conf"
  local pid; pid=$(pid_of nginx nginx)
  if [ -n "$pid" ]; then
    kill -HUP "$pid"  # reload: the replica list may have changed
    return 0
  fi
  stop_nginx_orphans
  port_free "$port" || die "port $port (nginx) is taken by $(port_holder "$port")"
  rm -f "$state/nginx.pid"
  "$nginx_bin" -p "$state" -e "$state/logs/nginx-error.log" -c "$state/nginx.conf"
  wait_until 10 test -s "$state/nginx.pid" || die "nginx did not start (see $state/logs/nginx-error.log)"
  cp "$state/nginx.pid" "$state/pids/nginx.pid"
}

# ---- commands ---------------------------------------------------------------------------------

status() {
  [ -d "$state/pids" ] || { echo "cluster: nothing started on port $port ($state)" >&2; return 3; }
  local n; n=$(started_replicas)
  local running=0 total=$((n + 2)) pid i
  pid=$(pid_of nginx nginx); echo "nginx ${pid:--} $port"; [ -n "$pid" ] && running=$((running + 1))
  for pid in $(nginx_orphans); do echo "nginx-orphan $pid $port"; done
  pid=$(pid_of redis redis-server); echo "redis ${pid:--} $redis_port"; [ -n "$pid" ] && running=$((running + 1))
  for ((i = 1; i <= n; i++)); do
    pid=$(pid_of "replica-$i" featureline-server)
    echo "replica $i ${pid:--} $(replica_port "$i")"
    [ -n "$pid" ] && running=$((running + 1))
  done
  [ "$running" = "$total" ] && return 0
  [ "$running" = 0 ] && return 3
  return 1
}

up() {
  command -v "$nginx_bin" >/dev/null || die "no nginx at $nginx_bin (scripts/setup.sh installs it)"
  command -v "$redis_bin" >/dev/null || die "no redis-server at $redis_bin (scripts/setup.sh installs it)"
  if [ "$wipe" = 1 ]; then
    [ -z "$(pid_of redis redis-server)" ] || die "--wipe needs the cluster down first"
    rm -rf "$state/redis" "$(redis_password_file)"
  fi
  mkdir -p "$state/pids" "$state/logs"
  local i surplus; surplus=$(started_replicas)
  start_redis
  for ((i = 1; i <= replicas; i++)); do start_replica "$i"; done
  for ((i = 1; i <= replicas; i++)); do
    wait_until 30 http_ok "$(replica_port "$i")" || die "replica $i did not answer on port $(replica_port "$i") (see $state/logs/replica-$i.log)"
  done
  start_nginx
  wait_until 10 http_ok "$port" || die "nginx did not answer on port $port (see $state/logs/nginx-error.log)"
  # nginx no longer routes to replicas beyond --replicas (reloaded above): stop them.
  for ((i = replicas + 1; i <= surplus; i++)); do stop_replica "$i"; done
  echo "$replicas" >"$state/replicas"
  status
}

stop_replica() {
  local pid; pid=$(pid_of "replica-$1" featureline-server)
  [ -n "$pid" ] && stop_pid "replica $1" "$pid"
  rm -f "$state/pids/replica-$1.pid"
}

down() {
  [ -d "$state/pids" ] || { echo "cluster: nothing started on port $port"; return 0; }
  local n; n=$(started_replicas)
  local pid i
  # The front first (no new requests), then the replicas, Redis last (its AOF is fsynced on exit).
  pid=$(pid_of nginx nginx); [ -n "$pid" ] && stop_pid nginx "$pid"
  stop_nginx_orphans
  for ((i = 1; i <= n; i++)); do stop_replica "$i"; done
  pid=$(pid_of redis redis-server); [ -n "$pid" ] && stop_pid redis "$pid"
  rm -rf "$state/pids"
  [ "$(id -u)" = 0 ] && rm -rf "$(nginx_temp)"
  [ "$wipe" = 1 ] && rm -rf "$state/redis" "$(redis_password_file)"
  # Done only when nothing answers on the front port any more.
  port_free "$port" || die "down: port $port is still held by $(port_holder "$port"), not a process this cluster recorded"
  echo "cluster: down (port $port)$([ "$wipe" = 1 ] && echo ", Redis data wiped")"
}

"$command"
