#!/usr/bin/env bash
# Makes the base images docker/Dockerfile.server and docker/Dockerfile start from (debian:12 and
# debian:12-slim) available to podman without a registry: when a tag is missing from podman's
# local store, a minimal Debian 12 root made by debootstrap is imported under that tag. Tags
# already there (pulled from a registry, or imported by an earlier run) are left alone.
# Installs podman and debootstrap from Debian when they are missing. Needs root.
#   scripts/container-base.sh
# The debootstrap root is cached as a tarball in /var/cache/featureline-container (rebuilt only
# when the tarball is removed).
set -euo pipefail

[ "$(id -u)" = 0 ] || { echo "container-base: must run as root (debootstrap and podman's store)" >&2; exit 2; }

tools=()
command -v podman >/dev/null || tools+=(podman)
command -v debootstrap >/dev/null || tools+=(debootstrap)
if [ ${#tools[@]} -gt 0 ]; then
  echo "container-base: installing ${tools[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${tools[@]}" >/dev/null
fi

tags=(debian:12 debian:12-slim)
missing=()
for tag in "${tags[@]}"; do
  podman image exists "$tag" || missing+=("$tag")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "container-base: ${tags[*]} already in podman's store"
  exit 0
fi

mirror=http://deb.debian.org/debian
cache=/var/cache/featureline-container
base=$cache/bookworm-minbase.tar.gz
mkdir -p "$cache"
if [ ! -s "$base" ]; then
  echo "container-base: making a minimal Debian 12 root with debootstrap (a few minutes, once)"
  root=$(mktemp -d /var/tmp/featureline-container-base.XXXXXX)
  trap 'rm -rf --one-file-system "$root"' EXIT
  if ! debootstrap --variant=minbase bookworm "$root" "$mirror" >"$cache/debootstrap.log" 2>&1; then
    echo "container-base: debootstrap failed; the end of $cache/debootstrap.log:" >&2
    tail -n 15 "$cache/debootstrap.log" >&2
    exit 1
  fi
  # Like Debian's own images: security and point-release updates reachable by apt, no package
  # lists or downloaded archives in the image, and the resolver and host name given by the
  # container engine at run time rather than this machine's.
  cat >"$root/etc/apt/sources.list" <<EOF
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb ${mirror}-security bookworm-security main
EOF
  rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/*.bin "$root"/var/cache/apt/archives/*.deb
  rm -f "$root/etc/resolv.conf" "$root/etc/hostname"
  tar -C "$root" --numeric-owner -czf "$base.part" . && mv "$base.part" "$base"
  rm -rf --one-file-system "$root"
  trap - EXIT
fi

first=${missing[0]}
echo "container-base: importing $base as ${missing[*]}"
podman import --quiet \
  --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
  --change 'CMD ["bash"]' \
  --message "debootstrap --variant=minbase bookworm $mirror" \
  "$base" "$first" >/dev/null
for tag in "${missing[@]:1}"; do podman tag "$first" "$tag"; done
podman images --format '{{.Repository}}:{{.Tag}} {{.Size}}' | grep -E '/debian:12(-slim)? ' || true
