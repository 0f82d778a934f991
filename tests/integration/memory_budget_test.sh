#!/usr/bin/env bash
# Memory per request, as an attacker would spend it: bodies built by this script against the
# real server with a small cache (--cache-mb 64). Each case checks the answers' status and error
# code, that the server's peak resident memory (VmHWM) stays within 3 x the cache budget + 64 MB,
# and that a normal client still gets its lines.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
FACTOR=$(time_factor "$SERVER")
CURL_MAX=$((60 * FACTOR))
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-memory.XXXXXX")
trap cleanup EXIT
CACHE_MB=64
PEAK_LIMIT_KB=$(((3 * CACHE_MB + 64) * 1024))
peak_kb() { sed -n 's/^VmHWM:[[:space:]]*\([0-9]*\) kB$/\1/p' "/proc/$1/status"; }

start_server main --cache-mb $CACHE_MB --quiet --preload samples/ridge_field.off || { finish; exit 1; }
B=${SRV_BASE[main]}
PID=${SRV_PID[main]}
id=$(sed -n 's/^preloaded .* as mesh \([0-9a-f]*\)$/\1/p' "$TMP/main.out")
LINE='{"keys": [701, 963, 1184]}'

# normal_lines N OUT: N line requests one after another, each retried (up to 20 times, 0.25 s
# apart) while the server sheds load with 503; OUT gets each final status.
normal_lines() {
  local n=$1 out=$2 i try code
  : >"$out"
  for i in $(seq 1 "$n"); do
    for try in $(seq 1 20); do
      code=$(curl -s -o /dev/null -w '%{http_code}' --max-time "$CURL_MAX" -X POST -H 'Content-Type: application/json' -d "$LINE" "$B/v1/meshes/$id/feature-lines")
      [ "$code" = 503 ] || break
      sleep 0.25
    done
    echo "$code" >>"$out"
  done
}

# burst NAME FILE COUNT: COUNT concurrent feature-line requests with FILE as body, while a normal
# client asks for lines; every hostile answer must be 413 or 503 (never 200 or 5xx other than 503).
burst() {
  local name=$1 file=$2 count=$3 i
  normal_lines 10 "$TMP/$name.normal" &
  local normal=$!
  BG_PIDS+=("$normal")
  for i in $(seq 1 "$count"); do
    curl -s -o "$TMP/$name.$i.json" -w '%{http_code}\n' --max-time "$CURL_MAX" -X POST -H 'Content-Type: application/json' \
      --data-binary @"$file" "$B/v1/meshes/$id/feature-lines" >"$TMP/$name.$i.code" &
    BG_PIDS+=("$!")
  done
  for i in $(seq 1 "$count"); do wait "${BG_PIDS[-$i]}" 2>/dev/null; done
  wait "$normal" 2>/dev/null
  local bad
  bad=$(cat "$TMP/$name".*.code | grep -vcE '^(413|503)$')
  check_eq "$name: every one of $count answers is 413 or 503" "$bad" 0
  check_eq "$name: the 413s say payload_too_large" \
    "$(for i in $(seq 1 "$count"); do [ "$(cat "$TMP/$name.$i.code")" = 413 ] && jq -r .error.code "$TMP/$name.$i.json"; done | sort -u | grep -v payload_too_large)" ""
  check_eq "$name: a normal client meanwhile gets every line (200)" "$(sort -u "$TMP/$name.normal")" 200
  local peak; peak=$(peak_kb "$PID")
  echo "#    $name: peak resident memory $((peak / 1024)) MB (limit $((PEAK_LIMIT_KB / 1024)) MB)"
  check "$name: peak resident memory within 3 x --cache-mb + 64 MB" [ "$peak" -lt "$PEAK_LIMIT_KB" ]
}

# 4 MiB of tiny containers: about 100 bytes of DOM per 3 bytes of text.
python3 -c "
import sys
n = (4 * 1024 * 1024 - 20) // 3
sys.stdout.write('{\"lines\": [' + ','.join(['{}'] * n) + ']}')" >"$TMP/containers.json"
burst "64 bodies of 4 MiB of {}" "$TMP/containers.json" 64
http "$TMP/one.json" -X POST -H 'Content-Type: application/json' --data-binary @"$TMP/containers.json" "$B/v1/meshes/$id/feature-lines"
check_eq "one such body alone: 413" "$STATUS" 413
check "... naming what is too large" grep -q 'JSON values (.* objects and arrays) in 4194' "$TMP/one.json"

# Deep nesting: refused by depth before any DOM is built.
python3 -c "import sys; sys.stdout.write('{\"keys\": ' + '[' * 100000 + ']' * 100000 + '}')" >"$TMP/deep.json"
http "$TMP/deep.out" -X POST -H 'Content-Type: application/json' --data-binary @"$TMP/deep.json" "$B/v1/meshes/$id/feature-lines"
check_eq "100,000 levels of nesting: 413" "$STATUS" 413
check "... saying how deep" grep -q 'nests 100001 levels deep; at most 64' "$TMP/deep.out"

http "$TMP/ok.json" -X POST -H 'Content-Type: application/json' -d "$LINE" "$B/v1/meshes/$id/feature-lines"
check_eq "afterwards a line answers 200" "$STATUS" 200
finish
