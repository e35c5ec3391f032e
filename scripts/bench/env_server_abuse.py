#!/usr/bin/env python3
"""What careless or hostile clients cost a running `negotiator env-server`.

N HTTP and N WebSocket clients each send one body of about 1 MB made of
100,000 unknown keys (HTTP: `POST /reset`; WebSocket: a `reset` message),
with a 4 KB receive buffer, and then never read. The script reports the
server's peak resident memory (VmHWM) and whether a well-behaved session
is still served while they hang on.

Usage: scripts/bench/env_server_abuse.py PORT PID [N]
  PORT: the server's port on 127.0.0.1; PID: its process id (to read
  /proc/PID/status); N: clients of each kind (default 32).
Standard library only; loopback only.
"""

import base64
import json
import os
import socket
import struct
import sys
import time


def peak_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    raise RuntimeError("no VmHWM")


def reset_clear_refs(pid: int) -> None:
    # Reset the high-water mark so the figure is this run's alone.
    try:
        with open(f"/proc/{pid}/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def small_socket(port: int) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.connect(("127.0.0.1", port))
    s.settimeout(30)
    return s


def junk_object() -> bytes:
    return ("{" + ",".join(f'"{i}":0' for i in range(100_000)) + "}").encode()


def http_client(port: int, body: bytes) -> socket.socket:
    s = small_socket(port)
    head = f"POST /reset HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n"
    s.sendall(head.encode() + body)
    return s


def ws_frame(payload: bytes) -> bytes:
    mask = os.urandom(4)
    n = len(payload)
    if n < 126:
        header = struct.pack("!BB", 0x81, 0x80 | n)
    elif n < 1 << 16:
        header = struct.pack("!BBH", 0x81, 0x80 | 126, n)
    else:
        header = struct.pack("!BBQ", 0x81, 0x80 | 127, n)
    masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    return header + mask + masked


def ws_client(port: int, message: bytes) -> socket.socket:
    s = small_socket(port)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(
        (
            "GET /ws HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    response = b""
    while b"\r\n\r\n" not in response:
        chunk = s.recv(1024)
        if not chunk:
            raise RuntimeError("upgrade refused")
        response += chunk
    s.sendall(message)
    return s


def well_behaved_session(port: int) -> float:
    """Seconds for a fresh client's reset over HTTP (a normal request)."""
    start = time.monotonic()
    s = socket.create_connection(("127.0.0.1", port), timeout=10)
    body = b'{"seed": 1}'
    s.sendall(
        f"POST /reset HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\nConnection: close\r\n\r\n".encode()
        + body
    )
    reply = b""
    while True:
        chunk = s.recv(65536)
        if not chunk:
            break
        reply += chunk
    s.close()
    if b" 200 " not in reply.split(b"\r\n", 1)[0]:
        raise RuntimeError(f"the normal reset failed: {reply[:80]!r}")
    return time.monotonic() - start


def main() -> None:
    port, pid = int(sys.argv[1]), int(sys.argv[2])
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 32
    junk = junk_object()
    message = ws_frame(b'{"type":"reset","data":' + junk + b"}")
    reset_clear_refs(pid)
    before = peak_kib(pid)
    clients = []
    for _ in range(n):
        clients.append(http_client(port, junk))
        clients.append(ws_client(port, message))
    time.sleep(2.0)
    normal = well_behaved_session(port)
    time.sleep(1.0)
    print(
        json.dumps(
            {
                "clients": 2 * n,
                "body_bytes": len(junk),
                "peak_before_mib": round(before / 1024, 1),
                "peak_with_clients_mib": round(peak_kib(pid) / 1024, 1),
                "normal_reset_s": round(normal, 3),
            }
        )
    )
    for c in clients:
        c.close()


if __name__ == "__main__":
    main()
