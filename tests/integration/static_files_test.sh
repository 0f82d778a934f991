#!/usr/bin/env bash
# The page's files with curl, as a browser revalidates them: ETag and Cache-Control on every
# file, 304 without a body for If-None-Match naming the ETag (also in a list, or weak), 200 and
# a new ETag once the file changed. Both ways the server serves the page: a --web-root folder
# (a fresh build of web/) and the copy compiled into the binary.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
FACTOR=1
CURL_MAX=30
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-static.XXXXXX")
trap cleanup EXIT

node web/build.mjs "$TMP/page" >/dev/null || { fail "the page builds"; finish; }

# revalidation NAME BASE PATH: the file's ETag and Cache-Control, then If-None-Match answers.
revalidation() {
  local name=$1 base=$2 path=$3
  http "$TMP/file" "$base$path"
  check_eq "$name: GET $path is 200" "$STATUS" 200
  local etag; etag=$(header "$TMP/file" ETag)
  check "$name: $path has a quoted ETag ($etag)" bash -c "[[ '$etag' =~ ^\\\"[0-9a-f]{16}\\\"$ ]]"
  check_eq "$name: $path must be revalidated" "$(header "$TMP/file" Cache-Control)" no-cache
  http "$TMP/again" -H "If-None-Match: $etag" "$base$path"
  check_eq "$name: If-None-Match with its ETag: 304" "$STATUS" 304
  # curl reads no body after a 304 whatever follows; the length the server announced tells.
  check_eq "$name: ... without a body" "$(header "$TMP/again" Content-Length)" 0
  check_eq "$name: ... and with the ETag" "$(header "$TMP/again" ETag)" "$etag"
  http "$TMP/again" -H "If-None-Match: \"0000000000000000\", W/$etag" "$base$path"
  check_eq "$name: a list holding the weak form of its ETag: 304" "$STATUS" 304
  http "$TMP/again" -H 'If-None-Match: "0000000000000000"' "$base$path"
  check_eq "$name: another ETag: 200 with the file" "$STATUS $(cmp -s "$TMP/again" "$TMP/file" && echo same)" "200 same"
  ETAG=$etag
}

start_server folder --host 127.0.0.1 --web-root "$TMP/page" || finish
revalidation "--web-root" "${SRV_BASE[folder]}" /index.html
revalidation "--web-root" "${SRV_BASE[folder]}" /main.js
printf '\n// changed\n' >>"$TMP/page/main.js"
http "$TMP/changed" -H "If-None-Match: $ETAG" "${SRV_BASE[folder]}/main.js"
check_eq "--web-root: a changed file is sent again" "$STATUS $(tail -c 11 "$TMP/changed")" "200 // changed"
check "--web-root: ... under a new ETag" test "$(header "$TMP/changed" ETag)" != "$ETAG"
stop_server folder

start_server built_in --host 127.0.0.1 || finish
revalidation "built-in page" "${SRV_BASE[built_in]}" /index.html
revalidation "built-in page" "${SRV_BASE[built_in]}" /vendor/three/build/three.module.js
stop_server built_in
finish
