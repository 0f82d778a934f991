#!/usr/bin/env bash
# The featureline CLI as a user sees it: JSON on stdout, exit codes, one-line errors.
set -u
fail=0
check() {  # check NAME CONDITION...
  local name=$1; shift
  if "$@"; then echo "ok   $name"; else echo "FAIL $name"; fail=1; fi
}
mesh="$SHARED/data/meshes/fandisk.off"
[ -f "$mesh" ] || { echo "FAIL missing test mesh $mesh (expected in ../shared/data/meshes)"; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$FEATURELINE" info "$mesh" >"$tmp/info.json" 2>"$tmp/err"; rc=$?
check "info exits 0" [ $rc = 0 ]
check "info counts fandisk's vertices" [ "$(jq .vertices "$tmp/info.json")" = 6475 ]
check "info counts fandisk's faces" [ "$(jq .faces "$tmp/info.json")" = 12946 ]
check "info reports one component" [ "$(jq .components "$tmp/info.json")" = 1 ]
check "info reports the default curvature method (jet)" [ "$(jq -r .curvature.method "$tmp/info.json")" = jet ]

"$FEATURELINE" info "$mesh" --curvature cotangent >"$tmp/cot.json" 2>"$tmp/err"; rc=$?
check "info --curvature cotangent exits 0" [ $rc = 0 ]
check "info --curvature cotangent reports method cotangent" [ "$(jq -r .curvature.method "$tmp/cot.json")" = cotangent ]
check "cotangent has no jet radius" [ "$(jq .curvature.radius "$tmp/cot.json")" = 0 ]
"$FEATURELINE" info "$mesh" --curvature quadric >"$tmp/out" 2>"$tmp/err"; rc=$?
check "unknown --curvature exits 2" [ $rc = 2 ]
check "unknown --curvature: the error comes first, then the usage" [ "$(head -n 1 "$tmp/err")" = "featureline: --curvature must be jet or cotangent" ]
check "unknown --curvature: nothing on stdout" [ ! -s "$tmp/out" ]
"$FEATURELINE" info "$mesh" --curvature-radius 20 >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--curvature-radius out of range is a usage error (exit 2)" [ $rc = 2 ]
check "--curvature-radius out of range: the range, then a pointer to --help" \
  [ "$(cat "$tmp/err")" = "$(printf '%s\n%s' 'featureline: "--curvature-radius" must be a number from 0 to 12' "Run 'featureline info --help' for usage.")" ]

"$FEATURELINE" detcet "$mesh" >"$tmp/out" 2>"$tmp/err"; rc=$?
check "a mistyped command is a usage error (exit 2)" [ $rc = 2 ]
check "... naming it and the commands there are" \
  [ "$(head -n 1 "$tmp/err")" = 'featureline: no command "detcet"; the commands are detect segment info features options' ]

"$FEATURELINE" detect "$mesh" --keys 10,200 --options '{"snake": {"max_iterations": 1e400}}' >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--options with a number no double holds is a usage error (exit 2)" [ $rc = 2 ]
check "... said in a sentence, without the JSON library's code" \
  [ "$(head -n 1 "$tmp/err")" = "featureline: --options is not valid JSON: number overflow parsing '1e400'" ]

if [ -w /dev/full ]; then
  "$FEATURELINE" info "$mesh" >/dev/full 2>"$tmp/err"; rc=$?
  check "an answer standard output cannot take (a full disk) exits 1" [ $rc = 1 ]
  check "... saying so" [ "$(cat "$tmp/err")" = "featureline: failed writing standard output" ]
fi

"$FEATURELINE" detect "$mesh" --keys 10,200,400 >"$tmp/line.json" 2>"$tmp/err"; rc=$?
check "detect exits 0" [ $rc = 0 ]
check "detect echoes the keys" [ "$(jq -c .keys "$tmp/line.json")" = "[10,200,400]" ]
check "initial line starts at the first key" [ "$(jq '.initial.vertices[0]' "$tmp/line.json")" = 10 ]
check "initial line ends at the last key" [ "$(jq '.initial.vertices[-1]' "$tmp/line.json")" = 400 ]
check "refined line has points, faces, barycentric in step" \
  [ "$(jq '(.refined.points|length) == (.refined.faces|length) and (.refined.faces|length) == (.refined.barycentric|length) and (.refined.points|length) > 2' "$tmp/line.json")" = true ]
check "timings are reported" [ "$(jq '.stats.timings_ms.total > 0' "$tmp/line.json")" = true ]

"$FEATURELINE" detect "$mesh" --keys 10,200 --initial geodesic --no-refine >"$tmp/geo.json"; rc=$?
check "--initial geodesic is honoured" [ "$(jq -r .initial.method "$tmp/geo.json")" = geodesic ]

"$FEATURELINE" detect "$mesh" --keys 10,200,400 --out "$tmp/line.glb"; rc=$?
check "--out .glb writes a GLB" [ $rc = 0 ] && check "GLB magic" [ "$(head -c 4 "$tmp/line.glb")" = glTF ]

check "no fitted curve unless asked" [ "$(jq 'has("fitted")' "$tmp/line.json")" = false ]
"$FEATURELINE" detect "$mesh" --keys 10,200,400 --fitted >"$tmp/fitted.json"; rc=$?
check "--fitted exits 0" [ $rc = 0 ]
check "--fitted answers a fitted curve with its control points per unit length" \
  [ "$(jq '(.fitted.points|length) > 2 and .fitted.control_points_per_unit_length > 0' "$tmp/fitted.json")" = true ]
check "--fitted leaves the refined line as it was" [ "$(jq -c .refined "$tmp/fitted.json")" = "$(jq -c .refined "$tmp/line.json")" ]
"$FEATURELINE" detect "$mesh" --keys 10,200,400 --fitted --fitted-control-spacing 4 --out "$tmp/fitted.obj"; rc=$?
check "--fitted --out .obj writes the line and its fitted curve" \
  [ $rc = 0 ] && check "OBJ objects" [ "$(grep -c '^o ' "$tmp/fitted.obj")" = 2 ] && check "OBJ fitted object" grep -q '^o line_0_fitted$' "$tmp/fitted.obj"
"$FEATURELINE" detect "$mesh" --keys 10,200,400 --fitted --out "$tmp/fitted.polylines.txt"; rc=$?
check "--fitted --out .polylines.txt writes two polylines" [ $rc = 0 ] && check "two text lines" [ "$(wc -l <"$tmp/fitted.polylines.txt")" = 2 ]
"$FEATURELINE" detect "$mesh" --keys 10,200,400 --fitted --out "$tmp/fitted.glb"; rc=$?
check "--fitted --out .glb names the fitted curve's node" [ $rc = 0 ] && check "GLB node fitted_curve_0" grep -q fitted_curve_0 "$tmp/fitted.glb"

"$FEATURELINE" detect "$mesh" --keys 10,99999999 >"$tmp/out" 2>"$tmp/err"; rc=$?
check "out-of-range key exits 1" [ $rc = 1 ]
check "out-of-range key: one clear line" [ "$(cat "$tmp/err")" = "featureline: request.keys[1] is vertex 99999999, but the mesh has only 6475 vertices" ]
check "nothing on stdout on error" [ ! -s "$tmp/out" ]

"$FEATURELINE" detect "$tmp/missing.obj" --keys 1,2 >"$tmp/out" 2>"$tmp/err"; rc=$?
check "missing file exits 1" [ $rc = 1 ]
check "missing file: one line" [ "$(wc -l <"$tmp/err")" = 1 ]

"$FEATURELINE" detect "$mesh" --keys 1,2 --bogus >"$tmp/out" 2>"$tmp/err"; rc=$?
check "unknown flag exits 2" [ $rc = 2 ]
check "unknown flag named" grep -q 'not expected: --bogus' "$tmp/err"
check "a usage error is two lines: what, and where help is" [ "$(wc -l <"$tmp/err")" = 2 ]
check "the pointer names the command's help" [ "$(tail -n 1 "$tmp/err")" = "Run 'featureline detect --help' for usage." ]

"$FEATURELINE" detect "$mesh" --keys 1,2 --options '{"snake": {"alpah": 1}}' >"$tmp/out" 2>"$tmp/err"; rc=$?
check "misspelt JSON option exits 1" [ $rc = 1 ]
check "misspelt JSON option named" [ "$(cat "$tmp/err")" = 'featureline: unknown option "options.snake.alpah"' ]

# --options may use an option's old name (before names became member paths); a flag still wins over it.
"$FEATURELINE" detect "$mesh" --keys 10,200 --rings 2 >"$tmp/rings_flag.json" 2>"$tmp/err"; rc=$?
check "--rings exits 0" [ $rc = 0 ]
"$FEATURELINE" detect "$mesh" --keys 10,200 --options '{"rings": 5}' --rings 2 >"$tmp/rings_both.json" 2>"$tmp/err"; rc=$?
check "--rings over an old-named JSON rings exits 0" [ $rc = 0 ]
check "... and the flag wins" [ "$(jq .stats.strip_faces "$tmp/rings_both.json")" = "$(jq .stats.strip_faces "$tmp/rings_flag.json")" ]
"$FEATURELINE" detect "$mesh" --keys 10,200 --options '{"initial": "marching", "weights": {"delta": 1}}' --weights 1,1,1,3 >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--weights over the old initial string and weights exits 0" [ $rc = 0 ]
check "... keeping the method" [ "$(jq -r '.initial.method' "$tmp/out")" = marching ]
"$FEATURELINE" detect "$mesh" --keys 10,200 --options '{"rings": 3, "strip": {"rings": 4}}' >"$tmp/out" 2>"$tmp/err"; rc=$?
check "an option by its old and new name exits 1" [ $rc = 1 ]
check "... naming both" [ "$(cat "$tmp/err")" = 'featureline: "options.rings" and "options.strip.rings" name the same option: give only "options.strip.rings"' ]

"$FEATURELINE" detect "$mesh" --keys 1,x >"$tmp/out" 2>"$tmp/err"; rc=$?
check "malformed keys exit 1" [ $rc = 1 ]
sample="$(dirname "$0")/../../samples/ridge_field.off"
"$FEATURELINE" segment "$sample" --line 820,860 >"$tmp/parts.json" 2>"$tmp/err"; rc=$?
check "segment exits 0" [ $rc = 0 ]
check "an open line from border to border makes two parts" [ "$(jq '.segments|length' "$tmp/parts.json")" = 2 ]
check "every face is labelled" [ "$(jq '.labels|length' "$tmp/parts.json")" = 3200 ]
check "part areas add up to the total" [ "$(jq '((.segments|map(.area)|add) - .total_area)|fabs < 1e-9' "$tmp/parts.json")" = true ]
"$FEATURELINE" segment "$sample" --line 820,860 --mode remesh --out "$tmp/parts.glb"; rc=$?
check "segment --out .glb writes a GLB" [ $rc = 0 ] && check "parts GLB magic" [ "$(head -c 4 "$tmp/parts.glb")" = glTF ]
"$FEATURELINE" segment "$sample" --line 700,705 >"$tmp/out" 2>"$tmp/err"; rc=$?
check "a line that closes nothing exits 1" [ $rc = 1 ]
check "and says so" grep -q "close no region" "$tmp/err"
"$FEATURELINE" segment "$sample" --loop 700,705,750 --mode sideways >"$tmp/out" 2>"$tmp/err"; rc=$?
check "unknown --mode exits 2" [ $rc = 2 ]
echo '{"lines": [{"keys": [820, 860]}]}' >"$tmp/seg_request.json"
"$FEATURELINE" segment "$sample" --loop 700,705,750 --request "$tmp/seg_request.json" >"$tmp/out" 2>"$tmp/err"; rc=$?
check "segment --loop with --request is a usage error (exit 2), not a line silently dropped" [ $rc = 2 ]
check "... naming the two" [ "$(head -n 1 "$tmp/err")" = "featureline: --loop excludes --request" ]
# Seeding keys without the page: fandisk's crease chains, and a line through a chain's ends.
"$FEATURELINE" features "$mesh" >"$tmp/features.json"; rc=$?
check "features exits 0" [ $rc = 0 ]
check "features finds fandisk's 34 crease chains" [ "$(jq '.crease_chains|length' "$tmp/features.json")" = 34 ]
check "chains are longest first" [ "$(jq '[.crease_chains[].length] | . == (sort|reverse)' "$tmp/features.json")" = true ]
check "every chain's points are its vertices' positions, one each" \
  [ "$(jq '[.crease_chains[] | (.points|length) == (.vertices|length)] | all' "$tmp/features.json")" = true ]
ends=$(jq -r '.crease_chains[0] | select(.closed|not) | "\(.vertices[0]),\(.vertices[(.vertices|length)/2|floor]),\(.vertices[-1])"' "$tmp/features.json")
chain_length=$(jq '.crease_chains[0].length' "$tmp/features.json")
"$FEATURELINE" detect "$mesh" --keys "$ends" >"$tmp/chain-line.json"; rc=$?
check "a line through the longest chain's ends and middle follows it (length within 1%)" \
  [ "$(jq --argjson c "$chain_length" '((.refined.length - $c) / $c) | fabs < 0.01' "$tmp/chain-line.json")" = true ]
# One key on the longest chain's middle: --trace follows the chain (at least as long as it: the
# trace also passes the chain's corners that the features command splits at).
middle=$(jq -r '.crease_chains[0].vertices as $v | $v[($v|length)/2|floor]' "$tmp/features.json")
"$FEATURELINE" detect "$mesh" --keys "$middle" --trace >"$tmp/traced.json"; rc=$?
check "--trace from the longest chain's middle exits 0" [ $rc = 0 ]
check "--trace: a traced line along creases at least as long as the chain" \
  [ "$(jq --argjson c "$chain_length" '.initial.method == "trace" and .trace.on_crease and .initial.length >= $c - 1e-9' "$tmp/traced.json")" = true ]
"$FEATURELINE" detect "$mesh" --keys "$middle" --trace --closed >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--trace with --closed is a usage error (exit 2)" [ $rc = 2 ]
valley=$(jq -r '[.crease_chains[] | select(.sign == "valley")][0].vertices as $v | $v[($v|length)/2|floor]' "$tmp/features.json")
"$FEATURELINE" detect "$mesh" --keys "$valley" --trace >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--trace from the first valley chain's middle follows a concave crease" \
  [ "$rc $(jq -c '[.trace.sign, .trace.on_crease]' "$tmp/out")" = '0 ["valley",true]' ]
"$FEATURELINE" detect "$mesh" --keys "$valley" --trace --trace-sign ridge >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--trace-sign ridge from there: no ridge nearby, refused (exit 1) saying so" \
  [ "$rc $(grep -c 'no ridge, valley or crease to trace' "$tmp/err")" = "1 1" ]
"$FEATURELINE" features "$mesh" --max-chains 5 --max-seeds 0 >"$tmp/f5.json"; rc=$?
check "--max-chains 5 gives 5 chains" [ "$(jq '.crease_chains|length' "$tmp/f5.json")" = 5 ]
"$FEATURELINE" features "$mesh" --corner-angle 200 >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--corner-angle out of range: exit 2" [ $rc = 2 ]

# Conventions: help and version on standard output with exit 0, for the program and each command.
"$FEATURELINE" --help >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--help exits 0" [ $rc = 0 ]
check "--help prints the commands on stdout" grep -q "detect" "$tmp/out"
check "--help writes nothing on stderr" [ ! -s "$tmp/err" ]
for command in detect segment info features options; do
  "$FEATURELINE" $command --help >"$tmp/out" 2>"$tmp/err"; rc=$?
  check "$command --help exits 0 with its usage on stdout" [ $rc = 0 ] && check "$command --help: usage line" grep -q "^Usage: featureline $command" "$tmp/out"
done
version=$("$FEATURELINE" --version); rc=$?
check "--version exits 0" [ $rc = 0 ]
spec_version=$(sed -n 's/^  version: \(.*\)$/\1/p' "$(dirname "$0")/../../api/openapi.yaml")
check "--version is the OpenAPI spec's version" [ "$version" = "featureline $spec_version" ]
"$FEATURELINE" >"$tmp/out" 2>"$tmp/err"; rc=$?
check "no command: exit 2" [ $rc = 2 ] && check "no command: two lines on stderr" [ "$(wc -l <"$tmp/err")" = 2 ]

# Standard input, point keys, request files, several meshes.
"$FEATURELINE" info - <"$mesh" >"$tmp/stdin.json"; rc=$?
check "info - reads standard input" [ $rc = 0 ] && check "info - counts fandisk's vertices" [ "$(jq .vertices "$tmp/stdin.json")" = 6475 ]
"$FEATURELINE" info - --format ply <"$mesh" >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--format ply on an OFF file is refused (exit 1)" [ $rc = 1 ]
"$FEATURELINE" info - </dev/null >"$tmp/out" 2>"$tmp/err"; rc=$?
check "empty standard input: exit 1" [ $rc = 1 ] && check "... saying it is empty" grep -q '^featureline: standard input is empty.$' "$tmp/err"
p10=$(jq -c '.initial.points[0]|map(tostring)|join(",")' -r "$tmp/line.json")
p400=$(jq -c '.initial.points[-1]|map(tostring)|join(",")' -r "$tmp/line.json")
"$FEATURELINE" detect "$mesh" --points "$p10;$p400" >"$tmp/points.json"; rc=$?
check "--points: a vertex's own position selects that vertex" [ "$(jq -c .keys "$tmp/points.json")" = "[10,400]" ]
"$FEATURELINE" detect "$mesh" --points "1,2;3" >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--points with a pair: exit 2" [ $rc = 2 ] && check "and names it" grep -q 'not "1,2"' "$tmp/err"
echo '{"lines": [{"keys": [10, 200]}, {"keys": [{"point": ['"$(jq -c '.initial.points[0]|map(tostring)|join(",")' -r "$tmp/line.json")"']}, 400], "closed": false}]}' >"$tmp/request.json"
"$FEATURELINE" detect "$mesh" --request "$tmp/request.json" >"$tmp/batch.json"; rc=$?
check "--request with two lines exits 0" [ $rc = 0 ]
check "--request answers {lines} as the HTTP API does" [ "$(jq -c '[.lines[].keys]' "$tmp/batch.json")" = "[[10,200],[10,400]]" ]
"$FEATURELINE" detect "$mesh" --request - <"$tmp/request.json" >"$tmp/batch2.json"; rc=$?
check "--request - reads standard input" cmp -s <(jq -S '[.lines[].refined.points]' "$tmp/batch.json") <(jq -S '[.lines[].refined.points]' "$tmp/batch2.json")
"$FEATURELINE" detect "$mesh" --keys 10,200,400 --request "$tmp/request.json" >"$tmp/out" 2>"$tmp/err"; rc=$?
check "--keys with --request: exit 2" [ $rc = 2 ]
"$FEATURELINE" info "$mesh" "$sample" "$tmp/missing.obj" >"$tmp/many.json" 2>"$tmp/err"; rc=$?
check "several meshes, one missing: exit 1" [ $rc = 1 ]
check "several meshes: one entry each, in order" [ "$(jq -c '[.[].mesh|split("/")|last]' "$tmp/many.json")" = '["fandisk.off","ridge_field.off","missing.obj"]' ]
check "several meshes: results and the error" [ "$(jq -c '[.[0].result.vertices, .[1].result.vertices, (.[2].error|test("does not exist"))]' "$tmp/many.json")" = "[6475,1681,true]" ]
exit $fail
