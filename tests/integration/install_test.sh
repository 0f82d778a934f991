#!/usr/bin/env bash
# Installing as a user or packager would: `cmake --install` into a prefix, the installed server
# serving its built-in page from anywhere, the man pages; the .deb from CPack, its dependencies
# read off the binaries, its programs run from the extracted package.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
FACTOR=1
CURL_MAX=60
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-install.XXXXXX")
trap cleanup EXIT
BUILD=${BUILD_DIR:-$ROOT/build}
version=$(sed -n 's/^  version: \(.*\)$/\1/p' "$ROOT/api/openapi.yaml")

cmake --install "$BUILD" --prefix "$TMP/prefix" >"$TMP/install.log" 2>&1
check "cmake --install succeeds" [ $? = 0 ]
for f in bin/featureline bin/featureline-server share/man/man1/featureline.1 share/man/man1/featureline-server.1 \
         share/doc/featureline/LICENSE share/doc/featureline/three.js.LICENSE share/doc/featureline/openapi.yaml; do
  check "installed $f" [ -s "$TMP/prefix/$f" ]
done
check "the man page is generated from --help" grep -q 'detect' "$TMP/prefix/share/man/man1/featureline.1"
check "... and lists the commands' pages" grep -q 'featureline-detect' "$TMP/prefix/share/man/man1/featureline.1"
for command in detect segment info features options; do
  page="$TMP/prefix/share/man/man1/featureline-$command.1"
  check "installed featureline-$command.1, titled by the command" grep -q "^\.TH FEATURELINE-${command^^} " "$page"
done
check "featureline-detect.1 is detect's own --help" grep -q 'keys' "$TMP/prefix/share/man/man1/featureline-detect.1"
check_eq "the installed CLI's --version" "$("$TMP/prefix/bin/featureline" --version)" "featureline $version"

# The installed server alone (run from an empty folder) serves its page.
cd "$TMP" || exit 1
SERVER="$TMP/prefix/bin/featureline-server" start_server installed --quiet
http "$TMP/index.html" "${SRV_BASE[installed]}/"
check_eq "the installed server serves its page at /" "$STATUS" 200
check "... as HTML" grep -q '<script' "$TMP/index.html"
stop_server installed
cd "$ROOT" || exit 1

cpack --config "$BUILD/CPackConfig.cmake" -G DEB -B "$TMP/package" >"$TMP/cpack.log" 2>&1
check "cpack makes a .deb" [ -s "$TMP/package/featureline_${version}_amd64.deb" ]
deb="$TMP/package/featureline_${version}_amd64.deb"
dpkg-deb -I "$deb" >"$TMP/deb.info" 2>&1
check "the package is featureline $version" grep -q "Version: $version" "$TMP/deb.info"
for lib in libopenmesh1 libcpp-httplib0.11 libdraco7 libhiredis0.14 libtinygltf2d; do
  check "the package depends on $lib (read off the binaries)" grep -q "Depends:.*$lib" "$TMP/deb.info"
done
dpkg-deb -c "$deb" >"$TMP/deb.files"
check "the package installs /usr/bin/featureline-server" grep -q ' \./usr/bin/featureline-server$' "$TMP/deb.files"
check "the package installs the man pages" grep -q ' \./usr/share/man/man1/featureline\.1' "$TMP/deb.files"
dpkg-deb -x "$deb" "$TMP/root"
check_eq "the packaged server runs" "$("$TMP/root/usr/bin/featureline-server" --version)" "featureline-server $version"
if [ "$(id -u)" = 0 ]; then
  apt-get install --simulate -qq "$deb" >"$TMP/apt.log" 2>&1
  check "apt can install the package here (its dependencies resolve)" [ $? = 0 ]
fi
finish
