#!/usr/bin/env bash
# What can be checked of docker/ and deploy/ without a Docker engine: the nginx
# template renders and passes `nginx -t` as the compose file renders it; the compose file and
# the Kubernetes manifests parse and describe the topology (3 replicas on the Redis store,
# liveness and startup on /healthz, readiness on /readyz, hashing on the mesh id, nginx/ingress edge limits); the image is multi-stage
# and non-root, its build packages are among scripts/setup.sh's, and its runtime packages own
# every shared library the tested server binary links (ldd + dpkg -S).
#
#   SERVER=build/server/featureline-server bash tests/integration/deploy_files_test.sh
set -u

# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"  # HERE, ROOT (the working directory), SERVER, SHARED, MESHES, VR, VG, JOBS
for tool in python3 dpkg ldd; do command -v "$tool" >/dev/null || { echo "FAIL $tool is missing"; exit 1; }; done
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
deploy/render-nginx-conf.sh >/dev/null 2>&1
check_eq "render-nginx-conf.sh without replicas is a usage error" "$?" 2

# ---- compose and Kubernetes: parse and describe the topology
python3 - >"$TMP/yaml.out" 2>&1 <<'PY'
import sys, yaml
problems = []
def need(cond, what):
    if not cond: problems.append(what)

compose = yaml.safe_load(open("docker/compose.yaml"))
services = compose.get("services", {})
need(set(services) == {"redis", "featureline", "nginx"}, "compose services are redis, featureline, nginx: %s" % sorted(services))
fl = services.get("featureline", {})
need(fl.get("deploy", {}).get("replicas") == 3, "compose: 3 featureline replicas")
need(fl.get("build", {}).get("dockerfile") == "docker/Dockerfile.server", "compose builds docker/Dockerfile.server")
need("redis://redis:6379" in fl.get("command", []), "compose replicas use the Redis store")
health = " ".join(fl.get("healthcheck", {}).get("test", []))
need("/readyz" in health and "' 200 '" in health, "compose replica healthcheck asks /readyz for a 200")
nginx_cmd = " ".join(services.get("nginx", {}).get("command", []))
need("render-nginx-conf.sh" in nginx_cmd and "featureline:8080" in nginx_cmd, "compose nginx renders the repository's template")
need("appendonly" not in " ".join(services.get("redis", {}).get("command", [])) and
     any("redis.conf" in v for v in services.get("redis", {}).get("volumes", [])), "compose Redis uses deploy/redis.conf")

docs = [d for d in yaml.safe_load_all(open("docker/kubernetes.yaml")) if d]
kinds = {(d["kind"], d["metadata"]["name"]) for d in docs}
for k in [("Deployment", "featureline"), ("Service", "featureline"), ("StatefulSet", "redis"), ("Service", "redis"),
          ("Ingress", "featureline"), ("ConfigMap", "ingress-nginx-controller")]:
    need(k in kinds, "kubernetes: %s %s" % k)
for d in docs:
    if d["kind"] == "Deployment":
        need(d["spec"]["replicas"] >= 2, "kubernetes: several replicas")
        c = d["spec"]["template"]["spec"]["containers"][0]
        for probe, path in (("startupProbe", "/healthz"), ("livenessProbe", "/healthz"), ("readinessProbe", "/readyz")):
            need(c.get(probe, {}).get("httpGet", {}).get("path") == path, "kubernetes: %s on %s" % (probe, path))
        # The readiness probe waits for /readyz's own store probe (2 s Redis timeout).
        need(c.get("readinessProbe", {}).get("timeoutSeconds", 1) > 2, "kubernetes: readiness timeout above the store's 2 s")
        startup = c.get("startupProbe", {})
        need(startup.get("periodSeconds", 10) * startup.get("failureThreshold", 3) >= 30, "kubernetes: the startup probe allows 30 s")
        need("redis://redis:6379" in c.get("args", []), "kubernetes replicas use the Redis store")
        need(d["spec"]["template"]["spec"]["securityContext"].get("runAsNonRoot") is True, "kubernetes: non-root pods")
    if d["kind"] == "Ingress":
        a = d["metadata"]["annotations"]
        need(a.get("nginx.ingress.kubernetes.io/upstream-hash-by") == "$mesh_id", "ingress hashes on $mesh_id")
        need(a.get("nginx.ingress.kubernetes.io/proxy-body-size") == "256m", "ingress body size limit")
    if d["kind"] == "ConfigMap":
        need("$mesh_id" in d["data"].get("http-snippet", ""), "ingress-nginx ConfigMap defines $mesh_id")
    if d["kind"] == "StatefulSet":
        args = d["spec"]["template"]["spec"]["containers"][0]["args"]
        need("noeviction" in args and "appendonly" in " ".join(args), "kubernetes Redis: durable and never evicting")
print("\n".join(problems) if problems else "ok")
sys.exit(1 if problems else 0)
PY
check "compose.yaml and kubernetes.yaml parse and describe the topology" test "$(cat "$TMP/yaml.out")" = ok ||
  sed 's/^/       | /' "$TMP/yaml.out"

# ---- the image
D=docker/Dockerfile.server
check_eq "the image is multi-stage (2 FROM)" "$(grep -c '^FROM ' "$D")" 2
check "the image runs as a non-root user" grep -qE '^USER [1-9][0-9]*$' "$D"
# The packages a RUN line installs, for stage N (1 = build, 2 = runtime).
stage_packages() {
  awk -v want="$1" '/^FROM / { stage++ } stage == want' "$D" | tr '\n\\' '  ' | grep -oE 'apt-get install [^&]*' |
    tr ' ' '\n' | grep -E '^[a-z0-9][a-z0-9.+-]+$' | grep -vxE 'apt-get|install' | sort -u
}
setup_packages=$(sed -n '/^packages=(/,/)/p' scripts/setup.sh | tr -d '()' | sed 's/packages=//' | tr ' ' '\n' | grep -v '^$' | sort -u)
missing=$(comm -23 <(stage_packages 1 | grep -vE '^(nodejs|npm)$') <(echo "$setup_packages"))
check_eq "the build stage installs only packages scripts/setup.sh installs" "$missing" ""
check "the build stage installs libhiredis-dev" grep -qx libhiredis-dev <(stage_packages 1)
# (A sanitizer build also links the sanitizers' runtimes: not part of the image.)
needed=$(for l in $(ldd "$SERVER" | awk '/=> \// && $1 !~ /^lib(a|ub|t|l)san/ { print $3 }'); do dpkg -S "$(readlink -f "$l")" 2>/dev/null || dpkg -S "$l"; done |
  cut -d: -f1 | sort -u | grep -vE '^(libc6|libgcc-s1|libstdc\+\+6|libssl3|libbrotli1|libstb0)$')
runtime=$(stage_packages 2)
check_eq "the runtime stage installs the package of every library the server links" "$(comm -23 <(echo "$needed") <(echo "$runtime"))" ""

finish
