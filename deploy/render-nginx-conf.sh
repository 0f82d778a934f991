#!/usr/bin/env bash
# Renders deploy/nginx.conf.template to stdout, for scripts/cluster.sh (loopback replicas) and
# for the containers of docker/ (replicas by service name: nginx resolves every address of a
# name, so "featureline:8080" with 3 replicas behind it gives 3 peers on the hash ring).
#
#   deploy/render-nginx-conf.sh STATE_DIR LISTEN MAX_UPLOAD_MB REPLICA... > nginx.conf
#     STATE_DIR      pid file, logs and temporary files (writable by nginx)
#     LISTEN         what nginx listens on: 127.0.0.1:8080, or 8080 for every address
#     MAX_UPLOAD_MB  the replicas' --max-upload-mb (larger bodies get 413 at the edge)
#     REPLICA        HOST:PORT of a featureline-server, one or more
#   NGINX_USER=name sets the workers' user; by default, started as root the workers run as
#   nobody:nogroup (never as root), otherwise nginx keeps the user who starts it. NGINX_USER=-
#   writes no user directive whoever renders: for a file rendered ahead of time for an nginx
#   that starts as a non-root user (docker/kubernetes.yaml's front).
#   NGINX_TEMP=DIR: where workers write request bodies and buffered answers (default
#   STATE_DIR/nginx-temp); workers running as another user must be able to reach it.
#   NGINX_TRIES=N: how many replicas one request may be tried on (default 3); with replicas
#   that may be absent (ordinals above an autoscaler's count), at least all of them.
set -euo pipefail
[ $# -ge 4 ] || { sed -n '6,18p' "$0" | sed 's/^# *//' >&2; exit 2; }
template="$(cd "$(dirname "$0")" && pwd)/nginx.conf.template"
state=$1 listen=$2 max_upload_mb=$3
shift 3
if [ "${NGINX_USER:-}" = - ] || { [ -z "${NGINX_USER:-}" ] && [ "$(id -u)" != 0 ]; }; then
  user="# user: not started as root, nginx keeps the user who started it"
elif [ -n "${NGINX_USER:-}" ]; then user="user $NGINX_USER;"
else user="user nobody nogroup;"; fi
temp=${NGINX_TEMP:-$state/nginx-temp}
tries=${NGINX_TRIES:-3}
[[ $tries =~ ^[1-9][0-9]*$ ]] || { echo "render-nginx-conf.sh: NGINX_TRIES must be a positive number, not '$tries'" >&2; exit 2; }
replicas=$(IFS='|'; echo "$*")
awk -v state="$state" -v temp="$temp" -v listen="$listen" -v mb="$max_upload_mb" -v user="$user" -v tries="$tries" -v replicas="$replicas" '
  { gsub(/@TEMP@/, temp); gsub(/@STATE@/, state); gsub(/@LISTEN@/, listen); gsub(/@MAX_UPLOAD_MB@/, mb); gsub(/@USER@/, user)
    gsub(/@TRIES@/, tries) }
  /^@REPLICAS@$/ {
    n = split(replicas, r, "|")
    for (i = 1; i <= n; i++) printf "    server %s max_fails=1 fail_timeout=10s;\n", r[i]
    next
  }
  { print }' "$template"
