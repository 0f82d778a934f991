#!/usr/bin/env bash
# The main job: set up, build, show the CLI on the bundled sample, then serve it over HTTP with
# the browser page at / (Ctrl-C stops the server).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${BUILD_DIR:-build}
sample=samples/ridge_field.off
keys=$(cat samples/ridge_field.keys)
echo "== featureline detect $sample --keys $keys"
"$build/cli/featureline" detect "$sample" --keys "$keys" |
  jq -c '{keys, initial: {method: .initial.method, vertices: (.initial.vertices|length), length: .initial.length},
          refined: {points: (.refined.points|length), length: .refined.length}, timings_ms: .stats.timings_ms}'
echo "== featureline-server with $sample preloaded"
port=${PORT:-8080}
# Uploads are kept on disk, so sessions survive restarts (DATA_DIR=... for another folder).
data_dir=${DATA_DIR:-${XDG_STATE_HOME:-$HOME/.local/state}/featureline/data}
mkdir -p "$data_dir"
sample_path="$PWD/$sample"
"$build/server/featureline-server" --port "$port" --preload "$sample" --data-dir "$data_dir" | while IFS= read -r line; do
  echo "$line"
  case "$line" in
    "preloaded "*)
      id=${line##* }
      echo "  curl -s -X POST http://127.0.0.1:$port/v1/meshes/$id/feature-lines -H 'Content-Type: application/json' -d '{\"keys\": [${keys//,/, }]}'"
      echo "  curl -s --data-binary @$sample_path -H 'Content-Type: application/octet-stream' http://127.0.0.1:$port/v1/meshes"
      ;;
  esac
done
