#!/usr/bin/env python3
"""Static checks of docker/compose.yaml and docker/kubernetes.yaml (no engine, no cluster).

  deploy_yaml_check.py ROOT CACHE_MB_DEFAULT DEADLINE_S_DEFAULT

ROOT holds docker/, scripts/cluster.sh and CMakeLists.txt; the defaults are the server's own
(from its --help). Prints one line per check, "PASS name" or "FAIL name: detail"; exits 1 if
any failed. deploy_files_test.sh also runs it on broken copies to see those checks fail.
"""
import re
import sys

import yaml

root, cache_default, deadline_default = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
failed = 0


def check(name, cond, detail=""):
    global failed
    if cond:
        print("PASS " + name)
    else:
        failed += 1
        print("FAIL %s%s" % (name, ": " + str(detail) if detail else ""))


def read(path):
    with open("%s/%s" % (root, path)) as f:
        return f.read()


def flag(args, name):
    """The value after NAME in an argument list, or None."""
    args = [str(a) for a in args]
    return args[args.index(name) + 1] if name in args and args.index(name) + 1 < len(args) else None


# ---- what the other files say
cluster = read("scripts/cluster.sh")
replica_line = re.search(r'setsid "\$server_bin".*?(?:\n.*?)*?</dev/null', cluster)
replica_cmd = replica_line.group(0) if replica_line else ""
cluster_flags = {}
for name in ("--http-threads", "--max-connections"):
    m = re.search(re.escape(name) + r' +"?([0-9]+)', replica_cmd)
    cluster_flags[name] = m.group(1) if m else None
check("scripts/cluster.sh starts its replicas with --http-threads", cluster_flags["--http-threads"] is not None)
version_m = re.search(r'project\(featureline VERSION ([0-9.]+)', read("CMakeLists.txt"))
version = version_m.group(1) if version_m else None
dockerfile = read("docker/Dockerfile.server")
uid_m = re.search(r'^USER ([0-9]+)$', dockerfile, re.M)
gid_m = re.search(r'groupadd [^\n]*--gid ([0-9]+)', dockerfile)
image_uid, image_gid = (int(uid_m.group(1)) if uid_m else None), (int(gid_m.group(1)) if gid_m else None)
check("docker/Dockerfile.server names its user and group by number", image_uid and image_gid)


def memory_mib(quantity, binary_suffixes_only=False):
    """A memory size in MiB: Kubernetes quantities (Mi, Gi, M, G, plain bytes) or, for Compose,
    Docker's sizes, whose k/m/g are binary."""
    m = re.fullmatch(r'([0-9.]+)([A-Za-z]*)', str(quantity).strip())
    if not m:
        return None
    n, unit = float(m.group(1)), m.group(2)
    if binary_suffixes_only:
        unit = {"b": "", "k": "Ki", "m": "Mi", "g": "Gi"}.get(unit.lower().rstrip("b") or "b", None)
        if unit is None:
            return None
    scale = {"": 1 / 2**20, "Ki": 1 / 1024, "Mi": 1, "Gi": 1024, "K": 1e3 / 2**20, "M": 1e6 / 2**20, "G": 1e9 / 2**20}
    return n * scale[unit] if unit in scale else None


def pinned(image):
    """name:tag with a tag that names a release (not latest, not absent), or a digest."""
    if "@sha256:" in image:
        return True
    tag = image.rsplit(":", 1)[1] if ":" in image.rsplit("/", 1)[-1] else None
    return tag is not None and tag != "latest"


def exact_version(image):
    return re.search(r':[0-9]+\.[0-9]+\.[0-9]+(-[a-z0-9.]+)?$', image) is not None or "@sha256:" in image


def memory_budget_ok(limit_mib, cache_mb):
    # Resident memory reaches 1.47-1.69 x the cache: 2 x the cache + 256 MiB leaves room.
    return limit_mib is not None and limit_mib >= 2 * cache_mb + 256


# ---- Redis' password
PASSWORD_VAR = "FEATURELINE_REDIS_PASSWORD"


def secretish(name):
    return re.search(r'PASS|AUTH|SECRET|TOKEN', name.upper()) is not None


def secret_refs(container):
    """{env name: (Secret, key)} for a container's variables taken from a Secret."""
    refs = {}
    for e in container.get("env", []):
        ref = e.get("valueFrom", {}).get("secretKeyRef")
        if ref:
            refs[e["name"]] = (ref.get("name"), ref.get("key"))
    return refs


def reads_password_on_stdin(script, var, dollar=r'\$'):
    """redis-server's last argument "-" (configuration on standard input) and a here-document
    giving requirepass from $var."""
    return (re.search(r'redis-server\b[^<]*\s-\s*<<\s*\'?(\w+)', script) is not None and
            re.search(r'requirepass\s+"?' + dollar + r'\{?' + var + r'\b', script) is not None)


def protected_mode_off(script):
    return re.search(r'protected-mode\s+"?no', script) is not None


def ignored(path, patterns_file):
    """Whether a line of ROOT/patterns_file names path exactly (the operator's own file)."""
    try:
        lines = {l.strip() for l in read(patterns_file).splitlines()}
    except OSError:
        return False
    return path in lines or "/" + path in lines


# ---- compose
compose = yaml.safe_load(read("docker/compose.yaml"))
services = compose.get("services", {})
check("compose services are redis, featureline, nginx", set(services) == {"redis", "featureline", "nginx"}, sorted(services))
fl = services.get("featureline", {})
fl_cmd = [str(a) for a in fl.get("command", [])]
check("compose: 3 featureline replicas", fl.get("deploy", {}).get("replicas") == 3)
check("compose builds docker/Dockerfile.server", fl.get("build", {}).get("dockerfile") == "docker/Dockerfile.server")
check("compose replicas use the Redis store", "redis://redis:6379" in fl_cmd)
for name, want in cluster_flags.items():
    check("compose replicas' %s is scripts/cluster.sh's (%s)" % (name, want), flag(fl_cmd, name) == want, flag(fl_cmd, name))
health = " ".join(fl.get("healthcheck", {}).get("test", []))
check("compose replica healthcheck asks /readyz for a 200", "/readyz" in health and "' 200 '" in health)
nginx_cmd = " ".join(services.get("nginx", {}).get("command", []))
check("compose nginx renders the repository's template", "render-nginx-conf.sh" in nginx_cmd and "featureline:8080" in nginx_cmd)
check("compose Redis uses deploy/redis.conf", "appendonly" not in " ".join(services.get("redis", {}).get("command", [])) and
      any("redis.conf" in v for v in services.get("redis", {}).get("volumes", [])))
for name, s in services.items():
    image = str(s.get("image", ""))
    check("compose %s: image pinned to a release (%s)" % (name, image), pinned(image) and exact_version(image))
    user = str(s.get("user", ""))
    check("compose %s: runs as a numeric non-root user (%s)" % (name, user),
          re.fullmatch(r'[1-9][0-9]*:[1-9][0-9]*', user) is not None)
    check("compose %s: read-only root file system" % name, s.get("read_only") is True)
    check("compose %s: drops every capability" % name, "ALL" in s.get("cap_drop", []) and not s.get("cap_add"))
    check("compose %s: no new privileges" % name,
          any(str(o).replace("=", ":") in ("no-new-privileges:true", "no-new-privileges") for o in s.get("security_opt", [])))
    check("compose %s: not privileged" % name, not s.get("privileged"))
check("compose featureline image tagged with the project's version %s" % version,
      str(fl.get("image", "")).endswith(":" + str(version)))
check("compose featureline runs as the image's user %s:%s" % (image_uid, image_gid), str(fl.get("user")) == "%s:%s" % (image_uid, image_gid))
compose_cache = int(flag(fl_cmd, "--cache-mb") or cache_default)
compose_limit = fl.get("deploy", {}).get("resources", {}).get("limits", {}).get("memory")
check("compose replicas' memory limit >= 2 x --cache-mb (%d) + 256 MiB (%s)" % (compose_cache, compose_limit),
      memory_budget_ok(memory_mib(compose_limit, binary_suffixes_only=True), compose_cache))
redis_svc = services.get("redis", {})


def env_files(service):
    files = service.get("env_file", [])
    files = [files] if isinstance(files, str) else files
    return sorted(f if isinstance(f, str) else f.get("path", "") for f in files)


check("compose: Redis and the replicas read the same env file", env_files(redis_svc) and env_files(redis_svc) == env_files(fl),
      (env_files(redis_svc), env_files(fl)))
for f in env_files(redis_svc):
    check("compose: the env file docker/%s is the operator's: git and image builds ignore it" % f,
          ignored("docker/" + f, ".gitignore") and ignored("docker/" + f, ".dockerignore"))
compose_redis = " ".join(str(a) for a in redis_svc.get("command", []))
check("compose Redis: requirepass from $%s, on standard input (redis-server ... - <<EOF)" % PASSWORD_VAR,
      reads_password_on_stdin(compose_redis, PASSWORD_VAR, dollar=r'\$\$'), compose_redis)
check("compose Redis: no --requirepass on its command line", "--requirepass" not in compose_redis)
check("compose Redis: protected mode on", not protected_mode_off(compose_redis))
redis_health = " ".join(str(a) for a in redis_svc.get("healthcheck", {}).get("test", []))
check("compose Redis: its health check authenticates (REDISCLI_AUTH) and wants PONG",
      "REDISCLI_AUTH=" in redis_health and PASSWORD_VAR in redis_health and "PONG" in redis_health, redis_health)
check("compose replicas: the store URL carries no password", not any(re.match(r'redis://[^/]*@', a) for a in fl_cmd), fl_cmd)


def environment_names(service):
    env = service.get("environment", {})
    return list(env) if isinstance(env, dict) else [str(e).split("=", 1)[0] for e in env]


env_literals = [(n, k) for n, s in services.items() for k in environment_names(s) if secretish(k)]
check("compose: no password in an environment: entry", not env_literals, env_literals)
redis_nets = services.get("redis", {}).get("networks", [])
sharing = {n for n, s in services.items() if n != "redis" and set(s.get("networks", [])) & set(redis_nets)}
check("compose: only the replicas share a network with Redis", redis_nets and sharing == {"featureline"}, sharing)

# ---- Kubernetes
docs = [d for d in yaml.safe_load_all(read("docker/kubernetes.yaml")) if d]
kinds = {(d["kind"], d["metadata"]["name"]) for d in docs}
for k in [("Namespace", "featureline"), ("Deployment", "featureline"), ("Service", "featureline"), ("StatefulSet", "redis"),
          ("Service", "redis"), ("Ingress", "featureline"), ("PodDisruptionBudget", "featureline"),
          ("HorizontalPodAutoscaler", "featureline"), ("NetworkPolicy", "redis"), ("NetworkPolicy", "featureline")]:
    check("kubernetes: %s %s" % k, k in kinds)
CLUSTER_SCOPED = {"Namespace", "ClusterRole", "ClusterRoleBinding", "PriorityClass", "StorageClass"}
for d in docs:
    ns = d["metadata"].get("namespace")
    what = "%s %s" % (d["kind"], d["metadata"]["name"])
    if d["kind"] in CLUSTER_SCOPED:
        check("kubernetes: %s is the featureline namespace or cluster-wide" % what,
              d["kind"] != "Namespace" or d["metadata"]["name"] == "featureline")
    else:
        check("kubernetes: %s is in namespace featureline, no other (%s)" % (what, ns), ns == "featureline")
for d in docs:
    if d["kind"] == "Namespace":
        labels = d["metadata"].get("labels", {})
        check("kubernetes: the namespace enforces the restricted Pod Security Standard",
              labels.get("pod-security.kubernetes.io/enforce") == "restricted")

by_kind = {}
for d in docs:
    by_kind.setdefault(d["kind"], []).append(d)
deploys = by_kind.get("Deployment", [])
dep = deploys[0] if deploys else {"spec": {"template": {"metadata": {}, "spec": {"containers": [{}]}}}}
pod = dep["spec"]["template"]["spec"]
pod_labels = dep["spec"]["template"]["metadata"].get("labels", {})
c = pod["containers"][0]
args = [str(a) for a in c.get("args", [])]
for probe, path in (("startupProbe", "/healthz"), ("livenessProbe", "/healthz"), ("readinessProbe", "/readyz")):
    check("kubernetes: %s on %s" % (probe, path), c.get(probe, {}).get("httpGet", {}).get("path") == path)
# The readiness probe waits for /readyz's own store probe (2 s Redis timeout).
check("kubernetes: readiness timeout above the store's 2 s", c.get("readinessProbe", {}).get("timeoutSeconds", 1) > 2)
startup = c.get("startupProbe", {})
check("kubernetes: the startup probe allows 30 s", startup.get("periodSeconds", 10) * startup.get("failureThreshold", 3) >= 30)
check("kubernetes replicas use the Redis store", "redis://redis:6379" in args)
for name, want in cluster_flags.items():
    check("kubernetes replicas' %s is scripts/cluster.sh's (%s)" % (name, want), flag(args, name) == want, flag(args, name))

# Engine threads follow the CPU request: the variable --threads names comes from the Downward API.
threads = flag(args, "--threads") or ""
threads_var = re.fullmatch(r'\$\((\w+)\)', threads)
cpu_field = next((e.get("valueFrom", {}).get("resourceFieldRef", {}) for e in c.get("env", [])
                  if threads_var and e.get("name") == threads_var.group(1)), {})
check("kubernetes: --threads is the pod's CPU request (%s)" % threads,
      cpu_field.get("resource") == "requests.cpu" and cpu_field.get("containerName") == c.get("name") and
      str(cpu_field.get("divisor", "1")) == "1" and c.get("resources", {}).get("requests", {}).get("cpu") is not None)

cache_mb = int(flag(args, "--cache-mb") or cache_default)
res = c.get("resources", {})
limit, request = res.get("limits", {}).get("memory"), res.get("requests", {}).get("memory")
check("kubernetes: memory limit >= 2 x --cache-mb (%d) + 256 MiB (%s)" % (cache_mb, limit), memory_budget_ok(memory_mib(limit), cache_mb))
check("kubernetes: memory request is the limit (%s, %s)" % (request, limit),
      request is not None and memory_mib(request) == memory_mib(limit))

# Failover: a sleep before SIGTERM, then a grace period covering the longest request.
pre = c.get("lifecycle", {}).get("preStop", {})
sleep_s = None
if "sleep" in pre:
    sleep_s = pre["sleep"].get("seconds")
elif pre.get("exec", {}).get("command", [None])[0] == "sleep" and len(pre["exec"]["command"]) == 2:
    sleep_s = float(pre["exec"]["command"][1])
check("kubernetes: a preStop hook sleeps 2-15 s before SIGTERM (%s)" % sleep_s, sleep_s is not None and 2 <= sleep_s <= 15)
deadline = float(flag(args, "--deadline-s") or deadline_default)
grace = pod.get("terminationGracePeriodSeconds", 30)
check("kubernetes: terminationGracePeriodSeconds (%s) >= preStop + --deadline-s (%g) + 5 s" % (grace, deadline),
      sleep_s is not None and grace >= sleep_s + deadline + 5)

spread = pod.get("topologySpreadConstraints", [])
anti = pod.get("affinity", {}).get("podAntiAffinity", {})
anti_terms = anti.get("requiredDuringSchedulingIgnoredDuringExecution", []) + \
    [t.get("podAffinityTerm", {}) for t in anti.get("preferredDuringSchedulingIgnoredDuringExecution", [])]
check("kubernetes: replicas spread across nodes (topologySpreadConstraints or podAntiAffinity on kubernetes.io/hostname)",
      any(t.get("topologyKey") == "kubernetes.io/hostname" and
          t.get("labelSelector", {}).get("matchLabels", {}).items() <= pod_labels.items() and t.get("labelSelector", {}).get("matchLabels")
          for t in spread + anti_terms))

hpas = by_kind.get("HorizontalPodAutoscaler", [])
if hpas:
    h = hpas[0]["spec"]
    check("kubernetes: the HPA scales the featureline Deployment",
          h.get("scaleTargetRef", {}).get("kind") == "Deployment" and h["scaleTargetRef"].get("name") == dep["metadata"].get("name"))
    check("kubernetes: the HPA keeps several replicas", h.get("minReplicas", 1) >= 2 and h.get("maxReplicas", 0) >= h.get("minReplicas", 1))
    check("kubernetes: the HPA scales on CPU",
          any(m.get("type") == "Resource" and m.get("resource", {}).get("name") == "cpu" for m in h.get("metrics", [])))
    check("kubernetes: the Deployment leaves the replica count to the HPA (no replicas field)", "replicas" not in dep["spec"])
    check("kubernetes: the replicas request CPU (the HPA's utilization is relative to it)", "cpu" in res.get("requests", {}))
else:
    check("kubernetes: several replicas", dep["spec"].get("replicas", 1) >= 2)
pdbs = by_kind.get("PodDisruptionBudget", [])
for p in pdbs:
    s = p["spec"]
    check("kubernetes: the PodDisruptionBudget selects the replicas",
          s.get("selector", {}).get("matchLabels") and s["selector"]["matchLabels"].items() <= pod_labels.items())
    check("kubernetes: the PodDisruptionBudget allows one replica down at a time",
          s.get("maxUnavailable") == 1 or (isinstance(s.get("minAvailable"), int) and s["minAvailable"] >= 1))

# Images: the server's from the project's version, the others an exact release.
for d in by_kind.get("Deployment", []) + by_kind.get("StatefulSet", []):
    for ct in d["spec"]["template"]["spec"].get("containers", []) + d["spec"]["template"]["spec"].get("initContainers", []):
        check("kubernetes %s/%s: image pinned to a release (%s)" % (d["metadata"]["name"], ct["name"], ct.get("image")),
              pinned(ct.get("image", "")) and exact_version(ct.get("image", "")))
check("kubernetes: the server image is tagged with the project's version %s" % version,
      c.get("image", "").split("/")[-1] == "featureline-server:%s" % version)

# The restricted Pod Security Standard, for every pod template, and a read-only root.
ALLOWED_VOLUMES = {"configMap", "csi", "downwardAPI", "emptyDir", "ephemeral", "persistentVolumeClaim", "projected", "secret"}
for d in by_kind.get("Deployment", []) + by_kind.get("StatefulSet", []):
    name = d["metadata"]["name"]
    ps = d["spec"]["template"]["spec"]
    psc = ps.get("securityContext", {})
    check("restricted %s: no host namespaces" % name, not (ps.get("hostNetwork") or ps.get("hostPID") or ps.get("hostIPC")))
    for v in ps.get("volumes", []):
        check("restricted %s: volume %s of an allowed type" % (name, v.get("name")), set(v) - {"name"} <= ALLOWED_VOLUMES)
    for ct in ps.get("containers", []) + ps.get("initContainers", []):
        sc = ct.get("securityContext", {})
        where = "%s/%s" % (name, ct["name"])
        check("restricted %s: runAsNonRoot" % where, sc.get("runAsNonRoot", psc.get("runAsNonRoot")) is True)
        check("restricted %s: runAsUser not 0" % where, sc.get("runAsUser", psc.get("runAsUser", 1)) != 0)
        seccomp = sc.get("seccompProfile", psc.get("seccompProfile", {})).get("type")
        check("restricted %s: seccompProfile RuntimeDefault or Localhost (%s)" % (where, seccomp), seccomp in ("RuntimeDefault", "Localhost"))
        check("restricted %s: allowPrivilegeEscalation false" % where, sc.get("allowPrivilegeEscalation") is False)
        check("restricted %s: not privileged" % where, not sc.get("privileged"))
        caps = sc.get("capabilities", {})
        check("restricted %s: capabilities drop ALL, add at most NET_BIND_SERVICE" % where,
              "ALL" in caps.get("drop", []) and set(caps.get("add", [])) <= {"NET_BIND_SERVICE"})
        check("restricted %s: no hostPort" % where, not any("hostPort" in p for p in ct.get("ports", [])))
        check("%s: read-only root file system" % where, sc.get("readOnlyRootFilesystem") is True)
check("kubernetes: the replicas run as the image's user and group (%s:%s)" % (image_uid, image_gid),
      (c.get("securityContext", {}).get("runAsUser", pod.get("securityContext", {}).get("runAsUser")),
       c.get("securityContext", {}).get("runAsGroup", pod.get("securityContext", {}).get("runAsGroup"))) == (image_uid, image_gid))
tmp_vols = {m["name"] for m in c.get("volumeMounts", []) if m.get("mountPath") == "/tmp"}
check("kubernetes: the replicas' /tmp is a writable emptyDir",
      any(v.get("name") in tmp_vols and "emptyDir" in v for v in pod.get("volumes", [])))

# Redis' password: in a Secret the operator creates (none shipped), read by Redis on standard
# input and by the replicas from FEATURELINE_REDIS_PASSWORD; never a literal, never in a URL.
sts = by_kind.get("StatefulSet", [{}])[0]
redis_c = sts.get("spec", {}).get("template", {}).get("spec", {}).get("containers", [{}])[0]
redis_script = " ".join(str(a) for a in redis_c.get("command", []) + redis_c.get("args", []))
check("kubernetes Redis: durable and never evicting",
      re.search(r'--maxmemory-policy\s+noeviction', redis_script) and re.search(r'--appendonly\s+yes', redis_script), redis_script)
redis_refs, replica_refs = secret_refs(redis_c), secret_refs(c)
auth_vars = [v for v in redis_refs if reads_password_on_stdin(redis_script, v)]
check("kubernetes Redis: requirepass from a Secret's variable, on standard input (redis-server ... - <<EOF)",
      auth_vars, redis_refs)
check("kubernetes Redis: no --requirepass on its command line", "--requirepass" not in redis_script)
check("kubernetes Redis: protected mode on", not protected_mode_off(redis_script))
probe = " ".join(str(a) for a in redis_c.get("readinessProbe", {}).get("exec", {}).get("command", []))
check("kubernetes Redis: its probe authenticates (REDISCLI_AUTH from the Secret) and wants PONG",
      "REDISCLI_AUTH" in redis_refs and "redis-cli" in probe and "PONG" in probe, probe)
check("kubernetes replicas: %s from the Secret Redis reads" % PASSWORD_VAR,
      auth_vars and replica_refs.get(PASSWORD_VAR) is not None and replica_refs.get(PASSWORD_VAR) == redis_refs[auth_vars[0]],
      replica_refs)
check("kubernetes replicas: the store URL carries no password", not any(re.match(r'redis://[^/]*@', a) for a in args), args)
check("kubernetes: no Secret shipped (the operator creates featureline-redis)", "Secret" not in by_kind)
literal = [(d["metadata"]["name"], e["name"]) for d in by_kind.get("Deployment", []) + by_kind.get("StatefulSet", [])
           for ct in d["spec"]["template"]["spec"].get("containers", []) for e in ct.get("env", []) if "value" in e and secretish(e["name"])]
check("kubernetes: no password as a literal env value", not literal, literal)


def policy_for(labels):
    return [p for p in by_kind.get("NetworkPolicy", []) if p["spec"].get("podSelector", {}).get("matchLabels") == labels]


redis_pol = policy_for({"app": "redis"})
froms = [f for p in redis_pol for rule in p["spec"].get("ingress", []) for f in (rule.get("from") or [{}])]
check("kubernetes: a NetworkPolicy admits only the replicas to Redis",
      redis_pol and all("Ingress" in p["spec"].get("policyTypes", ["Ingress"]) for p in redis_pol) and froms and
      all(set(f) == {"podSelector"} and f["podSelector"].get("matchLabels") and
          f["podSelector"]["matchLabels"].items() <= pod_labels.items() for f in froms), froms)
fl_pol = policy_for(pod_labels)
froms = [f for p in fl_pol for rule in p["spec"].get("ingress", []) for f in (rule.get("from") or [{}])]
check("kubernetes: a NetworkPolicy admits only the ingress controller to the replicas",
      fl_pol and froms and all("namespaceSelector" in f and f["namespaceSelector"].get("matchLabels") and "ipBlock" not in f
                               for f in froms), froms)

for ing in by_kind.get("Ingress", []):
    a = ing["metadata"].get("annotations", {})
    check("ingress hashes on $mesh_id", a.get("nginx.ingress.kubernetes.io/upstream-hash-by") == "$mesh_id")
    check("ingress body size limit", a.get("nginx.ingress.kubernetes.io/proxy-body-size") == "256m")
patch = yaml.safe_load(read("docker/ingress-nginx-controller-patch.yaml"))
check("the ingress-nginx ConfigMap patch is data only (merged, not an object)", set(patch) == {"data"}, sorted(patch))
check("the ingress-nginx ConfigMap patch defines $mesh_id", "$mesh_id" in patch.get("data", {}).get("http-snippet", ""))
sys.exit(1 if failed else 0)
