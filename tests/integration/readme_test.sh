#!/usr/bin/env bash
# The README's commands, as a reader runs them: every block fenced as ```sh in README.md, and in
# the "Quick start" sections of docs/cli.md and docs/http-api.md, run as written, in order, from
# the repository root. Each document is one shell session: variables set by a block (ID=...)
# are there for the next. A block fails on a non-zero exit status, a JSON answer carrying
# "error", an error status in the access log of a server the document started, or an empty
# file it names with -o / --out. A block ending in & is left running (its PID recorded),
# waited for on /healthz (20 s at most), and stopped by that PID when its document ends.
# Blocks fenced otherwise (```console: scripts/run.sh, scripts/test.sh, apt-get) are not run.
# Also: every relative link in README.md and docs/*.md leads to a file.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
FACTOR=1
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-readme.XXXXXX")
FEATURELINE=${FEATURELINE:-$ROOT/build/cli/featureline}
DOCS=(README.md:all docs/cli.md:quickstart docs/http-api.md:quickstart)

STARTED=()        # PIDs of programs a block left running in the current document
STARTED_LOGS=()   # their standard error (the server's access log), by the same index
LOG_SEEN=()       # access-log lines already checked, by the same index
CREATED=()        # files the blocks named that did not exist before: removed at the end

stop_started() {
  stop_pids 100 "${STARTED[@]}"
  STARTED=(); STARTED_LOGS=(); LOG_SEEN=()
}
path_of() { case "$1" in /*) echo "$1" ;; *) echo "$ROOT/$1" ;; esac; }
is_created() {
  local f
  for f in "${CREATED[@]}"; do [ "$f" = "$1" ] && return 0; done
  return 1
}
remove_created() {
  local f
  for f in "${CREATED[@]}"; do rm -f -- "$(path_of "$f")"; done
  CREATED=()
}
trap 'stop_started; remove_created; cleanup' EXIT
trap 'exit 130' INT TERM HUP

# The README names the binaries where a user finds them; when ctest hands over others (another
# build folder), the blocks run with those instead, and say so.
same_file() { [ "$(readlink -f "$1")" = "$(readlink -f "$2")" ]; }
REWRITE=()
if ! same_file "$SERVER" "$ROOT/build/server/featureline-server"; then
  REWRITE+=("build/server/featureline-server=$SERVER")
fi
if ! same_file "$FEATURELINE" "$ROOT/build/cli/featureline"; then
  REWRITE+=("build/cli/featureline=$FEATURELINE")
fi
for r in "${REWRITE[@]}"; do echo "# running ${r%%=*} as ${r#*=}"; done
for program in "$SERVER" "$FEATURELINE"; do
  [ -x "$program" ] || { fail "$program is built" "build first: cmake --build build"; finish; exit 1; }
done

# extract DOC MODE OUTDIR: writes each ```sh block as OUTDIR/NNN.sh and its line number as
# OUTDIR/NNN.line. MODE "all" takes every block, "quickstart" those under a heading containing
# "Quick start", up to the next heading of the same or a higher level.
extract() {
  awk -v mode="$2" -v out="$3" '
    BEGIN { inside = (mode == "all"); fence = 0; n = 0 }
    fence == 0 && /^```/ {
      fence = 1
      lang = substr($0, 4); sub(/[ \t]+$/, "", lang)
      capture = (lang == "sh" && inside)
      if (capture) { n++; file = sprintf("%s/%03d.sh", out, n); printf "%d\n", NR + 1 > (sprintf("%s/%03d.line", out, n)); printf "" > file }
      next
    }
    fence == 1 && /^```[ \t]*$/ { fence = 0; if (capture) close(file); capture = 0; next }
    fence == 1 { if (capture) print >> file; next }
    mode == "quickstart" && /^#+ / {
      match($0, /^#+/); level = RLENGTH
      if (tolower($0) ~ /quick start/) { inside = 1; quick_level = level }
      else if (inside && level <= quick_level) inside = 0
    }' "$1"
}

# json_error FILE: true when FILE holds JSON (one document, a stream, or one per line) with an
# "error" member anywhere.
json_error() {
  local rc
  jq -e -s 'any(.[]; [.. | objects | has("error")] | any)' "$1" >/dev/null 2>&1
  rc=$?
  [ $rc = 0 ] && return 0
  [ $rc = 1 ] && return 1
  local line
  while IFS= read -r line; do
    printf '%s' "$line" | jq -e '[.. | objects | has("error")] | any' >/dev/null 2>&1 && return 0
  done <"$1"
  return 1
}

# Variables a fresh shell has; the rest are what the blocks set, carried to the next block.
FRESH=" $(bash -c 'compgen -v' | tr '\n' ' ') "
# wrapper BLOCK STATE PIDFILE OUT: the block as a script that restores and saves the session.
wrapper() {
  local block=$1 state=$2 pidfile=$3 out=$4
  {
    printf 'cd %q || exit 99\n' "$ROOT"
    printf '[ -f %q ] && source %q\n' "$state" "$state"
    printf 'set -eo pipefail\n'
    cat "$block"
    printf '\n__fl_last_bg=${!:-}\n'
    printf 'printf "%%s\\n" "$__fl_last_bg" >%q\n' "$pidfile"
    printf '__fl_fresh=%q\n' "$FRESH"
    printf '{ for __fl_v in $(compgen -v); do\n'
    printf '    case "$__fl_fresh" in *" $__fl_v "*) continue ;; esac\n'
    printf '    case "$__fl_v" in __fl_*|BASH*|PIPESTATUS|FUNCNAME|LINENO|RANDOM|SECONDS|SRANDOM|EPOCH*|OPT*|REPLY|HISTCMD|COLUMNS|LINES|_) continue ;; esac\n'
    printf '    declare -p "$__fl_v"\n'
    printf '  done; } >%q.new && mv %q.new %q\n' "$state" "$state" "$state"
  } >"$out"
}

# The files a block names with -o FILE or --out FILE (relative to the repository root).
named_files() {
  grep -oE '(^|[[:space:]])(-o|--out)[[:space:]=]+[^[:space:];|&]+' "$1" | sed -E 's/^[[:space:]]*(-o|--out)[[:space:]=]+//' |
    grep -vx -e - -e /dev/null | sort -u
}
port_of() {  # the port a featureline-server command line names, else 8080
  local p; p=$(grep -oE -- '--port[ =][0-9]+' "$1" | head -n 1 | grep -oE '[0-9]+$')
  echo "${p:-8080}"
}
listening() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

# check_logs NAME: error statuses in the access logs of the servers started so far, since the
# last look.
check_logs() {
  local name=$1 i bad=""
  sleep 0.2  # a request's log line may follow its answer by a moment
  for i in "${!STARTED_LOGS[@]}"; do
    local log=${STARTED_LOGS[$i]} total
    total=$(wc -l <"$log")
    bad+=$(tail -n +"$((LOG_SEEN[$i] + 1))" "$log" | head -n "$((total - LOG_SEEN[$i]))" |
           awk '$1 ~ /^[0-9][0-9][0-9][0-9]-[0-9][0-9]-[0-9][0-9]T/ && $5 ~ /^[0-9][0-9][0-9]$/ && $5 >= 400 { print }')
    LOG_SEEN[$i]=$total
  done
  if [ -n "$bad" ]; then fail "$name: no error status in the server's access log" "$bad"; return 1; fi
  return 0
}

run_blocks() {
  local doc=${1%%:*} mode=${1#*:}
  local dir="$TMP/$(echo "$doc" | tr '/.' '__')"
  mkdir -p "$dir"
  if [ ! -f "$ROOT/$doc" ]; then fail "$doc exists"; return; fi
  extract "$ROOT/$doc" "$mode" "$dir"
  local blocks=("$dir"/*.sh)
  if [ ! -e "${blocks[0]}" ]; then fail "$doc has sh blocks to run"; return; fi
  local state="$dir/state.sh" block
  for block in "${blocks[@]}"; do
    local n; n=$(basename "$block" .sh)
    local where="$doc:$(cat "$dir/$n.line")"
    local first; first=$(grep -m 1 -v '^[[:space:]]*\(#.*\)\?$' "$block" | cut -c1-70)
    local name="$where: $first"
    local r
    for r in "${REWRITE[@]}"; do
      local from=${r%%=*} to=${r#*=}
      sed -i "s#${from//#/\\#}#${to//#/\\#}#g" "$block"
    done
    # Files the block writes: ours from an earlier block are removed first, so each block must
    # write its own; a file that was there before the test is the reader's and is left alone.
    local f
    while IFS= read -r f; do
      [ -n "$f" ] || continue
      if is_created "$f"; then rm -f -- "$(path_of "$f")"
      elif [ ! -e "$(path_of "$f")" ]; then CREATED+=("$f"); fi
    done < <(named_files "$block")
    # This test never installs software or runs the long commands: those belong in ```console.
    if grep -qE '(^|[[:space:];&|(])(scripts/(run|test|setup)\.sh|apt-get|apt |cmake --install|cpack|npm (ci|install))' "$block"; then
      fail "$name" "installs software or runs for long: fence it as console, not sh"
      continue
    fi
    local background=0
    grep -v '^[[:space:]]*\(#.*\)\?$' "$block" | tail -n 1 | grep -qE '(^|[^&])&[[:space:]]*(#.*)?$' && background=1
    if [ $background = 1 ] && grep -q featureline-server "$block"; then
      local port; port=$(port_of "$block")
      if listening "$port"; then
        fail "$name" "port $port is already in use, so this document's server cannot start;" \
             "stop whatever listens there and run the test again"
        return
      fi
    fi
    wrapper "$block" "$state" "$dir/$n.pid" "$dir/$n.run"
    local start; start=$(now_s)
    timeout 300 bash "$dir/$n.run" >"$dir/$n.out" 2>"$dir/$n.err" </dev/null
    local rc=$?
    local ok=1
    if [ $rc != 0 ]; then
      ok=0
      fail "$name" "exit status $rc" "stdout: $(head -c 400 "$dir/$n.out")" "stderr: $(tail -n 5 "$dir/$n.err")"
    elif json_error "$dir/$n.out"; then
      ok=0
      fail "$name" "a JSON answer carries an error:" "$(grep -m 3 error "$dir/$n.out" | cut -c1-300)"
    fi
    if [ $background = 1 ]; then
      local pid; pid=$(tr -dc 0-9 <"$dir/$n.pid" 2>/dev/null)
      if [ -z "$pid" ]; then
        fail "$name: started in the background" "no PID recorded"
        continue
      fi
      STARTED+=("$pid"); STARTED_LOGS+=("$dir/$n.err"); LOG_SEEN+=(0)
      if grep -q featureline-server "$block"; then
        local port up=0; port=$(port_of "$block")
        for _ in $(seq 1 200); do
          kill -0 "$pid" 2>/dev/null || break
          if curl -s -o /dev/null --max-time 1 "http://127.0.0.1:$port/healthz"; then up=1; break; fi
          sleep 0.1
        done
        if [ $up = 1 ]; then
          pass "$name (up on port $port in $(elapsed_since "$start") s)"
        else
          fail "$name" "the server did not answer /healthz on port $port within 20 s" "stderr: $(tail -n 5 "$dir/$n.err")"
          return
        fi
        LOG_SEEN[-1]=$(wc -l <"$dir/$n.err")
      elif [ $ok = 1 ]; then
        pass "$name"
      fi
      continue
    fi
    check_logs "$name" || ok=0
    while IFS= read -r f; do
      [ -n "$f" ] || continue
      local path; path=$(path_of "$f")
      if [ ! -s "$path" ]; then
        ok=0; fail "$name: wrote $f" "missing or empty"
      elif [ "$(head -c 1 "$path")" = "{" ] && json_error "$path"; then
        ok=0; fail "$name: wrote $f" "it holds an error: $(head -c 300 "$path")"
      fi
    done < <(named_files "$block")
    [ $ok = 1 ] && pass "$name"
  done
}
run_document() {
  run_blocks "$1"
  stop_started
}

for entry in "${DOCS[@]}"; do
  echo "# ${entry%%:*}"
  run_document "$entry"
done

# Links: every relative target in README.md and docs/*.md exists.
echo "# links"
broken=""
for doc in README.md docs/*.md; do
  base=$(dirname "$doc")
  while IFS= read -r target; do
    target=${target%%#*}
    [ -n "$target" ] || continue
    [ -e "$base/$target" ] || broken+="$doc -> $target"$'\n'
  done < <(grep -oE '\]\([^)]+\)' "$doc" | sed -E 's/^\]\(//; s/\)$//; s/[[:space:]].*$//' | grep -vE '^(https?:|mailto:|#)')
done
check_eq "every relative link in README.md and docs/ leads to a file" "$broken" ""
check "README.md cites no ../shared path (a clone has none)" bash -c "! grep -q '\.\./shared' README.md"
finish
