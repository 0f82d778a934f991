#!/usr/bin/env bash
# Memory of featureline-server under hostile clients (header floods, stalled uploads, files that
# expand, JSON bodies of tiny containers, many uploads into a small cache, deletes): prints
# resident memory
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
expanding() {  # expanding LABEL FILE: one upload of FILE, its status and time in the row
  local start answer
  start=$(date +%s.%N)
  answer=$(curl -s -o /dev/null -w '%{http_code}' --max-time 60 --data-binary @"$2" -H 'Content-Type: application/octet-stream' "$base/v1/meshes")
  row "$(awk -v l="$1" -v a="$answer" -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { printf "%s: %s in %.1f s", l, a, e - s }')"
}
hostile=tests/support/hostile_meshes.py
reset_peak; python3 $hostile repeated-ply 400000 "$tmp/r400k.ply"; expanding "PLY, one triangle x 400,000 (5 MB)" "$tmp/r400k.ply"
reset_peak; python3 $hostile repeated-ply 8000000 "$tmp/r8m.ply"; expanding "PLY, one triangle x 8,000,000 (104 MB)" "$tmp/r8m.ply"
reset_peak; python3 $hostile repeated-glb 40 "$tmp/r40.glb"; expanding "GLB, 40 primitives x 10,000 repeats (120 KB)" "$tmp/r40.glb"
reset_peak; python3 $hostile repeated-glb 800 "$tmp/r800.glb"; expanding "GLB, 800 primitives x 10,000 repeats (120 KB)" "$tmp/r800.glb"
reset_peak; python3 $hostile draco 33554432 100 "$tmp/d1.drc"; expanding "Draco declaring 33.5 M faces (80 B)" "$tmp/d1.drc"
reset_peak; python3 $hostile draco 400000 200000 "$tmp/d2.drc"; expanding "Draco declaring 400 k faces, 200 k points (80 B)" "$tmp/d2.drc"
rm -f "$tmp"/*.ply "$tmp"/*.glb "$tmp"/*.drc
reset_peak
python3 -c "
import sys
n = (4 * 1024 * 1024 - 20) // 3
sys.stdout.write('{\"lines\": [' + ','.join(['{}'] * n) + ']}')" >"$tmp/containers.json"
sample=$(curl -s --data-binary @samples/ridge_field.off -H 'Content-Type: model/x-off' "$base/v1/meshes" | jq -r .mesh_id)
bodies=()
for i in $(seq 1 64); do
  curl -s -o /dev/null --max-time 60 -H 'Content-Type: application/json' --data-binary @"$tmp/containers.json" \
    "$base/v1/meshes/$sample/feature-lines" &
  bodies+=($!)
done
wait "${bodies[@]}"  # not the server
row "64 concurrent JSON bodies of 4 MiB of {} (413/503)"
sleep 6  # the sweeper trims what request bodies held within 5 s
reset_peak; row "6 s later"
curl -s -o /dev/null -X DELETE "$base/v1/meshes/$sample"
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
