#!/usr/bin/env python3
"""Keep-alive clients that never retry: each keeps one connection and sends REQUESTS requests on
it one after another, reconnecting only when an answer said `Connection: close`. A connection
closed with a request sent and no answer is counted as lost (a POST cannot be retried safely).

  keepalive_clients.py PORT CLIENTS REQUESTS PATH BODY

Prints "answered N lost N refused N" (refused: 503 answers, e.g. at the connection limit) and
exits 1 when any request was lost or answered other than 200/503.
"""
import http.client
import sys
import threading
import time

port, clients, requests, path, body = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
counts = {"answered": 0, "lost": 0, "refused": 0, "other": 0}
lock = threading.Lock()


def count(kind):
    with lock:
        counts[kind] += 1


def client():
    connection = None
    deadline = time.monotonic() + 120
    for _ in range(requests):
        if time.monotonic() > deadline:
            count("other")
            return
        if connection is None:
            connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        try:
            connection.request("POST", path, body=body, headers={"Content-Type": "application/json"})
            response = connection.getresponse()
            response.read()
        except (http.client.RemoteDisconnected, ConnectionResetError, BrokenPipeError):
            count("lost")
            connection.close()
            connection = None
            continue
        count("answered" if response.status == 200 else "refused" if response.status == 503 else "other")
        if response.getheader("Connection", "").lower() == "close" or response.will_close:
            connection.close()
            connection = None


threads = [threading.Thread(target=client) for _ in range(clients)]
for t in threads:
    t.start()
for t in threads:
    t.join()
print(" ".join(f"{k} {v}" for k, v in counts.items()))
sys.exit(1 if counts["lost"] or counts["other"] else 0)
