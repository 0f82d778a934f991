#!/usr/bin/env bash
# Lines through the loopback cluster (scripts/cluster.sh, 3 replicas, nginx, Redis) while Redis
# is up, then while it is stopped with SIGSTOP (a hung store), for S seconds each: 8 curl loops
# asking 2-key lines on 6 cached meshes (samples/ridge_field.off uploaded 6 times). Prints lines
# per second, the median and 99th percentile of curl's total time, and the answers other than 200.
# SERVER=... picks the server binary (as scripts/cluster.sh does). Figures depend on the machine's
# load: the load average is printed before and after.
#
#   bench/store_faults.sh [--port P] [--seconds S]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
port=28500 seconds=8
while [ $# -gt 0 ]; do
  case "$1" in
    --port) port=$2; shift 2 ;;
    --seconds) seconds=$2; shift 2 ;;
    *) echo "usage: bench/store_faults.sh [--port P] [--seconds S]" >&2; exit 2 ;;
  esac
done
state=$(mktemp -d "${TMPDIR:-/tmp}/featureline-bench-faults.XXXXXX")
cluster() { scripts/cluster.sh "$1" --port "$port" --state-dir "$state" "${@:2}"; }
redis_pid=""
finish() {
  [ -n "$redis_pid" ] && kill -CONT "$redis_pid" 2>/dev/null
  cluster down --wipe >/dev/null 2>&1 || true
  rm -rf "$state"
}
trap finish EXIT
front="http://127.0.0.1:$port"

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg) ($(nproc) cores)"
cluster up --replicas 3 -- --quiet >/dev/null
redis_pid=$(cluster status | awk '$1 == "redis" { print $2 }')
ids=()
for _ in 1 2 3 4 5 6; do
  ids+=("$(curl -s --data-binary @samples/ridge_field.off -H 'Content-Type: application/octet-stream' "$front/v1/meshes" | jq -r .mesh_id)")
done
body='{"keys": [701, 963]}'

# load NAME: 8 loops for $seconds s (each at most 5000 requests), one "seconds status" line per request.
load() {
  local out="$state/$1" client
  for client in 1 2 3 4 5 6 7 8; do
    (
      end=$(($(date +%s) + seconds))
      for ((n = 0; n < 5000 && $(date +%s) < end; n++)); do
        id=${ids[$(((client + n) % 6))]}
        curl -s -o /dev/null -w '%{time_total} %{http_code}\n' --max-time 10 -X POST -H 'Content-Type: application/json' \
          -d "$body" "$front/v1/meshes/$id/feature-lines"
      done
    ) >"$out.$client" &
  done
  wait
  cat "$out".? >"$out"
}
report() {
  sort -n "$state/$1" | awk -v name="$1" -v s="$seconds" '
    { t[NR] = $1; if ($2 == 200) ok++; else other[$2]++ }
    END {
      others = ""; for (c in other) others = others " " c ":" other[c]
      printf "%-14s %7.1f lines/s  p50 %6.3f s  p99 %6.3f s  not 200:%s\n", name, ok / s, t[int(NR * 0.5) + 1], t[int(NR * 0.99) + 1], (others == "" ? " none" : others)
    }'
}

for id in "${ids[@]}"; do curl -s -o /dev/null -X POST -H 'Content-Type: application/json' -d "$body" "$front/v1/meshes/$id/feature-lines"; done
load redis-up
kill -STOP "$redis_pid"
load redis-stopped
kill -CONT "$redis_pid"
report redis-up
report redis-stopped
for i in 1 2 3; do
  curl -s "http://127.0.0.1:$((port + 1 + i))/metrics" | awk -v r="$i" '$1 == "featureline_store_breaker_openings_total" { printf "replica %s: breaker opened %s times\n", r, $2 }'
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
