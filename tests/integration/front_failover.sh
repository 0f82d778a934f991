#!/usr/bin/env bash
# The Kubernetes front's nginx.conf (the ConfigMap's text) routing and failing over, run by
# deploy_files_test.sh inside a private network and mount namespace (as root):
#
#   in_private_mounts unshare --net bash front_failover.sh FRONT_CONF     (lib.sh)
#
# The Services featureline-0 ... featureline-5 get the addresses fd00:f1::10 ... fd00:f1::15, on
# the namespace's own loopback device and in an /etc/hosts seen here only (IPv6, as nginx listens
# on port 8080 of every IPv4 address). Stand-ins answer for ordinals 0-2 on port 8080 (their name
# in the body); 3-5 are absent, so a connection to them is refused, as kube-proxy refuses one to
# a Service without a ready endpoint. nginx runs as the pod's user 101. Prints "PASS name" or
# "FAIL name: detail" per check.
set -u
conf=$1
trap 'kill $(jobs -p) 2>/dev/null' EXIT
ip link set lo up
for i in 0 1 2 3 4 5; do ip -6 addr add "fd00:f1::1$i/128" dev lo nodad; done
{ cat /etc/hosts; for i in 0 1 2 3 4 5; do echo "fd00:f1::1$i featureline-$i"; done; } >"$conf.hosts"
exec 3<"$conf"
mount --bind "$conf.hosts" /etc/hosts
mount -t tmpfs -o size=64m,mode=1777 tmpfs /tmp
mkdir -p /tmp/nginx/logs /tmp/nginx/nginx-temp /tmp/etc
cat <&3 >/tmp/etc/nginx.conf
chown -R 101:101 /tmp/nginx

check() {  # NAME DETAIL COMMAND...
  local name=$1 detail=$2; shift 2
  if "$@"; then echo "PASS $name"; else echo "FAIL $name: $detail"; fi
}

# A stand-in replica: answers every request with its name; /slow after 2 s.
replica() {
  python3 -c '
import socket, sys, time, http.server
name, host = sys.argv[1], sys.argv[2]
class H(http.server.BaseHTTPRequestHandler):
    def answer(self):
        n = int(self.headers.get("Content-Length") or 0)
        if n:
            self.rfile.read(n)
        if self.path.endswith("/slow"):
            time.sleep(2)
        body = name.encode()
        self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)
    do_GET = do_POST = answer
    def log_message(self, *a):
        pass
class Server(http.server.ThreadingHTTPServer):
    address_family = socket.AF_INET6
Server((host, 8080), H).serve_forever()' "featureline-$1" "fd00:f1::1$1" &
  pids[$1]=$!
}
declare -a pids
for i in 0 1 2; do replica "$i"; done
# nginx after the stand-ins: a request that found none would mark them all failed for 10 s.
for _ in $(seq 1 100); do
  [ "$(for i in 0 1 2; do curl -s "http://[fd00:f1::1$i]:8080/" >/dev/null && echo x; done | wc -l)" = 3 ] && break
  sleep 0.1
done
# As the pod's user 101; where a folder above nginx is closed to others (a fresh machine whose /
# is a 0700 folder), user 101 reaches nothing, and nginx runs as root, workers included.
as_pod=(setpriv --reuid=101 --regid=101 --clear-groups) directives='daemon off;'
if ! "${as_pod[@]}" test -x /usr/sbin/nginx 2>/dev/null; then
  echo "note: user 101 cannot reach /usr/sbin/nginx here: nginx runs as root" >&2
  as_pod=() directives='daemon off; user root;'
fi
"${as_pod[@]}" nginx -p /tmp/nginx -e stderr -c /tmp/etc/nginx.conf -g "$directives" &
nginx_pid=$!
for _ in $(seq 1 100); do (exec 4<>/dev/tcp/127.0.0.1/8080) 2>/dev/null && break; sleep 0.1; done

ids=()
for i in $(seq 1 40); do ids+=("$(printf '%s' "$i" | md5sum | cut -c1-32)"); done
# route PATH_SUFFIX [METHOD]: "STATUS BODY" for every id, one line each.
route() {
  local id
  for id in "${ids[@]}"; do
    curl -s -X "${2:-GET}" -o "/tmp/body" -w '%{http_code} ' "http://127.0.0.1:8080/v1/meshes/$id$1"; cat /tmp/body; echo
  done
}
first=$(route /lines)
check "3 of 6 ordinals present: every mesh id answered 200" "$(grep -vc '^200 ' <<<"$first") not" \
  test "$(grep -c '^200 featureline-[012]$' <<<"$first")" = "${#ids[@]}"
second=$(route /lines)
check "each id answered by the same replica again" "$(diff <(echo "$first") <(echo "$second") | head -3)" test "$first" = "$second"
check "the ids spread over the 3 present replicas" "$(sort <<<"$first" | uniq -c | tr '\n' ' ')" \
  test "$(sort -u <<<"$first" | wc -l)" = 3
uploads=$(for _ in 1 2 3 4 5 6; do curl -s -X POST --data-binary x -o /dev/null -w '%{http_code}\n' http://127.0.0.1:8080/v1/meshes; done | sort -u)
check "uploads (any replica) answered 200" "$uploads" test "$uploads" = 200

# Ordinal 1 killed (SIGKILL) during a slow POST for one of its ids (sent: repeated only because
# of non_idempotent); then every id again.
victim_ids=()
for n in "${!ids[@]}"; do [ "$(sed -n "$((n + 1))p" <<<"$first")" = "200 featureline-1" ] && victim_ids+=("${ids[n]}"); done
curl -s -X POST --data-binary '{}' -o /tmp/inflight -w '%{http_code} ' "http://127.0.0.1:8080/v1/meshes/${victim_ids[0]}/slow" >/tmp/inflight.status &
curl_pid=$!
sleep 0.5
{ kill -9 "${pids[1]}"; wait "${pids[1]}"; } 2>/dev/null
wait "$curl_pid"
inflight="$(cat /tmp/inflight.status)$(cat /tmp/inflight)"
check "a POST in flight on the killed replica is answered by another" "$inflight" \
  grep -qE '^200 featureline-[02]$' <<<"$inflight"
after=$(route /lines)
check "after the kill, every mesh id answered 200" "$(grep -v '^200 ' <<<"$after" | head -3)" \
  test "$(grep -c '^200 featureline-[02]$' <<<"$after")" = "${#ids[@]}"
moved=$(paste -d' ' <(echo "$first") <(echo "$after") | awk '$2 != $4 && $2 != "featureline-1"' | wc -l)
check "only the killed replica's ids moved" "$moved others moved" test "$moved" = 0
posts=$(route /lines POST)
check "after the kill, every POST answered 200" "$(grep -v '^200 ' <<<"$posts" | head -3)" \
  test "$(grep -c '^200 featureline-[02]$' <<<"$posts")" = "${#ids[@]}"

# Back after the front's 10 s fail_timeout: the ids return to it.
replica 1
sleep 11
route /lines >/dev/null
back=$(route /lines)
check "the restarted replica gets its ids back after fail_timeout (10 s)" "$(diff <(echo "$first") <(echo "$back") | head -3)" \
  test "$first" = "$back"

kill "$nginx_pid" "${pids[@]}" 2>/dev/null
wait 2>/dev/null
trap - EXIT
