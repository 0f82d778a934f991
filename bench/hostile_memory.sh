#!/usr/bin/env bash
# Memory of featureline-server under hostile clients (header floods, stalled uploads, many
# uploads into a small cache, deletes): prints resident memory
# (VmRSS) after each case and its peak during the case (VmHWM, reset before each case).
#   bash bench/hostile_memory.sh [SERVER]        (default build/server/featureline-server)
# The server runs with --cache-mb 64 and its other defaults (256 MiB uploads, 512 MiB upload
# buffer, 64 connection workers). Traffic goes to 127.0.0.1 only; every client is bounded in time.
set -euo pipefail
cd "$(dirname "$0")/.."
server=${1:-build/server/featureline-server}
meshes=${SHARED:-../shared}/data/meshes
tmp=$(mktemp -d)
"$server" --port 0 --port-file "$tmp/port" --cache-mb 64 --quiet >"$tmp/out" 2>"$tmp/err" &
pid=$!
trap 'kill $pid 2>/dev/null; wait $pid 2>/dev/null; rm -rf "$tmp"' EXIT
for _ in $(seq 1 100); do [ -s "$tmp/port" ] && break; sleep 0.1; done
port=$(cat "$tmp/port")
base=http://127.0.0.1:$port
until curl -s -o /dev/null "$base/healthz"; do sleep 0.1; done

mb() { awk -v k="$1" '$1 == k":" { printf "%.0f", $2 / 1024 }' "/proc/$pid/status"; }
reset_peak() { echo 5 >"/proc/$pid/clear_refs"; }
row() { printf '%-58s %8s %8s\n' "$1" "$(mb VmRSS)" "$(mb VmHWM)"; }
send() { timeout "$1" bash -c "exec 3<>/dev/tcp/127.0.0.1/$port; cat >&3; timeout 2 cat <&3 >/dev/null" 2>/dev/null || true; }

printf '%-58s %8s %8s\n' case "RSS MB" "peak MB"
reset_peak; row "idle"
reset_peak
{ printf 'GET /healthz HTTP/1.1\r\nHost: x\r\n'; yes $'X-Flood: b\r' | head -n 1000000; printf '\r\n'; } | send 20 || true
row "1,000,000 request headers (431 after 100)"
reset_peak
{ printf 'GET /healthz HTTP/1.1\r\nX-Long: '; head -c 268435456 /dev/zero | tr '\0' a; printf '\r\n\r\n'; } | send 20 || true
row "one 256 MB header line (431 after 64 KiB)"
reset_peak
uploads=()
for i in 1 2 3 4; do
  { printf 'POST /v1/meshes HTTP/1.1\r\nHost: x\r\nContent-Type: model/obj\r\nContent-Length: 209715200\r\n\r\n'
    head -c 104857600 /dev/zero; sleep 3; } | send 15 || true &
  uploads+=($!)
done
sleep 2.5
row "4 uploads of 200 MB stalled after 100 MB (2 get 503)"
wait "${uploads[@]}"
reset_peak
ids=()
for i in $(seq 1 12); do
  id=$(curl -s --data-binary @"$meshes/bunny_closed.off" -H 'Content-Type: model/x-off' "$base/v1/meshes" | jq -r '.mesh_id // empty')
  [ -n "$id" ] && ids+=("$id")
done
row "12 uploads of bunny_closed (70k triangles) into a 64 MB cache"
for id in "${ids[@]}"; do curl -s -o /dev/null -X DELETE "$base/v1/meshes/$id"; done
sleep 6  # the sweeper returns freed memory within 5 s
reset_peak; row "after deleting every session (malloc_trim)"
echo "cache: $(curl -s "$base/metrics" | grep -E '^featureline_cache_(bytes|evictions_total) ' | tr '\n' ' ')"
