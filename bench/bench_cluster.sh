#!/usr/bin/env bash
# The cluster on loopback: scripts/cluster.sh with 3 replicas, then
#  1. lines/s and p50/p99 at 32, 128 and 512 connections through nginx vs one replica directly
#     (build/bench/bench_cluster);
#  2. the time to the first answer for a mesh whose replica died: igea (268,686 triangles)
#     uploaded through nginx, a line computed, its replica SIGKILLed, the same line asked again
#     through nginx (failover + rebuild from Redis), 3 times from a restarted cluster, against
#     the same line on the live, warm replica.
# Prints the machine's load average before and after: figures taken under load are not final.
#
#   bench/bench_cluster.sh [--port P] [--seconds S] [--failover-only]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
port=28400 seconds=5 load=1
while [ $# -gt 0 ]; do
  case "$1" in
    --failover-only) load=0; shift ;;
    --port) port=$2; shift 2 ;;
    --seconds) seconds=$2; shift 2 ;;
    *) echo "usage: bench/bench_cluster.sh [--port P] [--seconds S]" >&2; exit 2 ;;
  esac
done
bench=build/bench/bench_cluster
igea=../shared/data/meshes/igea.ply
[ -x "$bench" ] || { echo "no $bench: cmake --build build --target bench_cluster" >&2; exit 1; }
[ -f "$igea" ] || { echo "missing $igea" >&2; exit 1; }
state=$(mktemp -d "${TMPDIR:-/tmp}/featureline-bench-cluster.XXXXXX")
cluster() { scripts/cluster.sh "$1" --port "$port" --state-dir "$state" "${@:2}"; }
trap 'cluster down --wipe >/dev/null 2>&1; rm -rf "$state"' EXIT
front="http://127.0.0.1:$port"

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg) ($(nproc) cores)"
cluster up --replicas 3 -- --quiet >/dev/null
if [ "$load" = 1 ]; then
  echo "== lines through nginx vs replica 1 directly (port $((port + 2)))"
  "$bench" --front "$port" --replica $((port + 2)) --seconds "$seconds"
fi

echo
echo "== time to the first answer after the mesh's replica died (igea, 268,686 triangles)"
id=$(curl -s --data-binary @"$igea" -H 'Content-Type: application/octet-stream' "$front/v1/meshes" | jq -r .mesh_id)
body='{"keys": [1000, 1001]}'  # a short line: the time is the failover and the rebuild
line() {  # prints: seconds status replica(s) that answered
  curl -s -o /dev/null -D "$state/h" -w '%{time_total} %{http_code}' -X POST -H 'Content-Type: application/json' \
    -d "$body" "$front/v1/meshes/$id/feature-lines" >"$state/t"
  echo "$(cat "$state/t") $(grep -i '^X-Featureline-Replica:' "$state/h" | tr -d '\r' | cut -d' ' -f2- | tr -d ' ')"
}
# Every run starts from empty caches (the whole cluster restarted; Redis keeps the upload), so
# the first line is a rebuild on the id's replica, and the line after its SIGKILL a rebuild on
# the next replica of the ring (the replica that took the upload no longer has it in memory).
printf '%-5s %-22s %-22s %-22s %s\n' run "first after restart s" "warm line s" "after SIGKILL s" "answered by (status)"
for run in 1 2 3; do
  cluster down >/dev/null
  cluster up --replicas 3 -- --quiet >/dev/null
  read -r first_s _ _ < <(line)
  read -r warm_s _ replica < <(line)
  victim_port=${replica##*:}
  victim_pid=$(cluster status | awk -v p="$victim_port" '$1 == "replica" && $4 == p { print $3 }')
  kill -KILL "$victim_pid"
  for _ in $(seq 1 50); do kill -0 "$victim_pid" 2>/dev/null || break; sleep 0.1; done
  read -r after_s status after_replica < <(line)
  printf '%-5s %-22s %-22s %-22s %s\n' "$run" "$first_s" "$warm_s ($victim_port)" "$after_s" "$after_replica ($status)"
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
