#!/usr/bin/env bash
# The first minutes of a new user, the way they start things: scripts/run.sh as the README runs
# it, every curl line it prints run verbatim (and again after a restart, so the preloaded
# session is durable), the bare server binary with no flags serving its page, and a second
# server on a port in use refused at start-up.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
FACTOR=1
CURL_MAX=60
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-first.XXXXXX")
RUN_PID=""
stop_run() {  # run.sh and its server: one process group (setsid), stopped by its leader's PID
  [ -n "$RUN_PID" ] || return 0
  kill -INT -- "-$RUN_PID" 2>/dev/null
  for _ in $(seq 1 100); do kill -0 "$RUN_PID" 2>/dev/null || break; sleep 0.1; done
  kill -KILL -- "-$RUN_PID" 2>/dev/null
  wait "$RUN_PID" 2>/dev/null
  RUN_PID=""
}
trap 'stop_run; cleanup' EXIT

# start_run OUT: scripts/run.sh on $RUN_PORT with its data in $TMP/data; waits (bounded) until it serves.
start_run() {
  local out=$1
  PORT=$RUN_PORT DATA_DIR="$TMP/data" setsid scripts/run.sh >"$out" 2>"$out.err" </dev/null &
  RUN_PID=$!
  for _ in $(seq 1 600); do
    grep -q '^open http' "$out" && return 0
    kill -0 "$RUN_PID" 2>/dev/null || break
    sleep 0.5
  done
  fail "scripts/run.sh starts serving" "$(tail -n 20 "$out" "$out.err")"
  return 1
}

# run_printed_curls OUT: every "  curl ..." line run.sh printed, run as printed; each answer must
# be JSON without an error.
run_printed_curls() {
  local out=$1 n=0 line
  while IFS= read -r line; do
    n=$((n + 1))
    bash -c "${line#  }" >"$TMP/curl-$n.json" 2>"$TMP/curl-$n.err"
    local rc=$?
    if [ $rc = 0 ] && jq -e 'type == "object" and (has("error") | not)' "$TMP/curl-$n.json" >/dev/null 2>&1; then
      pass "run.sh's printed line works verbatim: ${line:2:60}..."
    else
      fail "run.sh's printed line works verbatim: $line" "exit $rc" "$(head -c 300 "$TMP/curl-$n.json")"
    fi
  done < <(grep '^  curl ' "$out")
  check "run.sh printed three curl lines" [ "$n" = 3 ]
}

RUN_PORT=$(free_port_block 1) || { fail "a free port for run.sh"; exit 1; }
if start_run "$TMP/run1.out"; then
  pass "scripts/run.sh starts serving"
  check "run.sh ran the CLI on the sample first" grep -q '"refined":{"points":' "$TMP/run1.out"
  check "run.sh says where to open the page" grep -qx "open http://127.0.0.1:$RUN_PORT/" "$TMP/run1.out"
  run_printed_curls "$TMP/run1.out"
  check_eq "the printed feature-line request gives a refined line" "$(jq '.refined.points | length > 2' "$TMP/curl-1.json")" true
  check_eq "the printed upload gives a new mesh id" "$(jq -r '.mesh_id | test("^[0-9a-f]{32}$")' "$TMP/curl-2.json")" true
  check_eq "the printed mesh query describes the sample" "$(jq .vertices "$TMP/curl-3.json")" 1681
  first_id=$(sed -n 's/^preloaded .* as mesh \([0-9a-f]*\)$/\1/p' "$TMP/run1.out")
  http "$TMP/page.html" "http://127.0.0.1:$RUN_PORT/"
  check_eq "run.sh's server serves the page at /" "$STATUS" 200
  stop_run
  # The preloaded sample is stored like an upload: the first run's lines still answer.
  if start_run "$TMP/run2.out"; then
    http "$TMP/old.json" "http://127.0.0.1:$RUN_PORT/v1/meshes/$first_id"
    check_eq "after a restart, the first run's preloaded mesh id still answers" "$STATUS" 200
    check_eq "... with the sample's vertex count" "$(jq .vertices "$TMP/old.json")" 1681
    rm -f "$TMP"/curl-*.json
    run_printed_curls "$TMP/run2.out"
    stop_run
  fi
fi

# The bare binary, no flags, from a folder with nothing beside it: the page and the API on 8080.
cd "$TMP" || exit 1
if ss -Htln 'sport = :8080' 2>/dev/null | grep -q .; then
  fail "port 8080 is free for the bare-binary check" "$(ss -Htlnp 'sport = :8080')"
else
  "$SERVER" >"$TMP/bare.out" 2>"$TMP/bare.log" &
  SRV_PID[bare]=$!
  for _ in $(seq 1 100); do curl -s -o /dev/null --max-time 1 http://127.0.0.1:8080/healthz && break; sleep 0.1; done
  http "$TMP/index.html" http://127.0.0.1:8080/
  check_eq "featureline-server with no flags serves / (200)" "$STATUS" 200
  check "... as HTML" grep -qi '^content-type: text/html' "$TMP/index.html.hdr"
  check "... the page itself" grep -q '<script' "$TMP/index.html"
  # Every module the page loads, followed through their relative imports, answers 200.
  missing=$(node --input-type=module -e '
    const base = "http://127.0.0.1:8080/", seen = new Set(), bad = [];
    async function visit(url) {
      if (seen.has(url) || seen.size > 400) return;
      seen.add(url);
      const res = await fetch(url);
      if (res.status !== 200) { bad.push(`${url} ${res.status}`); return; }
      const text = await res.text();
      const refs = url.endsWith(".html")
        ? [...text.matchAll(/<script[^>]*src="([^"]+)"/g), ...text.matchAll(/"(\.{0,2}\/?[\w./-]+\.js)"/g)].map((m) => m[1])
        : [...text.matchAll(/(?:from\s*|import\s*\(?\s*)["'\''](\.{1,2}\/[^"'\'']+)["'\'']/g)].map((m) => m[1]);
      for (const ref of refs) await visit(new URL(ref, url).href);
    }
    await visit(base + "index.html");
    if (seen.size < 3) bad.push(`only ${seen.size} files found`);
    console.log(bad.join("\n"));')
  check_eq "every script of the built-in page loads" "$missing" ""
  http "$TMP/options.json" http://127.0.0.1:8080/v1/options
  check_eq "the bare binary's API answers" "$STATUS" 200
  http "$TMP/nothing.json" http://127.0.0.1:8080/no-such-file.js
  check_eq "a file the page does not have: 404" "$STATUS" 404
  etag=$(header "$TMP/index.html" ETag)
  http "$TMP/again.html" -H "If-None-Match: $etag" http://127.0.0.1:8080/
  check_eq "the page revalidates with its ETag (304)" "$STATUS" 304

  # A second server on the same port: a start-up error naming the port, the first unharmed.
  timeout 10 "$SERVER" >"$TMP/second.out" 2>"$TMP/second.err"
  rc=$?
  check "a second server on a port in use exits 1" [ "$rc" = 1 ]
  check_eq "... saying so" "$(cat "$TMP/second.err")" \
    "featureline-server: cannot listen on 127.0.0.1:8080: the port is already in use (--port picks another)"
  check "... without claiming to listen" bash -c "! grep -q listening '$TMP/second.out'"
  ok_count=0
  for _ in $(seq 1 10); do
    [ "$(curl -s -o /dev/null -w '%{http_code}' http://127.0.0.1:8080/)" = 200 ] && ok_count=$((ok_count + 1))
  done
  check_eq "the first server still answers every request" "$ok_count" 10
  stop_server bare
  check_eq "the bare server stops on SIGTERM with exit 0" "$STOP_RC" 0
fi

"$SERVER" --help >"$TMP/help.out" 2>"$TMP/help.err"
check "featureline-server --help exits 0 with its usage on stdout" grep -q '^Usage: featureline-server' "$TMP/help.out"
check_eq "featureline-server --version" "$("$SERVER" --version)" "featureline-server $(sed -n 's/^  version: \(.*\)$/\1/p' "$ROOT/api/openapi.yaml")"
"$SERVER" --port 99999 >"$TMP/bad.out" 2>"$TMP/bad.err"
rc=$?
check_eq "a bad flag exits 2" "$rc" 2
check_eq "... with one line and a pointer to --help" "$(wc -l <"$TMP/bad.err")" 2
finish
