"""The env-server an Inspect run plays on: one named by its URL, or a local
`negotiator env-server` started from the binary on PATH (or NEGOTIATOR_BIN)
for this process and stopped when it exits."""

from __future__ import annotations

import atexit
import os
import shutil
import subprocess
import threading
from typing import Any

import httpx

_LISTENING = "listening on "
_lock = threading.Lock()
_local: LocalServer | None = None


class EnvServerError(RuntimeError):
    """env-server refused a request or could not be started."""


class LocalServer:
    """`negotiator env-server --port 0` (or another serving command, such
    as `serve --policy expert`) as a child process; `url` is the address
    it announces on starting."""

    def __init__(self, binary: str, command: list[str] | None = None) -> None:
        self.process = subprocess.Popen(
            [binary, *(command or ["env-server"]), "--port", "0"],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert self.process.stdout is not None
        # The address is announced on one of the first lines (`serve` first
        # says what it serves).
        line = ""
        for _ in range(5):
            line = self.process.stdout.readline().strip()
            if line.startswith(_LISTENING) or not line:
                break
        if not line.startswith(_LISTENING):
            self.close()
            what = " ".join(command or ["env-server"])
            raise EnvServerError(f"{binary} {what} did not start (last line: {line!r})")
        self.url = line[len(_LISTENING) :].split()[0]

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def binary(base_url_flag: str = "-T base_url=URL") -> str:
    """The negotiator binary: NEGOTIATOR_BIN, else `negotiator` on PATH.
    Without either, the error names `base_url_flag`: how the calling
    command is given a server instead (Inspect's `-T base_url=URL` by
    default)."""
    named = os.environ.get("NEGOTIATOR_BIN")
    if named:
        return named
    found = shutil.which("negotiator")
    if found is None:
        raise EnvServerError(
            f"no env-server to play on: pass {base_url_flag}, set NEGOTIATOR_BIN, or put negotiator on PATH"
        )
    return found


def server_url(base_url: str | None) -> str:
    """`base_url` itself, or the URL of this process's local env-server
    (started on first use, stopped at exit)."""
    if base_url:
        return base_url.rstrip("/")
    global _local
    with _lock:
        if _local is None or _local.process.poll() is not None:
            _local = LocalServer(binary())
            atexit.register(_local.close)
        return _local.url


async def post(http: httpx.AsyncClient, path: str, body: dict[str, Any]) -> dict[str, Any]:
    """One env-server request; a refusal is an error with the server's own
    `detail` (a bug in the task, never a model's fault)."""
    response = await http.post(path, json=body)
    if response.status_code != 200:
        raise EnvServerError(f"env-server {path}: {response.status_code} {response.text[:300]}")
    reply: dict[str, Any] = response.json()
    return reply
