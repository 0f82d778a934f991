#!/usr/bin/env bash
# What can be checked of docker/ and deploy/ without a Docker engine: the nginx
# template renders and passes `nginx -t` as the compose file renders it, and so does the
# Kubernetes front's nginx.conf (the ConfigMap's text, its upstream names resolved in a private
# /etc/hosts), which also routes and fails over as it should (front_failover.sh: as root, 3 of 6
# ordinals present, one replica SIGKILLed); the compose file and the Kubernetes manifests parse and describe the topology
# (replicas on the Redis store, liveness and startup on /healthz, readiness on /readyz, nginx
# hashing on the mesh id with its edge limits) and meet what deploy_yaml_check.py asks of them
# (scripts/cluster.sh's --http-threads, memory from --cache-mb, preStop and grace period,
# PodDisruptionBudgets, HPA, spread, pinned images, the restricted Pod Security Standard,
# network policies, Redis' password from an operator's Secret or env file and never a literal,
# the front's nginx.conf rendered from the template with a Service per replica ordinal and
# retries that reach them all), each check shown to fail on a copy broken for it; Redis started
# as each file's container starts it (a local
# redis-server, the image's paths mapped) wants the password, has protected mode on and passes
# its own probe with the password only; the image is multi-stage
# and non-root, its build packages are among scripts/setup.sh's, and its runtime packages own
# every shared library the tested server binary links (ldd + dpkg -S).
#
#   SERVER=build/server/featureline-server bash tests/integration/deploy_files_test.sh
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), SERVER, SHARED, MESHES, VR, VG, JOBS
for tool in python3 dpkg ldd ss; do command -v "$tool" >/dev/null || { echo "FAIL $tool is missing"; exit 1; }; done
[ -x /usr/sbin/nginx ] || { echo "FAIL nginx is not installed (scripts/setup.sh)"; exit 1; }
python3 -c 'import yaml' 2>/dev/null || { echo "FAIL python3-yaml is not installed (scripts/setup.sh)"; exit 1; }
[ -x "$SERVER" ] || { echo "FAIL no server binary at $SERVER"; exit 1; }
TMP=$(mktemp -d "${TMPDIR:-/tmp}/featureline-deploy.XXXXXX")
trap cleanup EXIT

# ---- nginx: the template as compose renders it (names replaced by loopback: nginx -t resolves them)
mkdir -p "$TMP/nginx/logs" "$TMP/nginx/nginx-temp"
deploy/render-nginx-conf.sh "$TMP/nginx" 18080 256 127.0.0.1:18081 >"$TMP/nginx/nginx.conf"
out=$(/usr/sbin/nginx -t -p "$TMP/nginx" -e "$TMP/nginx/logs/nginx-error.log" -c "$TMP/nginx/nginx.conf" 2>&1)
check "nginx -t accepts the rendered template" grep -q "test is successful" <<<"$out"
for directive in 'hash $mesh_id consistent' 'client_header_timeout 10s' 'client_body_timeout 30s' \
                 'client_max_body_size 256m' 'limit_conn per_address' 'proxy_request_buffering on' \
                 'proxy_next_upstream error timeout http_502 non_idempotent' 'max_fails=1 fail_timeout=10s'; do
  check "the rendered nginx.conf has: $directive" grep -qF "$directive" "$TMP/nginx/nginx.conf"
done
check "no @PLACEHOLDER@ left" bash -c "! grep -q '@[A-Z_]*@' '$TMP/nginx/nginx.conf'"
if [ "$(id -u)" = 0 ]; then
  check_eq "rendered as root, the workers' user is nobody (never root)" "$(grep -E '^user ' "$TMP/nginx/nginx.conf")" "user nobody nogroup;"
fi
check_eq "NGINX_USER names the workers' user" \
  "$(NGINX_USER=www-data deploy/render-nginx-conf.sh "$TMP/nginx" 18080 256 127.0.0.1:18081 | grep -E '^user ')" "user www-data;"
check "NGINX_TEMP moves the workers' temporary files" \
  bash -c "NGINX_TEMP=/run/x deploy/render-nginx-conf.sh '$TMP/nginx' 18080 256 127.0.0.1:18081 | grep -q 'client_body_temp_path /run/x/client_body;'"
check "nothing outside the state folder is written (no /var paths)" bash -c "! grep -E '^[^#]*/var/' '$TMP/nginx/nginx.conf'"
check "NGINX_USER=- writes no user directive, even as root" \
  bash -c "NGINX_USER=- deploy/render-nginx-conf.sh '$TMP/nginx' 18080 256 127.0.0.1:18081 | grep -q '^# user: not started as root'"
check "proxy_next_upstream_tries is 3 by default" grep -qx '    proxy_next_upstream_tries 3;' "$TMP/nginx/nginx.conf"
check "NGINX_TRIES sets proxy_next_upstream_tries" \
  bash -c "NGINX_TRIES=6 deploy/render-nginx-conf.sh '$TMP/nginx' 18080 256 127.0.0.1:18081 | grep -qx '    proxy_next_upstream_tries 6;'"
deploy/render-nginx-conf.sh >/dev/null 2>&1
check_eq "render-nginx-conf.sh without replicas is a usage error" "$?" 2
NGINX_TRIES=0 deploy/render-nginx-conf.sh "$TMP/nginx" 18080 256 127.0.0.1:18081 >/dev/null 2>&1
check_eq "render-nginx-conf.sh refuses NGINX_TRIES=0" "$?" 2

# ---- the Kubernetes front's nginx.conf: the ConfigMap's own text. nginx -t resolves upstream names,
# so the Services featureline-0 ... get loopback addresses in an /etc/hosts that only this nginx
# sees (a private mount namespace, where /tmp, the pod's emptyDir, is a private tmpfs too), and
# nginx runs as the pod's user 101 where this test runs as root.
python3 -c '
import sys, yaml
docs = [d for d in yaml.safe_load_all(open(sys.argv[1])) if d]
cm = next(d for d in docs if d["kind"] == "ConfigMap" and d["metadata"]["name"] == "featureline-front-nginx")
open(sys.argv[2], "w").write(cm["data"]["nginx.conf"])' docker/kubernetes.yaml "$TMP/front.conf"
front_names=$(grep -oE '^ *server [a-z0-9-]+:' "$TMP/front.conf" | sed 's/^ *server //; s/:$//' | sort -u)
check "the front's upstreams name the replicas' Services" test -n "$front_names"
{ cat /etc/hosts; i=10; for n in $front_names; do echo "127.0.0.$i $n"; i=$((i + 1)); done; } >"$TMP/hosts"
# front_nginx_t HOSTS_FILE: nginx -t on the front's nginx.conf, with HOSTS_FILE as /etc/hosts.
# Not root: a user namespace, where only root is mapped, so nginx keeps it for its workers.
front_nginx_t() {
  local ns=(in_private_mounts) as=(setpriv --reuid=101 --regid=101 --clear-groups) user=""
  [ "$(id -u)" = 0 ] || { ns=(unshare --user --map-root-user --mount --propagation private); as=(env); user="user root;"; }
  # Where user 101 reaches nothing (a fresh machine whose / is a 0700 folder): nginx as root.
  "${as[@]}" test -x /usr/sbin/nginx 2>/dev/null || { as=(env); user="user root;"; }
  "${ns[@]}" bash -c 'set -e; exec 3<"$1"; mount --bind "$2" /etc/hosts; mount -t tmpfs -o size=16m,mode=1777 tmpfs /tmp
    mkdir -p /tmp/nginx/logs /tmp/nginx/nginx-temp /tmp/etc; cat <&3 >/tmp/etc/nginx.conf
    [ -n "$3" ] || chown -R 101:101 /tmp/nginx
    g=$3; shift 3; "$@" /usr/sbin/nginx -t -p /tmp/nginx -e stderr -c /tmp/etc/nginx.conf ${g:+-g "$g"} 2>&1' \
    _ "$TMP/front.conf" "$1" "$user" "${as[@]}" 2>&1
}
out=$(front_nginx_t "$TMP/hosts")
check "nginx -t accepts the Kubernetes front's nginx.conf (the ConfigMap's text)" grep -q "test is successful" <<<"$out" ||
  sed 's/^/       | /' <<<"$out" | head -5
out=$(front_nginx_t /etc/hosts)
check "... and refuses it where the Services' names do not resolve (so they were resolved)" \
  grep -q 'host not found in upstream "featureline-0:8080"' <<<"$out"
# ... and run: routing and failover with stand-in replicas for 3 of the 6 ordinals, one SIGKILLed
# (front_failover.sh, in a network namespace of its own: needs root).
if [ "$(id -u)" = 0 ]; then
  in_private_mounts timeout 120 unshare --net bash "$HERE/front_failover.sh" "$TMP/front.conf" \
    >"$TMP/failover.out" 2>"$TMP/failover.err"
  while IFS= read -r line; do
    case "$line" in
      "PASS "*) pass "front failover: ${line#PASS }" ;;
      "FAIL "*) fail "front failover: ${line#FAIL }" ;;
      *) fail "front_failover.sh: $line" ;;
    esac
  done <"$TMP/failover.out"
  check "front_failover.sh ran its 9 checks" test "$(grep -c '^PASS \|^FAIL ' "$TMP/failover.out")" = 9 ||
    sed 's/^/       | /' "$TMP/failover.err" | tail -5
else
  echo "skip the Kubernetes front's failover run (front_failover.sh needs root for a network namespace)"
fi

# ---- compose and Kubernetes: parse, describe the topology, agree with scripts/cluster.sh, the
# server's defaults and its image; resources, failover, disruption budget, autoscaling, spread,
# pinned images, the restricted Pod Security Standard, network policies (deploy_yaml_check.py)
help=$("$SERVER" --help)
cache_default=$(grep -oE -- '--cache-mb [^=]*=[0-9]+' <<<"$help" | sed 's/.*=//')
deadline_default=$(grep -oE -- '--deadline-s [^=]*=[0-9.]+' <<<"$help" | sed 's/.*=//')
check "the server's --help gives the defaults of --cache-mb and --deadline-s" test -n "$cache_default" -a -n "$deadline_default"
yaml_check() { python3 "$HERE/deploy_yaml_check.py" "$1" "${cache_default:-1024}" "${deadline_default:-30}"; }
yaml_check . >"$TMP/yaml.out" 2>&1
while IFS= read -r line; do
  case "$line" in
    "PASS "*) pass "${line#PASS }" ;;
    "FAIL "*) fail "${line#FAIL }" ;;
    *) fail "deploy_yaml_check.py: $line" ;;
  esac
done <"$TMP/yaml.out"
check "deploy_yaml_check.py ran its checks" grep -q '^PASS ' "$TMP/yaml.out"

# Each check above can fail: a copy broken in one way fails the check that guards it.
# mutant NAME EXPECTED_FAILURE FILE PYTHON queues one: PYTHON edits `docs` (the YAML documents of
# FILE, a list) in place, with obj(kind, name) for a Kubernetes object; FILE = scripts/cluster.sh
# or deploy/nginx.conf.template takes a sed expression instead. run_mutants runs the queue in one
# Python process (deploy_yaml_check.py on each copy), and each must show its expected failure.
: >"$TMP/mutants"
mutant() { printf '%s\0' "$@" >>"$TMP/mutants"; }
run_mutants() {
  python3 - "$TMP/mutants" "$TMP/mutant" "$HERE/deploy_yaml_check.py" "${cache_default:-1024}" "${deadline_default:-30}" \
    >"$TMP/mutants.out" 2>"$TMP/mutants.err" <<'PY'
import contextlib, io, os, runpy, shutil, subprocess, sys
import yaml
queue, m, check_script, cache, deadline = sys.argv[1:6]
fields = open(queue).read().split("\0")[:-1]
for k in range(0, len(fields), 4):
    name, want, path, edit = fields[k:k + 4]
    shutil.rmtree(m, ignore_errors=True)
    os.makedirs(m + "/scripts")
    for d in ("docker", "deploy"):
        shutil.copytree(d, "%s/%s" % (m, d))
    shutil.copy("scripts/cluster.sh", m + "/scripts/")
    for f in ("CMakeLists.txt", ".gitignore", ".dockerignore"):
        shutil.copy(f, m)
    if os.path.exists(m + "/docker/redis.env"):
        os.remove(m + "/docker/redis.env")
    target = "%s/%s" % (m, path)
    if path in ("scripts/cluster.sh", "deploy/nginx.conf.template"):
        subprocess.run(["sed", "-i", edit, target], check=True)
    else:
        docs = [d for d in yaml.safe_load_all(open(target)) if d]
        def obj(kind, name):
            return next(d for d in docs if d.get("kind") == kind and d["metadata"]["name"] == name)
        exec(edit)
        yaml.safe_dump_all(docs, open(target, "w"), sort_keys=False)
    out = io.StringIO()
    sys.argv = [check_script, m, cache, deadline]
    with contextlib.redirect_stdout(out):
        try:
            runpy.run_path(check_script, run_name="__main__")
        except SystemExit:
            pass
    if "FAIL " + want in out.getvalue():
        print("PASS broken copy fails: " + name)
    else:
        print("FAIL broken copy fails: " + name)
        for line in [l for l in out.getvalue().splitlines() if not l.startswith("PASS")][:5]:
            print("%s | %s" % (name, line), file=sys.stderr)
PY
  local line
  while IFS= read -r line; do
    case "$line" in
      "PASS "*) pass "${line#PASS }" ;;
      "FAIL "*) fail "${line#FAIL }" "$(grep -F "${line#FAIL broken copy fails: } | " "$TMP/mutants.err" | head -5)" ;;
      *) fail "run_mutants: $line" ;;
    esac
  done <"$TMP/mutants.out"
  check_eq "every broken copy was run" "$(grep -c '^PASS \|^FAIL ' "$TMP/mutants.out")" "$(($(tr -cd '\0' <"$TMP/mutants" | wc -c) / 4))" ||
    sed 's/^/       | /' "$TMP/mutants.err" | tail -5
}
K=docker/kubernetes.yaml C=docker/compose.yaml
fl_pod='obj("StatefulSet", "featureline")["spec"]["template"]["spec"]'
mutant "cluster.sh's --http-threads changed" "compose replicas' --http-threads is scripts/cluster.sh's" \
  scripts/cluster.sh 's/--http-threads 256/--http-threads 512/'
mutant "kubernetes replicas without --http-threads" "kubernetes replicas' --http-threads" $K \
  "a = $fl_pod['containers'][0]['args']; i = a.index('--http-threads'); del a[i:i + 2]"
mutant "kubernetes replicas without --threads" "kubernetes: --threads is the pod's CPU request" $K \
  "a = $fl_pod['containers'][0]['args']; i = a.index('--threads'); del a[i:i + 2]"
mutant "--threads from the memory request" "kubernetes: --threads is the pod's CPU request" $K \
  "e = $fl_pod['containers'][0]['env']; next(x for x in e if x['name'] == 'FEATURELINE_CPU_REQUEST')['valueFrom']['resourceFieldRef']['resource'] = 'requests.memory'"
mutant "memory limit 1536Mi for a 1024 MiB cache" "kubernetes: memory limit >= 2 x --cache-mb" $K \
  "$fl_pod['containers'][0]['resources']['limits']['memory'] = '1536Mi'"
mutant "a larger --cache-mb under the same limit" "kubernetes: memory limit >= 2 x --cache-mb (1536)" $K \
  "a = $fl_pod['containers'][0]['args']; a[a.index('--cache-mb') + 1] = '1536'"
mutant "compose memory limit 1536M" "compose replicas' memory limit" $C \
  "for r in ['featureline-1', 'featureline-2', 'featureline-3']: docs[0]['services'][r]['deploy']['resources']['limits']['memory'] = '1536M'"
mutant "no preStop hook" "kubernetes: a preStop hook" $K "del $fl_pod['containers'][0]['lifecycle']"
mutant "grace period shorter than --deadline-s" "kubernetes: terminationGracePeriodSeconds" $K \
  "$fl_pod['terminationGracePeriodSeconds'] = 30"
mutant "a ConfigMap of another namespace shipped" "kubernetes: ConfigMap ingress-nginx-controller is in namespace featureline" $K \
  "docs.append({'apiVersion': 'v1', 'kind': 'ConfigMap', 'metadata': {'name': 'ingress-nginx-controller', 'namespace': 'ingress-nginx'}, 'data': {}})"
mutant "no PodDisruptionBudget" "kubernetes: PodDisruptionBudget featureline" $K \
  "docs.remove(obj('PodDisruptionBudget', 'featureline'))"
mutant "replicas field next to the HPA" "kubernetes: the StatefulSet leaves the replica count to the HPA" $K \
  "obj('StatefulSet', 'featureline')['spec']['replicas'] = 3"
mutant "no spread across nodes" "kubernetes: replicas spread across nodes" $K "del $fl_pod['topologySpreadConstraints']"
mutant "server image :latest" "kubernetes featureline/featureline-server: image pinned" $K \
  "$fl_pod['containers'][0]['image'] = 'featureline-server:latest'"
mutant "redis:7.0 (not an exact release)" "kubernetes redis/redis: image pinned" $K \
  "obj('StatefulSet', 'redis')['spec']['template']['spec']['containers'][0]['image'] = 'redis:7.0'"
mutant "compose replicas as one service scaled to 3" "compose services are redis, featureline-1..3, nginx" $C \
  "s = docs[0]['services']; s['featureline'] = s.pop('featureline-1'); s['featureline']['deploy']['replicas'] = 3; del s['featureline-2'], s['featureline-3']"
mutant "compose nginx given one name for the replicas" "compose nginx names every replica on its own" $C \
  "docs[0]['services']['nginx']['command'][2] = docs[0]['services']['nginx']['command'][2].replace('featureline-1:8080 featureline-2:8080 featureline-3:8080', 'featureline:8080')"
mutant "compose replica 2 configured differently" "compose: the 3 replicas are configured alike" $C \
  "s = docs[0]['services']; s['featureline-2'] = dict(s['featureline-2'], command=['--store', 'redis://redis:6379'])"
mutant "compose nginx not waiting for replica 3" "compose nginx waits for every replica to be healthy" $C \
  "del docs[0]['services']['nginx']['depends_on']['featureline-3']"
mutant "compose nginx unpinned" "compose nginx: image pinned" $C "docs[0]['services']['nginx']['image'] = 'nginx'"
mutant "Redis allows privilege escalation" "restricted redis/redis: allowPrivilegeEscalation false" $K \
  "obj('StatefulSet', 'redis')['spec']['template']['spec']['containers'][0]['securityContext']['allowPrivilegeEscalation'] = True"
mutant "no seccomp profile" "restricted featureline/featureline-server: seccompProfile" $K \
  "del $fl_pod['securityContext']['seccompProfile']"
mutant "a capability kept" "restricted featureline/featureline-server: capabilities drop ALL" $K \
  "$fl_pod['containers'][0]['securityContext']['capabilities'] = {'drop': ['NET_RAW']}"
mutant "another user than the image's" "kubernetes: the replicas run as the image's user" $K \
  "$fl_pod['securityContext']['runAsUser'] = 1000"
mutant "namespace without the restricted label" "kubernetes: the namespace enforces the restricted" $K \
  "obj('Namespace', 'featureline')['metadata']['labels'] = {}"
mutant "Redis open to every pod" "kubernetes: a NetworkPolicy admits only the replicas to Redis" $K \
  "obj('NetworkPolicy', 'redis')['spec']['ingress'][0]['from'] = [{'podSelector': {}}]"
mutant "replicas open to every address" "kubernetes: a NetworkPolicy admits only the front to the replicas" $K \
  "obj('NetworkPolicy', 'featureline')['spec']['ingress'][0].pop('from')"
mutant "replicas open to ingress-nginx's pods" "kubernetes: a NetworkPolicy admits only the front to the replicas" $K \
  "obj('NetworkPolicy', 'featureline')['spec']['ingress'][0]['from'] = [{'namespaceSelector': {'matchLabels': {'kubernetes.io/metadata.name': 'ingress-nginx'}}, 'podSelector': {'matchLabels': {'app.kubernetes.io/name': 'ingress-nginx'}}}]"
# The front: its nginx.conf rendered from the template, a Service per ordinal, retries that reach them.
front_pod='obj("Deployment", "featureline-front")["spec"]["template"]["spec"]'
front_conf='obj("ConfigMap", "featureline-front-nginx")["data"]'
conf_edit() { echo "d = $front_conf; d['nginx.conf'] = d['nginx.conf'].replace($1)"; }
mutant "the front's nginx.conf edited by hand" "kubernetes front: the ConfigMap's nginx.conf is deploy/render-nginx-conf.sh's output" $K \
  "$(conf_edit "'client_header_timeout 10s', 'client_header_timeout 20s'")"
mutant "the template changed, the front's nginx.conf not rendered again" \
  "kubernetes front: the ConfigMap's nginx.conf is deploy/render-nginx-conf.sh's output" deploy/nginx.conf.template \
  's/client_header_timeout 10s/client_header_timeout 20s/'
mutant "maxReplicas 8 with Services for 6" "kubernetes: a ClusterIP Service for each replica ordinal" $K \
  "obj('HorizontalPodAutoscaler', 'featureline')['spec']['maxReplicas'] = 8"
mutant "an ordinal's Service missing" "kubernetes: a ClusterIP Service for each replica ordinal" $K \
  "docs.remove(obj('Service', 'featureline-4'))"
mutant "an ordinal's Service selecting every replica" "kubernetes: a ClusterIP Service for each replica ordinal" $K \
  "del obj('Service', 'featureline-2')['spec']['selector']['statefulset.kubernetes.io/pod-name']"
mutant "an ordinal's Service headless" "kubernetes: a ClusterIP Service for each replica ordinal" $K \
  "obj('Service', 'featureline-1')['spec']['clusterIP'] = 'None'"
mutant "an ordinal missing from the front's upstreams" "kubernetes front: every upstream lists the ordinals' Services" $K \
  "$(conf_edit "'    server featureline-5:8080 max_fails=1 fail_timeout=10s;\n', ''")"
mutant "the front's hash not consistent" "kubernetes front: an upstream hashes on \$mesh_id, consistent" $K \
  "$(conf_edit "'hash \$mesh_id consistent;', 'hash \$mesh_id;'")"
mutant "the front without passive health checks" "kubernetes front: a replica that fails is skipped for a while" $K \
  "$(conf_edit "' max_fails=1 fail_timeout=10s', ''")"
mutant "the front not retrying a refused connection" "kubernetes front: a refused, failed or timed-out request goes to the next replica" $K \
  "$(conf_edit "'proxy_next_upstream error timeout', 'proxy_next_upstream timeout'")"
mutant "the front not retrying uploads" "kubernetes front: a refused, failed or timed-out request goes to the next replica" $K \
  "$(conf_edit "' non_idempotent;', ';'")"
mutant "3 tries for 6 ordinals" "kubernetes front: proxy_next_upstream_tries" $K \
  "$(conf_edit "'proxy_next_upstream_tries 6;', 'proxy_next_upstream_tries 3;'")"
mutant "the HPA on a Deployment" "kubernetes: the HPA scales the featureline StatefulSet" $K \
  "obj('HorizontalPodAutoscaler', 'featureline')['spec']['scaleTargetRef']['kind'] = 'Deployment'"
mutant "pods created one after another" "kubernetes: the StatefulSet creates and removes pods in parallel" $K \
  "del obj('StatefulSet', 'featureline')['spec']['podManagementPolicy']"
mutant "the StatefulSet's Service not headless" "kubernetes: the StatefulSet's serviceName is a headless Service" $K \
  "del obj('Service', 'featureline-replicas')['spec']['clusterIP']"
mutant "one front pod" "kubernetes front: at least 2 nginx pods" $K "obj('Deployment', 'featureline-front')['spec']['replicas'] = 1"
mutant "the front's nginx unpinned" "kubernetes featureline-front/nginx: image pinned" $K "$front_pod['containers'][0]['image'] = 'nginx'"
mutant "the front's nginx another release than Compose's" "kubernetes front: the image Compose runs" $K \
  "$front_pod['containers'][0]['image'] = 'nginx:1.25.3'"
mutant "the front as root" "restricted featureline-front/nginx: runAsUser not 0" $K "$front_pod['securityContext']['runAsUser'] = 0"
mutant "the front as another user than Compose's nginx" "kubernetes front: nginx runs as Compose's nginx user" $K \
  "$front_pod['securityContext']['runAsUser'] = 1000"
mutant "the front's root file system writable" "featureline-front/nginx: read-only root file system" $K \
  "del $front_pod['containers'][0]['securityContext']['readOnlyRootFilesystem']"
mutant "the front allows privilege escalation" "restricted featureline-front/nginx: allowPrivilegeEscalation false" $K \
  "$front_pod['containers'][0]['securityContext']['allowPrivilegeEscalation'] = True"
mutant "the front keeps its capabilities" "restricted featureline-front/nginx: capabilities drop ALL" $K \
  "del $front_pod['containers'][0]['securityContext']['capabilities']"
mutant "the front without a seccomp profile" "restricted featureline-front/nginx: seccompProfile" $K \
  "del $front_pod['securityContext']['seccompProfile']"
mutant "the front reading another nginx.conf" "kubernetes front: nginx runs the ConfigMap's nginx.conf" $K \
  "a = $front_pod['containers'][0]['args']; a[0] = a[0].replace('/etc/featureline/nginx.conf', '/etc/nginx/nginx.conf')"
mutant "the front without its writable /tmp" "kubernetes front: every file nginx writes" $K \
  "c = $front_pod['containers'][0]; c['volumeMounts'] = [m for m in c['volumeMounts'] if m['mountPath'] != '/tmp']"
mutant "the front's container port not nginx's" "kubernetes front: nginx listens on the container's port" $K \
  "$front_pod['containers'][0]['ports'][0]['containerPort'] = 80"
mutant "the front without a readiness probe" "kubernetes front: readiness and liveness probes" $K \
  "del $front_pod['containers'][0]['readinessProbe']"
mutant "the front's preStop only sleeps" "kubernetes front: a preStop hook sleeps, then nginx quits gracefully" $K \
  "$front_pod['containers'][0]['lifecycle']['preStop']['exec']['command'] = ['sleep', '5']"
mutant "the front's grace period shorter than a request" "kubernetes front: terminationGracePeriodSeconds" $K \
  "$front_pod['terminationGracePeriodSeconds'] = 30"
mutant "the front not spread" "kubernetes front: nginx pods spread across nodes" $K "del $front_pod['topologySpreadConstraints']"
mutant "no PodDisruptionBudget for the front" "kubernetes front: a PodDisruptionBudget selects the front" $K \
  "docs.remove(obj('PodDisruptionBudget', 'featureline-front'))"
mutant "the front's Service selecting the replicas" "kubernetes front: its Service selects the nginx pods" $K \
  "obj('Service', 'featureline-front')['spec']['selector'] = {'app': 'featureline'}"
mutant "a LoadBalancer that hides clients' addresses" "kubernetes front: its Service is ClusterIP, or a LoadBalancer" $K \
  "obj('Service', 'featureline-front')['spec']['externalTrafficPolicy'] = 'Cluster'"
mutant "the front open on every port" "kubernetes front: a NetworkPolicy admits clients to nginx's port only" $K \
  "del obj('NetworkPolicy', 'featureline-front')['spec']['ingress'][0]['ports']"
mutant "no NetworkPolicy for the front" "kubernetes front: a NetworkPolicy admits clients to nginx's port only" $K \
  "docs.remove(obj('NetworkPolicy', 'featureline-front'))"
mutant "an Ingress hashing on the mesh id" "kubernetes: no Ingress hashes by itself" $K \
  "docs.append({'apiVersion': 'networking.k8s.io/v1', 'kind': 'Ingress', 'metadata': {'name': 'featureline', 'namespace': 'featureline', 'annotations': {'nginx.ingress.kubernetes.io/upstream-hash-by': '\$mesh_id'}}, 'spec': {}})"
redis_k='obj("StatefulSet", "redis")["spec"]["template"]["spec"]["containers"][0]'
mutant "a Redis password the replicas do not send" "kubernetes replicas: FEATURELINE_REDIS_PASSWORD from the Secret" $K \
  "del $fl_pod['containers'][0]['env']"
mutant "the replicas' password from another Secret" "kubernetes replicas: FEATURELINE_REDIS_PASSWORD from the Secret" $K \
  "$fl_pod['containers'][0]['env'][0]['valueFrom']['secretKeyRef']['name'] = 'other'"
mutant "the password a literal env value" "kubernetes: no password as a literal env value" $K \
  "$fl_pod['containers'][0]['env'] = [{'name': 'FEATURELINE_REDIS_PASSWORD', 'value': 'x'}]"
mutant "the password in the store URL" "kubernetes replicas: the store URL carries no password" $K \
  "a = $fl_pod['containers'][0]['args']; a[a.index('redis://redis:6379')] = 'redis://:x@redis:6379'"
mutant "a Secret shipped with a password" "kubernetes: no Secret shipped" $K \
  "docs.append({'apiVersion': 'v1', 'kind': 'Secret', 'metadata': {'name': 'featureline-redis', 'namespace': 'featureline'}, 'stringData': {'password': 'x'}})"
mutant "Redis' password on its command line" "kubernetes Redis: no --requirepass on its command line" $K \
  "c = $redis_k; c['args'] = [c['args'][0].split(' - <<')[0] + ' --requirepass \"\$REDISCLI_AUTH\"']"
mutant "Redis without a password" "kubernetes Redis: requirepass from a Secret's variable" $K \
  "c = $redis_k; c['args'] = [c['args'][0].split(' - <<')[0]]; del c['env']"
mutant "Redis' protected mode off" "kubernetes Redis: protected mode on" $K \
  "c = $redis_k; c['args'] = [c['args'][0].replace('--protected-mode yes', '--protected-mode no')]"
mutant "Redis' probe without the password" "kubernetes Redis: its probe authenticates" $K \
  "c = $redis_k; c['readinessProbe']['exec']['command'] = ['redis-cli', 'ping']"
mutant "compose replicas without the env file" "compose: Redis and the replicas read the same env file" $C \
  "for r in ['featureline-1', 'featureline-2', 'featureline-3']: docs[0]['services'][r].pop('env_file', None)"
mutant "compose env file git does not ignore" "compose: the env file docker/secrets.env is the operator's" $C \
  "for r in ['featureline-1', 'featureline-2', 'featureline-3']: docs[0]['services'][r]['env_file'] = docs[0]['services']['redis']['env_file'] = ['secrets.env']"
mutant "compose password in environment:" "compose: no password in an environment: entry" $C \
  "for r in ['featureline-1', 'featureline-2', 'featureline-3']: docs[0]['services'][r]['environment'] = ['FEATURELINE_REDIS_PASSWORD=x']"
mutant "compose Redis protected mode off" "compose Redis: protected mode on" $C \
  "c = docs[0]['services']['redis']['command']; c[-1] = c[-1].replace('--protected-mode yes', '--protected-mode no')"
mutant "compose Redis health check without the password" "compose Redis: its health check authenticates" $C \
  "docs[0]['services']['redis']['healthcheck']['test'] = ['CMD', 'redis-cli', 'ping']"
mutant "compose nginx writable" "compose nginx: read-only root file system" $C "del docs[0]['services']['nginx']['read_only']"
mutant "compose Redis as root" "compose redis: runs as a numeric non-root user" $C "del docs[0]['services']['redis']['user']"
mutant "compose nginx on Redis' network" "compose: only the replicas share a network with Redis" $C \
  "docs[0]['services']['nginx']['networks'].append('store')"

run_mutants

# ---- Redis started as the compose file's and the manifest's containers start it ------------------
# Their start-up command and probe, run here with redis-server and redis-cli wrapped: the image's
# paths mapped to deploy/redis.conf and a temporary folder, loopback and a free port added.
if command -v redis-server >/dev/null && command -v redis-cli >/dev/null; then
  mkdir -p "$TMP/bin"
  cat >"$TMP/bin/redis-server" <<'SH'
#!/bin/bash
args=()
for a in "$@"; do
  case "$a" in
    /etc/redis/redis.conf) args+=("$DEPLOY_ROOT/deploy/redis.conf") ;;
    /data) args+=("$DEPLOY_DATA") ;;
    *) args+=("$a") ;;
  esac
done
here=(--port "$DEPLOY_PORT" --bind 127.0.0.1)
if [ "${args[-1]:-}" = - ]; then args=("${args[@]:0:${#args[@]}-1}" "${here[@]}" -); else args+=("${here[@]}"); fi
exec /usr/bin/redis-server "${args[@]}"
SH
  printf '#!/bin/bash\nexec /usr/bin/redis-cli -p "$DEPLOY_PORT" "$@"\n' >"$TMP/bin/redis-cli"
  chmod +x "$TMP/bin/redis-server" "$TMP/bin/redis-cli"
  # container_redis FILE OUT: OUT.start and OUT.probe (NUL-separated argv: Compose's "$$" as "$"),
  # OUT.vars (the variables that carry the password in Redis' container).
  container_redis() {
    python3 - "$1" "$2" <<'PY'
import sys, yaml
path, out = sys.argv[1], sys.argv[2]
docs = [d for d in yaml.safe_load_all(open(path)) if d]
if "services" in docs[0]:
    r = docs[0]["services"]["redis"]
    start, test = r["command"], r["healthcheck"]["test"]
    probe = ["sh", "-c", test[1]] if test[0] == "CMD-SHELL" else test[1:]
    start, probe = [a.replace("$$", "$") for a in start], [a.replace("$$", "$") for a in probe]
    names = ["FEATURELINE_REDIS_PASSWORD"]
else:
    c = next(d for d in docs if d["kind"] == "StatefulSet" and d["metadata"]["name"] == "redis")["spec"]["template"]["spec"]["containers"][0]
    start, probe = c.get("command", []) + c.get("args", []), c["readinessProbe"]["exec"]["command"]
    names = [e["name"] for e in c.get("env", []) if "secretKeyRef" in e.get("valueFrom", {})]
for ext, argv in (("start", start), ("probe", probe)):
    open(out + "." + ext, "w").write("".join(a + "\0" for a in argv))
open(out + ".vars", "w").write("\n".join(names) + "\n")
PY
  }
  fails_quietly() { ! "$@" 2>/dev/null; }
  # container_env PASSWORD OUT: CONTAINER_ENV, for env: OUT.vars set to PASSWORD, the wrappers first.
  container_env() {
    local v
    CONTAINER_ENV=(PATH="$TMP/bin:$PATH" DEPLOY_ROOT="$ROOT" DEPLOY_DATA="$DEPLOY_DATA" DEPLOY_PORT="$DEPLOY_PORT")
    while IFS= read -r v; do [ -n "$v" ] && CONTAINER_ENV+=("$v=$1"); done <"$2.vars"
  }
  for file in $C $K; do
    name=${file#docker/}; out="$TMP/redis-$name"
    DEPLOY_DATA="$TMP/data-$name"; mkdir -p "$DEPLOY_DATA"
    DEPLOY_PORT=$(free_port_block 1) || { fail "$name: a free port for Redis"; continue; }
    container_redis "$file" "$out" || { fail "$name: Redis' command and probe read"; continue; }
    mapfile -d '' start <"$out.start"; mapfile -d '' probe <"$out.probe"
    pw="t$(od -An -N12 -tx1 /dev/urandom | tr -d ' \n')"
    container_env "$pw" "$out"
    env "${CONTAINER_ENV[@]}" "${start[@]}" >"$out.log" 2>&1 &
    pid=$!
    BG_PIDS+=("$pid")
    for _ in $(seq 1 50); do REDISCLI_AUTH="$pw" redis-cli -p "$DEPLOY_PORT" ping 2>/dev/null | grep -q PONG && break; sleep 0.1; done
    check "$name: Redis as its container starts it answers with the password" \
      bash -c "REDISCLI_AUTH='$pw' redis-cli -p '$DEPLOY_PORT' ping | grep -q PONG"
    check "$name: ... and refuses commands without it (NOAUTH)" bash -c "redis-cli -p '$DEPLOY_PORT' ping | grep -q NOAUTH"
    check_eq "$name: ... protected mode on" \
      "$(REDISCLI_AUTH="$pw" redis-cli -p "$DEPLOY_PORT" config get protected-mode | tail -n 1)" yes
    check_eq "$name: ... Redis itself is the container's first process (exec)" "$(cat "/proc/$pid/comm" 2>/dev/null)" redis-server
    check "$name: ... the password is on no command line" bash -c "! cat /proc/$pid/cmdline | tr '\0' ' ' | grep -qF '$pw'"
    check "$name: its probe passes with the password" env "${CONTAINER_ENV[@]}" "${probe[@]}"
    container_env wrong "$out"
    check "$name: its probe fails with another one" fails_quietly env "${CONTAINER_ENV[@]}" "${probe[@]}"
    stop_pids 50 "$pid"
    wait "$pid" 2>/dev/null
  done
else
  fail "redis-server and redis-cli are installed (scripts/setup.sh)"
fi

# ---- the image
D=docker/Dockerfile.server
check_eq "the image is multi-stage (2 FROM)" "$(grep -c '^FROM ' "$D")" 2
check "the image runs as a non-root user" grep -qE '^USER [1-9][0-9]*$' "$D"
# The packages a RUN line installs, for stage N (1 = build, 2 = runtime) of Dockerfile F (default $D).
stage_packages() {
  awk -v want="$1" '/^FROM / { stage++ } stage == want' "${2:-$D}" | tr '\n\\' '  ' | grep -oE 'apt-get install [^&]*' |
    tr ' ' '\n' | grep -E '^[a-z0-9][a-z0-9.+-]+$' | grep -vxE 'apt-get|install' | sort -u
}
# The packages owning the shared libraries PROGRAM links, but those every Debian image has.
linked_packages() {
  # (A sanitizer build also links the sanitizers' runtimes: not part of the image.)
  for l in $(ldd "$1" | awk '/=> \// && $1 !~ /^lib(a|ub|t|l)san/ { print $3 }'); do dpkg -S "$(readlink -f "$l")" 2>/dev/null || dpkg -S "$l"; done |
    cut -d: -f1 | sort -u | grep -vE '^(libc6|libgcc-s1|libstdc\+\+6|libssl3|libbrotli1|libstb0)$'
}
setup_packages=$(sed -n '/^packages=(/,/)/p' scripts/setup.sh | tr -d '()' | sed 's/packages=//' | tr ' ' '\n' | grep -v '^$' | sort -u)
missing=$(comm -23 <(stage_packages 1 | grep -vE '^(nodejs|npm)$') <(echo "$setup_packages"))
check_eq "the build stage installs only packages scripts/setup.sh installs" "$missing" ""
check "the build stage installs libhiredis-dev" grep -qx libhiredis-dev <(stage_packages 1)
runtime=$(stage_packages 2)
check_eq "the runtime stage installs the package of every library the server links" \
  "$(comm -23 <(linked_packages "$SERVER") <(echo "$runtime"))" ""

# ---- the CLI image: the server image's build stage, line for line (one build serves both)
build_stage() { awk '/^FROM / { stage++ } stage == 1' "$1"; }
check_eq "docker/Dockerfile's build stage is docker/Dockerfile.server's" "$(diff <(build_stage "$D") <(build_stage docker/Dockerfile) && echo same)" same
check "... and it builds both programs" grep -q -- '--target featureline-server featureline ' "$D"
check_eq "the CLI image is multi-stage (2 FROM)" "$(grep -c '^FROM ' docker/Dockerfile)" 2
check_eq "the CLI runtime stage installs the package of every library the CLI links" \
  "$(comm -23 <(linked_packages "${FEATURELINE:-$ROOT/build/cli/featureline}") <(stage_packages 2 docker/Dockerfile))" ""

finish
