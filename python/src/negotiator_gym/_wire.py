"""One WebSocket session with env-server, driven in the calling thread
through the `websockets` library's Sans-I/O protocol (`ClientProtocol`)
over a blocking socket. The library's threaded client hands every frame
from a reader thread to the caller; here a step is one `sendall` and one
blocking read, which cuts the client's CPU per step by about a third
(docs/rl.md has the figures)."""

from __future__ import annotations

import socket
import ssl
from collections import deque

from websockets.client import ClientProtocol
from websockets.frames import Frame, Opcode
from websockets.http11 import Response
from websockets.uri import parse_uri


class Session:
    def __init__(self, ws_url: str, headers: dict[str, str], timeout_s: float = 120.0) -> None:
        uri = parse_uri(ws_url)
        sock = socket.create_connection((uri.host, uri.port), timeout=timeout_s)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if uri.secure:
            sock = ssl.create_default_context().wrap_socket(sock, server_hostname=uri.host)
        self.sock = sock
        self.protocol = ClientProtocol(uri, max_size=None)
        request = self.protocol.connect()
        for name, value in headers.items():
            request.headers[name] = value
        self.protocol.send_request(request)
        self._flush()
        self._texts: deque[bytes] = deque()
        self._partial: list[bytes] = []
        response = None
        while response is None:
            self._read()
            response = next((e for e in self.protocol.events_received() if isinstance(e, Response)), None)
        if self.protocol.handshake_exc is not None:
            self.sock.close()
            raise ConnectionError(f"env-server refused the WebSocket ({response.status_code}): {self.protocol.handshake_exc}")

    def _flush(self) -> None:
        data = self.protocol.data_to_send()
        if data:
            self.sock.sendall(b"".join(data))

    def _read(self) -> None:
        chunk = self.sock.recv(1 << 16)
        if not chunk:
            self.protocol.receive_eof()
            raise ConnectionError("env-server closed the connection")
        self.protocol.receive_data(chunk)

    def send(self, text: str) -> None:
        self.protocol.send_text(text.encode())
        self._flush()

    def recv(self) -> bytes:
        """The next text message, as its UTF-8 bytes (pings are answered on
        the way)."""
        while not self._texts:
            self._read()
            for frame in self.protocol.events_received():
                if not isinstance(frame, Frame):
                    continue
                if frame.opcode in (Opcode.TEXT, Opcode.CONT):
                    self._partial.append(bytes(frame.data))
                    if frame.fin:
                        self._texts.append(b"".join(self._partial))
                        self._partial = []
                elif frame.opcode is Opcode.CLOSE:
                    raise ConnectionError(f"env-server closed the session: {self.protocol.close_exc}")
            self._flush()
        return self._texts.popleft()

    def close(self) -> None:
        try:
            self.protocol.send_close()
            self._flush()
        except OSError:
            pass
        finally:
            self.sock.close()
