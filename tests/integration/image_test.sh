#!/usr/bin/env bash
# docker/Dockerfile.server built and run for real, with podman, as root. The base images come
# from scripts/container-base.sh (a registry's debian:12 when one was pulled, else a debootstrap
# root); the build uses chroot isolation and the host's network, which works where podman cannot
# create namespaces for a container. The image is then run without a container runtime: its
# root file system is mounted (podman create + podman mount) and its entrypoint runs there under
# chroot as the image's user, with /proc mounted in a private mount namespace (gone with the
# server). Against it: /healthz, an upload of samples/ridge_field.off, a feature line, the page at
# /, the upload written to /var/lib/featureline, and the process's user ids. Then the CLI image
# (docker/Dockerfile) is built the same way and its command run in its root file system.
# Prints the build context's size, each build's time and each image's size.
#
#   bash tests/integration/image_test.sh      (as root; about 5-10 minutes per image on 2 cores
#                                              when the sources changed, seconds when podman's
#                                              cache holds every layer)
# It needs no build of this checkout: the image builds the server from source.
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), check/pass/fail/finish, http
[ "$(id -u)" = 0 ] || { echo "FAIL the image test runs as root (podman's store, chroot, mount)"; exit 1; }
# Where / is not a mount point (a fresh machine made by debootstrap), podman's storage cannot make
# / private ("remount /: invalid argument") and no image can be imported or built: the test then
# runs itself again where it is one (in_private_mounts, lib.sh).
if ! root_is_mount_point; then
  echo "# / is not a mount point here: running in a private bind mount of /"
  in_private_mounts bash "$(realpath "${BASH_SOURCE[0]}")"
  exit $?
fi
for tool in curl jq unshare chroot; do command -v "$tool" >/dev/null || { echo "FAIL $tool is missing"; exit 1; }; done
FACTOR=1
CURL_MAX=60
IMAGE=featureline-server:test
CLI_IMAGE=featureline:test
CONTEXT_IMAGE=featureline-context:test
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-image.XXXXXX")
CONTAINERS=()
image_cleanup() {
  local id
  cleanup  # the server, by process id; then TMP
  for id in "${CONTAINERS[@]}"; do
    podman umount "$id" >/dev/null 2>&1
    podman rm -f "$id" >/dev/null 2>&1
  done
  podman rmi "$CONTEXT_IMAGE" >/dev/null 2>&1
}
trap image_cleanup EXIT

# mount_image IMAGE: a new container of IMAGE with its root file system mounted (writable);
# sets CID and ROOTFS.
mount_image() {
  CID=$(podman create "$1" 2>"$TMP/create.err") || { fail "podman create $1" "$(cat "$TMP/create.err")"; return 1; }
  CONTAINERS+=("$CID")
  ROOTFS=$(podman mount "$CID" 2>"$TMP/mount.err") || { fail "podman mount $1" "$(cat "$TMP/mount.err")"; return 1; }
  [ -d "$ROOTFS" ] || { fail "podman mount $1" "no directory: $ROOTFS"; return 1; }
}
unmount_image() {
  podman umount "$CID" >/dev/null && podman rm "$CID" >/dev/null
}

# ---- base images
if scripts/container-base.sh >"$TMP/base.log" 2>&1; then
  pass "scripts/container-base.sh: debian:12 and debian:12-slim in podman's store"
  sed 's/^/# /' "$TMP/base.log"
else
  fail "scripts/container-base.sh" "$(tail -n 20 "$TMP/base.log")"
  finish; exit 1
fi
command -v podman >/dev/null || { fail "podman is installed"; finish; exit 1; }
BUILD=(podman build --pull=never --network=host --isolation=chroot)

# ---- the build context, as podman sends it (.dockerignore applied by podman itself)
printf 'FROM debian:12-slim\nCOPY . /context/\n' >"$TMP/Containerfile.context"
if "${BUILD[@]}" --layers=false -q -f "$TMP/Containerfile.context" -t "$CONTEXT_IMAGE" . >"$TMP/context.log" 2>&1 &&
   mount_image "$CONTEXT_IMAGE"; then
  kib=$(du -sk "$ROOTFS/context" | cut -f1)
  files=$(find "$ROOTFS/context" -type f | wc -l)
  echo "# build context: $((kib / 1024)).$(((kib % 1024) * 10 / 1024)) MiB in $files files"
  for path in .git node_modules build; do
    check "the context has no $path/ (.dockerignore)" test ! -e "$ROOTFS/context/$path"
  done
  check "the context has no build*/ or web-dist/ folder" \
    test -z "$(find "$ROOTFS/context" -maxdepth 3 -type d \( -name 'build-*' -o -name web-dist -o -name node_modules \) -print -quit)"
  # Every committed file but the CI's is needed by one image or the other (sources, page, docs).
  lost=""
  if command -v git >/dev/null && git rev-parse --git-dir >/dev/null 2>&1; then
    lost=$(git ls-files | grep -v '^\.ci/' | while IFS= read -r f; do [ ! -e "$f" ] || [ -e "$ROOTFS/context/$f" ] || echo "$f"; done | head -n 5)
  fi
  check_eq "the context has every committed file (none lost to .dockerignore)" "$lost" ""
  unmount_image
  podman rmi "$CONTEXT_IMAGE" >/dev/null 2>&1
else
  fail "the build context can be copied into an image" "$(tail -n 20 "$TMP/context.log")"
fi

# build_image DOCKERFILE TAG: podman build with the flags above; prints the time and the size.
build_image() {
  local file=$1 tag=$2 old new start rc seconds size cached log="$TMP/build.$(basename "$1").log"
  old=$(podman image inspect --format '{{.Id}}' "$tag" 2>/dev/null)
  start=$(date +%s)
  "${BUILD[@]}" -f "$file" -t "$tag" . >"$log" 2>&1
  rc=$?
  seconds=$(($(date +%s) - start))
  if [ $rc != 0 ]; then
    fail "podman build $file (exit $rc after $seconds s)" "$(tail -n 30 "$log")"
    return 1
  fi
  pass "podman build $file"
  new=$(podman image inspect --format '{{.Id}}' "$tag")
  # The previous build's image, now untagged, is no use to the layer cache.
  if [ -n "$old" ] && [ "$old" != "$new" ]; then podman rmi "$old" >/dev/null 2>&1; fi
  size=$(podman image inspect --format '{{.Size}}' "$tag")
  cached=$(grep -c -- '--> Using cache' "$log")
  echo "# build of $file: $seconds s ($cached steps from podman's cache); image $tag: $((size / 1000000)) MB"
}
# image_path TAG: the PATH of the image's environment (Debian's default when it sets none).
image_path() {
  local path
  path=$(podman image inspect --format '{{json .Config.Env}}' "$1" | jq -r '.[]? | select(startswith("PATH=")) | sub("^PATH="; "")')
  echo "${path:-/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin}"
}

# ---- the server image
build_image docker/Dockerfile.server "$IMAGE" || { finish; exit 1; }
user=$(podman image inspect --format '{{.Config.User}}' "$IMAGE")
check_eq "the image's user" "${user%%:*}" 10001
entry=$(podman image inspect --format '{{json .Config.Entrypoint}}' "$IMAGE" | jq -r '.[0] // empty')
check_eq "the image's entrypoint program" "$entry" featureline-server
path=$(image_path "$IMAGE")

# ---- the image run: its root file system, chroot as its user
mount_image "$IMAGE" || { finish; exit 1; }
program=""
for dir in ${path//:/ }; do
  if [ -x "$ROOTFS$dir/$entry" ]; then program=$dir/$entry; break; fi
done
check "the entrypoint is in the image's PATH" test -n "$program"
check "the image has no compiler (runtime stage only)" test ! -e "$ROOTFS/usr/bin/g++" -a ! -e "$ROOTFS/usr/bin/cmake"
# The group a container runtime gives: USER's own, else the user's primary group in the image.
uid=${user%%:*}
gid=${user#*:}
[ "$gid" != "$user" ] || gid=$(awk -F: -v u="$uid" '$3 == u { print $4 }' "$ROOTFS/etc/passwd")
check_eq "the image's group (USER or /etc/passwd)" "$gid" 10001
check_eq "/var/lib/featureline belongs to the image's user" "$(stat -c %u:%g "$ROOTFS/var/lib/featureline" 2>&1)" "$uid:$gid"
[ -n "$program" ] && [ -n "$gid" ] || { finish; exit 1; }

port_file=/tmp/featureline.port  # inside the image
rm -f "$ROOTFS$port_file"
env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin unshare --mount --propagation private /bin/sh -c '
  mount -t proc proc "$1/proc" || exit 97
  root=$1 userspec=$2; shift 2
  exec chroot --userspec="$userspec" "$root" /usr/bin/env -i "PATH=$0" HOME=/var/lib/featureline "$@"' \
  "$path" "$ROOTFS" "$uid:$gid" "$program" --host 127.0.0.1 --port 0 --port-file "$port_file" --data-dir /var/lib/featureline \
  >"$TMP/server.out" 2>"$TMP/server.log" &
pid=$!
SRV_PID[image]=$pid
SRV_LOG[image]="$TMP/server.log"
base=""
for _ in $(seq 1 120); do  # up to 30 s
  kill -0 "$pid" 2>/dev/null || break
  port=$(tr -dc 0-9 2>/dev/null <"$ROOTFS$port_file")
  if [ -n "$port" ] && curl -s -o /dev/null --max-time 2 "http://127.0.0.1:$port/healthz"; then
    base="http://127.0.0.1:$port"; break
  fi
  sleep 0.25
done
if [ -z "$base" ]; then
  fail "the image's server starts in its root file system" "$(kill -0 "$pid" 2>/dev/null && echo "no answer after 30 s" || echo "it exited")" \
    "$(tail -n 20 "$TMP/server.log")"
  finish; exit 1
fi
pass "the image's server starts in its root file system (port $port)"

http "$TMP/healthz" "$base/healthz"
check_eq "GET /healthz" "$STATUS" 200
http "$TMP/upload" --data-binary @samples/ridge_field.off -H 'Content-Type: application/octet-stream' "$base/v1/meshes"
check_eq "POST /v1/meshes samples/ridge_field.off" "$STATUS" 201
id=$(jq -r '.mesh_id // empty' "$TMP/upload" 2>/dev/null)
check "the upload's answer has a mesh_id" test -n "$id"
http "$TMP/line" -X POST -H 'Content-Type: application/json' -d '{"keys": [701, 963, 1184]}' "$base/v1/meshes/$id/feature-lines"
check_eq "POST /v1/meshes/ID/feature-lines" "$STATUS" 200
points=$(jq '.refined.faces | length' "$TMP/line" 2>/dev/null)
check "the feature line's answer has refined points" test "${points:-0}" -ge 2
http "$TMP/page" "$base/"
check_eq "GET /" "$STATUS" 200
check "the page is HTML with a <script" grep -q '<script' "$TMP/page"
echo "# healthz: $(head -c 200 "$TMP/healthz")"
echo "# upload: $(jq -c '{mesh_id, vertices, faces}' "$TMP/upload" 2>/dev/null)"
echo "# feature line: $points refined points; page: $(wc -c <"$TMP/page") bytes"
check "the upload is kept in /var/lib/featureline by the image's user" \
  test -n "$(find "$ROOTFS/var/lib/featureline" -type f -uid "$uid" -print -quit)"
uids=$(awk '/^Uid:/ { print $2, $3, $4, $5 }' "/proc/$pid/status" 2>/dev/null)
gids=$(awk '/^Gid:/ { print $2, $3, $4, $5 }' "/proc/$pid/status" 2>/dev/null)
# Under in_private_mounts the kernel may name the binary from the namespace's real root (the
# bind mount's folder first): the path ends with the image's binary either way.
exe=$(readlink "/proc/$pid/exe")
check "the process is the image's server ($exe)" test "${exe%"$ROOTFS$program"}" != "$exe"
check_eq "the server runs as uid 10001 (real, effective, saved, fs)" "$uids" "10001 10001 10001 10001"
check_eq "the server runs as gid 10001" "$gids" "10001 10001 10001 10001"

stop_server image
check_eq "the server exits with 0 on SIGTERM" "$STOP_RC" 0
check "no mount is left in the image's root file system" bash -c "! findmnt -rn -o TARGET | grep -qF '$ROOTFS/'"
check "the container is unmounted and removed" unmount_image

# ---- the CLI image (docker/Dockerfile: scripts/setup.sh inside Debian 12), its command run as
# the image runs it: as root (no USER), from its working directory.
build_image docker/Dockerfile "$CLI_IMAGE" || { finish; exit 1; }
mount_image "$CLI_IMAGE" || { finish; exit 1; }
workdir=$(podman image inspect --format '{{.Config.WorkingDir}}' "$CLI_IMAGE")
mapfile -t command < <(podman image inspect --format '{{json .Config.Cmd}}' "$CLI_IMAGE" | jq -r '.[]?')
check_eq "the CLI image's command" "${command[*]:0:2}" "featureline detect"
start=$(date +%s)
inner='cd "$0" && exec "$@"'
timeout 120 env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin unshare --mount --propagation private /bin/sh -c '
  mount -t proc proc "$1/proc" || exit 97
  path=$0 root=$1 inner=$2; shift 2
  exec chroot "$root" /usr/bin/env -i "PATH=$path" HOME=/root /bin/sh -c "$inner" "$@"' \
  "$(image_path "$CLI_IMAGE")" "$ROOTFS" "$inner" "${workdir:-/}" "${command[@]}" >"$TMP/cli.json" 2>"$TMP/cli.err"
rc=$?
check_eq "the CLI image's command exits with 0" "$rc" 0
[ "$rc" = 0 ] || sed 's/^/       | /' "$TMP/cli.err" | tail -n 10
points=$(jq '.refined.points | length' "$TMP/cli.json" 2>/dev/null)
check "its answer is a feature line with refined points" test "${points:-0}" -ge 2
echo "# CLI image: ${command[*]}: $points refined points in $(($(date +%s) - start)) s"
check "the CLI container is unmounted and removed" unmount_image

finish
