#!/usr/bin/env bash
# The main job: set up, build, and detect a feature line on the bundled sample mesh.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${BUILD_DIR:-build}
sample=samples/ridge_field.off
keys=$(cat samples/ridge_field.keys)
echo "== featureline info $sample"
"$build/cli/featureline" info "$sample" | jq -c '{vertices, faces, components, mean_edge, curvature}'
echo "== featureline detect $sample --keys $keys"
"$build/cli/featureline" detect "$sample" --keys "$keys" --out "$build/sample_line.json"
jq -c '{keys, initial: {method: .initial.method, vertices: (.initial.vertices|length), length: .initial.length},
        refined: {points: (.refined.points|length), length: .refined.length}, stats: .stats.timings_ms}' "$build/sample_line.json"
"$build/cli/featureline" detect "$sample" --keys "$keys" --out "$build/sample_line.glb"
echo "wrote $build/sample_line.json and $build/sample_line.glb (mesh + initial and refined lines)"
