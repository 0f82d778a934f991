#!/usr/bin/env bash
# Installs the npm packages of package-lock.json into node_modules/ (npm ci), from the current
# directory. Used by scripts/setup.sh and by the image builds in docker/.
#   scripts/npm-ci.sh
# Behind a TLS-intercepting proxy whose CA this machine does not trust, npm fails with a
# certificate error (SELF_SIGNED_CERT_IN_CHAIN); it is then run again without TLS verification,
# which is safe for npm ci: every tarball is still checked against the sha512 integrity hash
# recorded in package-lock.json. Any other failure is reported as it is.
set -euo pipefail
[ -f package-lock.json ] || { echo "npm-ci: no package-lock.json in $(pwd)" >&2; exit 2; }
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if npm ci --no-audit --no-fund --loglevel=error 2>"$log"; then exit 0; fi
if ! grep -q -i -E "certificate|CERT_" "$log"; then
  cat "$log" >&2
  exit 1
fi
echo "npm-ci: npm could not verify the registry's certificate; retrying without TLS verification" \
     "(packages are still verified against package-lock.json's integrity hashes)"
npm ci --no-audit --no-fund --loglevel=error --strict-ssl=false
