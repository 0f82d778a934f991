#!/usr/bin/env python3
"""Static checks of docker/compose.yaml and docker/kubernetes.yaml (no engine, no cluster).

  deploy_yaml_check.py ROOT CACHE_MB_DEFAULT DEADLINE_S_DEFAULT

ROOT holds docker/, deploy/, scripts/cluster.sh and CMakeLists.txt; the defaults are the server's
own (from its --help). Prints one line per check, "PASS name" or "FAIL name: detail"; exits 1 if
any failed. deploy_files_test.sh also runs it on broken copies to see those checks fail.
"""
import re
import subprocess
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
REPLICAS = ["featureline-1", "featureline-2", "featureline-3"]
check("compose services are redis, featureline-1..3, nginx", set(services) == {"redis", "nginx", *REPLICAS}, sorted(services))
# One service per replica, each its own name on nginx's hash ring (one name with several
# addresses gives them a single place on it: ids would not stick); all configured alike.
replicas = [services.get(n, {}) for n in REPLICAS]
check("compose: the 3 replicas are configured alike", all(r == replicas[0] for r in replicas))
check("compose: no replica is scaled by deploy.replicas (one name per replica)",
      all("replicas" not in r.get("deploy", {}) for r in replicas))
fl = replicas[0]
fl_cmd = [str(a) for a in fl.get("command", [])]
check("compose builds docker/Dockerfile.server", fl.get("build", {}).get("dockerfile") == "docker/Dockerfile.server")
check("compose replicas use the Redis store", "redis://redis:6379" in fl_cmd)
for name, want in cluster_flags.items():
    check("compose replicas' %s is scripts/cluster.sh's (%s)" % (name, want), flag(fl_cmd, name) == want, flag(fl_cmd, name))
health = " ".join(fl.get("healthcheck", {}).get("test", []))
check("compose replica healthcheck asks /readyz for a 200", "/readyz" in health and "' 200 '" in health)
nginx_cmd = " ".join(services.get("nginx", {}).get("command", []))
check("compose nginx renders the repository's template", "render-nginx-conf.sh" in nginx_cmd)
check("compose nginx names every replica on its own (featureline-N:8080)",
      re.search(r'render-nginx-conf\.sh \S+ \S+ \S+ ' + " ".join(n + ":8080" for n in REPLICAS) + r'(\s|>)', nginx_cmd) is not None,
      nginx_cmd)
check("compose nginx waits for every replica to be healthy",
      all(services.get("nginx", {}).get("depends_on", {}).get(n, {}).get("condition") == "service_healthy" for n in REPLICAS))
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
check("compose: only the replicas share a network with Redis", redis_nets and sharing == set(REPLICAS), sharing)

# ---- Kubernetes
docs = [d for d in yaml.safe_load_all(read("docker/kubernetes.yaml")) if d]
kinds = {(d["kind"], d["metadata"]["name"]) for d in docs}
for k in [("Namespace", "featureline"), ("StatefulSet", "featureline"), ("StatefulSet", "redis"), ("Service", "redis"),
          ("PodDisruptionBudget", "featureline"), ("HorizontalPodAutoscaler", "featureline"),
          ("ConfigMap", "featureline-front-nginx"), ("Deployment", "featureline-front"), ("Service", "featureline-front"),
          ("PodDisruptionBudget", "featureline-front"),
          ("NetworkPolicy", "redis"), ("NetworkPolicy", "featureline"), ("NetworkPolicy", "featureline-front")]:
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
EMPTY_WORKLOAD = {"metadata": {}, "spec": {"template": {"metadata": {}, "spec": {"containers": [{}]}}}}


def obj(kind, name, default=None):
    return next((d for d in docs if d["kind"] == kind and d["metadata"]["name"] == name), default)


# The replicas (StatefulSet featureline) and the nginx in front of them (Deployment featureline-front).
dep = obj("StatefulSet", "featureline", EMPTY_WORKLOAD)
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
    check("kubernetes: the HPA scales the featureline StatefulSet",
          h.get("scaleTargetRef", {}).get("kind") == "StatefulSet" and h["scaleTargetRef"].get("name") == dep["metadata"].get("name"))
    check("kubernetes: the HPA keeps several replicas", h.get("minReplicas", 1) >= 2 and h.get("maxReplicas", 0) >= h.get("minReplicas", 1))
    check("kubernetes: the HPA scales on CPU",
          any(m.get("type") == "Resource" and m.get("resource", {}).get("name") == "cpu" for m in h.get("metrics", [])))
    check("kubernetes: the StatefulSet leaves the replica count to the HPA (no replicas field)", "replicas" not in dep["spec"])
    check("kubernetes: the replicas request CPU (the HPA's utilization is relative to it)", "cpu" in res.get("requests", {}))
else:
    check("kubernetes: several replicas", dep["spec"].get("replicas", 1) >= 2)
pdbs = by_kind.get("PodDisruptionBudget", [])
check("kubernetes: a PodDisruptionBudget selects the replicas",
      any(p["spec"].get("selector", {}).get("matchLabels") and p["spec"]["selector"]["matchLabels"].items() <= pod_labels.items()
          for p in pdbs))
for p in pdbs:
    s = p["spec"]
    check("kubernetes: the PodDisruptionBudget %s allows one pod down at a time" % p["metadata"]["name"],
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
sts = obj("StatefulSet", "redis", {})
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
front = obj("Deployment", "featureline-front", EMPTY_WORKLOAD)
front_pod = front["spec"]["template"]["spec"]
front_labels = front["spec"]["template"]["metadata"].get("labels", {})
check("kubernetes: a NetworkPolicy admits only the front to the replicas",
      fl_pol and froms and front_labels and
      all(set(f) == {"podSelector"} and f["podSelector"].get("matchLabels") and
          f["podSelector"]["matchLabels"].items() <= front_labels.items() for f in froms), froms)

# ---- the front: nginx (Deployment featureline-front) running the repository's template, rendered
# into a ConfigMap, which hashes on the mesh id over one Service per replica ordinal up to the
# autoscaler's maximum and retries a failed request on the next replica.
hpa_max = hpas[0]["spec"].get("maxReplicas", 0) if hpas else 0
replica_port = next((p.get("containerPort") for p in c.get("ports", []) if p.get("name") == "http"), None)
POD_NAME = "statefulset.kubernetes.io/pod-name"


def ordinal_server(i):
    """HOST:PORT of the Service of ordinal i, or None when it is missing or not a ClusterIP
    Service for that pod alone."""
    name = "%s-%d" % (dep["metadata"].get("name"), i)
    svc = obj("Service", name)
    if not svc:
        return None
    spec = svc["spec"]
    selector = dict(spec.get("selector", {}))
    ports = spec.get("ports", [])
    if (selector.pop(POD_NAME, None) != name or not selector.items() <= pod_labels.items() or
            spec.get("type", "ClusterIP") != "ClusterIP" or spec.get("clusterIP") == "None" or
            len(ports) != 1 or ports[0].get("targetPort") not in ("http", replica_port)):
        return None
    return "%s:%s" % (name, ports[0].get("port"))


ordinal_servers = [ordinal_server(i) for i in range(hpa_max)]
check("kubernetes: a ClusterIP Service for each replica ordinal 0-%d (the HPA's maxReplicas), selecting that pod only" % (hpa_max - 1),
      hpa_max > 0 and None not in ordinal_servers,
      [i for i, s in enumerate(ordinal_servers) if s is None])
check("kubernetes: the StatefulSet creates and removes pods in parallel (podManagementPolicy)",
      dep["spec"].get("podManagementPolicy") == "Parallel")
governing = obj("Service", dep["spec"].get("serviceName", ""))
check("kubernetes: the StatefulSet's serviceName is a headless Service of the replicas",
      governing is not None and governing["spec"].get("clusterIP") == "None" and
      governing["spec"].get("selector") and governing["spec"]["selector"].items() <= pod_labels.items())

front_cm = obj("ConfigMap", "featureline-front-nginx", {})
conf = front_cm.get("data", {}).get("nginx.conf", "")
# The ConfigMap is the template as render-nginx-conf.sh renders it for this manifest, never a copy
# that could drift from it.
try:
    rendered = subprocess.run(["bash", "%s/docker/kubernetes-nginx-conf.sh" % root, "%s/docker/kubernetes.yaml" % root],
                              capture_output=True, text=True, timeout=60)
    want, why = rendered.stdout, rendered.stderr.strip()
except (OSError, subprocess.SubprocessError) as e:
    want, why = None, str(e)
first_diff = next(((n + 1, a, b) for n, (a, b) in enumerate(zip(conf.splitlines(), (want or "").splitlines())) if a != b),
                  (len(conf.splitlines()), len((want or "").splitlines())))
check("kubernetes front: the ConfigMap's nginx.conf is deploy/render-nginx-conf.sh's output for this manifest "
      "(docker/kubernetes-nginx-conf.sh --update writes it)", want and conf == want, why or first_diff)


def directives(text, name):
    """The arguments of every `name ...;` line of an nginx configuration."""
    return [m.group(1).split() for m in re.finditer(r'^\s*' + re.escape(name) + r'\s+([^;#]*);', text, re.M)]


upstreams = {m.group(1): m.group(2) for m in re.finditer(r'^\s*upstream\s+(\S+)\s*\{(.*?)^\s*\}', conf, re.M | re.S)}
by_mesh = [body for body in upstreams.values() if ["$mesh_id", "consistent"] in directives(body, "hash")]
check("kubernetes front: an upstream hashes on $mesh_id, consistent", len(by_mesh) == 1, sorted(upstreams))
listed = {name: [args[0] for args in directives(body, "server")] for name, body in upstreams.items()}
check("kubernetes front: every upstream lists the ordinals' Services, each once (%d)" % hpa_max,
      upstreams and None not in ordinal_servers and all(sorted(v) == sorted(ordinal_servers) for v in listed.values()), listed)
passive = all(any(a.startswith("max_fails=") and a != "max_fails=0" for a in args) and
              any(a.startswith("fail_timeout=") for a in args)
              for body in upstreams.values() for args in directives(body, "server"))
check("kubernetes front: a replica that fails is skipped for a while (max_fails, fail_timeout)", upstreams and passive)
next_upstream = sum(directives(conf, "proxy_next_upstream"), [])
check("kubernetes front: a refused, failed or timed-out request goes to the next replica, uploads too "
      "(proxy_next_upstream error timeout non_idempotent)",
      {"error", "timeout", "non_idempotent"} <= set(next_upstream), next_upstream)
tries = [int(a[0]) for a in directives(conf, "proxy_next_upstream_tries") if a and a[0].isdigit()]
check("kubernetes front: proxy_next_upstream_tries %s reaches every ordinal (>= %d, the HPA's maxReplicas)" % (tries, hpa_max),
      len(tries) == 1 and (tries[0] == 0 or tries[0] >= hpa_max > 0))

fc = front_pod["containers"][0]
compose_nginx = services.get("nginx", {})
check("kubernetes front: at least 2 nginx pods", front["spec"].get("replicas", 1) >= 2)
check("kubernetes front: the image Compose runs (%s)" % compose_nginx.get("image"),
      fc.get("image") and fc.get("image") == compose_nginx.get("image"))
front_user = (fc.get("securityContext", {}).get("runAsUser", front_pod.get("securityContext", {}).get("runAsUser")),
              fc.get("securityContext", {}).get("runAsGroup", front_pod.get("securityContext", {}).get("runAsGroup")))
check("kubernetes front: nginx runs as Compose's nginx user (%s)" % compose_nginx.get("user"),
      "%s:%s" % front_user == str(compose_nginx.get("user")), front_user)
front_cmd = " ".join(str(a) for a in fc.get("command", []) + fc.get("args", []))
conf_mounts = [m.get("mountPath", "").rstrip("/") + "/" + m.get("subPath", "nginx.conf").split("/")[-1]
               for m in fc.get("volumeMounts", []) for v in front_pod.get("volumes", [])
               if v.get("name") == m.get("name") and v.get("configMap", {}).get("name") == "featureline-front-nginx"]
conf_arg = re.search(r'\bnginx\b.*\s-c\s+(\S+)', front_cmd)
check("kubernetes front: nginx runs the ConfigMap's nginx.conf (-c)", conf_arg and conf_arg.group(1) in conf_mounts,
      (conf_arg and conf_arg.group(1), conf_mounts))
writable = [m["mountPath"].rstrip("/") + "/" for m in fc.get("volumeMounts", []) for v in front_pod.get("volumes", [])
            if v.get("name") == m.get("name") and "emptyDir" in v]
written = [a[0] for name in ("pid", "error_log", "access_log", "client_body_temp_path", "proxy_temp_path",
                             "fastcgi_temp_path", "uwsgi_temp_path", "scgi_temp_path") for a in directives(conf, name) if a]
check("kubernetes front: every file nginx writes (pid, logs, temporary files) is on a writable emptyDir",
      written and writable and all(any(w.startswith(d) for d in writable) for w in written),
      [w for w in written if not any(w.startswith(d) for d in writable)])
listen = sum(directives(conf, "listen"), [])
front_port = next((p.get("containerPort") for p in fc.get("ports", [])), None)
check("kubernetes front: nginx listens on the container's port (%s)" % front_port,
      listen and listen[0].rsplit(":", 1)[-1] == str(front_port), listen)


def probes_port(ct, port):
    ok = []
    for name in ("readinessProbe", "livenessProbe"):
        p = ct.get(name, {})
        target = (p.get("tcpSocket") or p.get("httpGet") or {}).get("port")
        ok.append(target in (port, next((q.get("name") for q in ct.get("ports", []) if q.get("containerPort") == port), None)))
    return all(ok)


check("kubernetes front: readiness and liveness probes on nginx's port", front_port and probes_port(fc, front_port))
front_pre = " ".join(str(a) for a in fc.get("lifecycle", {}).get("preStop", {}).get("exec", {}).get("command", []))
front_sleep = re.search(r'\bsleep\s+([0-9.]+)', front_pre)
check("kubernetes front: a preStop hook sleeps, then nginx quits gracefully (SIGQUIT) and is waited for",
      front_sleep and re.search(r'kill\s+-(QUIT|3|s\s+QUIT)\s+1\b', front_pre) and "kill -0 1" in front_pre, front_pre)
read_timeout = [a[0] for a in directives(conf, "proxy_read_timeout")]
read_s = float(read_timeout[0].rstrip("s")) if read_timeout and re.fullmatch(r'[0-9]+s?', read_timeout[0]) else None
front_grace = front_pod.get("terminationGracePeriodSeconds", 30)
check("kubernetes front: terminationGracePeriodSeconds (%s) >= preStop + proxy_read_timeout (%s s) + 5 s" % (front_grace, read_s),
      front_sleep and read_s is not None and front_grace >= float(front_sleep.group(1)) + read_s + 5)


def spread_across_nodes(pod_spec, labels):
    spread = pod_spec.get("topologySpreadConstraints", [])
    anti = pod_spec.get("affinity", {}).get("podAntiAffinity", {})
    terms = anti.get("requiredDuringSchedulingIgnoredDuringExecution", []) + \
        [t.get("podAffinityTerm", {}) for t in anti.get("preferredDuringSchedulingIgnoredDuringExecution", [])]
    return any(t.get("topologyKey") == "kubernetes.io/hostname" and t.get("labelSelector", {}).get("matchLabels") and
               t["labelSelector"]["matchLabels"].items() <= labels.items() for t in spread + terms)


check("kubernetes front: nginx pods spread across nodes", front_labels and spread_across_nodes(front_pod, front_labels))
check("kubernetes front: a PodDisruptionBudget selects the front",
      front_labels and any(p["spec"].get("selector", {}).get("matchLabels") and
                           p["spec"]["selector"]["matchLabels"].items() <= front_labels.items() for p in pdbs))
front_svc = obj("Service", "featureline-front", {"spec": {}})["spec"]
svc_type = front_svc.get("type", "ClusterIP")
check("kubernetes front: its Service selects the nginx pods, on nginx's port",
      front_labels and front_svc.get("selector") and front_svc["selector"].items() <= front_labels.items() and
      front_svc.get("ports") and all(p.get("targetPort") in (front_port, "http") for p in front_svc["ports"]))
check("kubernetes front: its Service is ClusterIP, or a LoadBalancer keeping clients' addresses (externalTrafficPolicy Local) "
      "for nginx's per-address limits (%s)" % svc_type,
      svc_type == "ClusterIP" or (svc_type == "LoadBalancer" and front_svc.get("externalTrafficPolicy") == "Local"))
front_pol = policy_for(front_labels) if front_labels else []
front_rule_ports = [p.get("port") for pol in front_pol for rule in pol["spec"].get("ingress", []) for p in (rule.get("ports") or [{}])]
check("kubernetes front: a NetworkPolicy admits clients to nginx's port only (%s)" % front_rule_ports,
      front_pol and all("Ingress" in pol["spec"].get("policyTypes", ["Ingress"]) for pol in front_pol) and
      front_rule_ports and all(p in (front_port, "http") for p in front_rule_ports))
hashing_ingresses = [i["metadata"]["name"] for i in by_kind.get("Ingress", [])
                     if "nginx.ingress.kubernetes.io/upstream-hash-by" in i["metadata"].get("annotations", {})]
check("kubernetes: no Ingress hashes by itself (ingress-nginx's upstream-hash-by retries on the same pod)",
      not hashing_ingresses, hashing_ingresses)
sys.exit(1 if failed else 0)
