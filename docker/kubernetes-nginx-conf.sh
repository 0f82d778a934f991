#!/usr/bin/env bash
# The nginx.conf of docker/kubernetes.yaml's front (ConfigMap featureline-front-nginx) is
# deploy/nginx.conf.template rendered by deploy/render-nginx-conf.sh, never edited by hand. This
# prints what the render gives for the manifest, or writes it into the manifest (--update), e.g.
# after a change of the template or of the autoscaler's maxReplicas; the deploy test
# (deploy_yaml_check.py) fails while the two differ.
#
#   docker/kubernetes-nginx-conf.sh [--update] [MANIFEST]     (default: docker/kubernetes.yaml)
#
# The render's inputs, as the front's pod runs nginx: state folder /tmp/nginx (its emptyDir),
# port 8080, uploads up to 256 MB (the replicas' --max-upload-mb, as Compose passes it), one
# Service per StatefulSet ordinal, featureline-0:8080 ... featureline-(M-1):8080 for M the
# HorizontalPodAutoscaler's maxReplicas, M tries (every ordinal above the autoscaler's count is
# absent and refuses), and no user directive (nginx starts as user 101). --update needs python3.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
update=0
[ "${1:-}" = --update ] && { update=1; shift; }
manifest=${1:-$here/kubernetes.yaml}
[ $# -le 1 ] && [ -f "$manifest" ] || { sed -n '8p' "$0" | sed 's/^# *//' >&2; exit 2; }

# maxReplicas of the HorizontalPodAutoscaler (the manifest has one, written in block style).
max=$(awk '/^---/ { hpa = 0 } /^kind: HorizontalPodAutoscaler$/ { hpa = 1 } hpa && /^  maxReplicas: *[0-9]+$/ { print $2 }' "$manifest")
[[ $max =~ ^[1-9][0-9]*$ ]] || { echo "kubernetes-nginx-conf.sh: no maxReplicas in $manifest's HorizontalPodAutoscaler" >&2; exit 1; }
servers=()
for ((i = 0; i < max; i++)); do servers+=("featureline-$i:8080"); done
conf=$(NGINX_USER=- NGINX_TRIES=$max "$here/../deploy/render-nginx-conf.sh" /tmp/nginx 8080 256 "${servers[@]}")
if [ $update = 0 ]; then printf '%s\n' "$conf"; exit 0; fi

# The ConfigMap's "nginx.conf: |" block, replaced line for line; the rest of the file as it is.
python3 - "$manifest" "$conf" <<'PY'
import re, sys
path, conf = sys.argv[1], sys.argv[2]
lines = open(path).read().split("\n")
doc_start = next(i for i, l in enumerate(lines) if l == "  name: featureline-front-nginx")
key = next(i for i in range(doc_start, len(lines)) if re.fullmatch(r"  nginx\.conf: \|", lines[i]))
end = key + 1
while end < len(lines) and (lines[end] == "" or lines[end].startswith("    ")):
    end += 1
while lines[end - 1] == "":  # blank lines before the next document belong to no block
    end -= 1
block = ["    " + l if l else "" for l in conf.split("\n")]
lines[key + 1:end] = block
open(path, "w").write("\n".join(lines))
PY
