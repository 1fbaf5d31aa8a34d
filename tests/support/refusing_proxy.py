"""A Modbus TCP proxy in front of a real server (`mdl sim`) that records the function code of every
request and refuses some functions with exception 1 (ILLEGAL FUNCTION), as a device that does not
implement them answers; everything else is forwarded unchanged, so a value written lands in the sim.

    from support.refusing_proxy import refusing_proxy

    with refusing_proxy(sim.host, sim.port, refused={5, 6}) as proxy:
        run_mdl("write", "device.xml", "--host", proxy.host, "--port", proxy.port, "level=7")
        assert proxy.codes == [16]

Each client connection gets its own connection to the server; requests are answered in order.
"""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Collection, Iterator
from contextlib import contextmanager, suppress

MBAP = struct.Struct(">HHHB")  # transaction id, protocol id, length of what follows, unit id
POLL = 0.1  # seconds between looks at the stop flag
ILLEGAL_FUNCTION = 1


def _recv_exactly(conn: socket.socket, size: int, stop: threading.Event) -> bytes | None:
    """`size` bytes, or None when the peer closed the connection or the proxy is stopping."""
    data = b""
    while len(data) < size:
        if stop.is_set():
            return None
        try:
            chunk = conn.recv(size - len(data))
        except TimeoutError:
            continue
        except OSError:
            return None
        if not chunk:
            return None
        data += chunk
    return data


def _frame(conn: socket.socket, stop: threading.Event) -> tuple[bytes, bytes] | None:
    """(MBAP header, PDU) of the next frame on `conn`, or None when it closed."""
    header = _recv_exactly(conn, MBAP.size, stop)
    if header is None:
        return None
    length = MBAP.unpack(header)[2]
    pdu = _recv_exactly(conn, length - 1, stop) if length > 1 else b""
    return None if not pdu else (header, pdu)


class RefusingProxy:
    """Listens on 127.0.0.1 (self.host, self.port); self.codes: the function code of each request, in order."""

    def __init__(self, upstream: tuple[str, int], refused: Collection[int]):
        self.upstream, self.refused = upstream, frozenset(refused)
        self.codes: list[int] = []
        self.stop = threading.Event()
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(POLL)
        self.host, self.port = self.listener.getsockname()[:2]
        self.sockets: list[socket.socket] = []
        self.threads = [threading.Thread(target=self._accept, daemon=True)]
        self.threads[0].start()

    def _accept(self) -> None:
        while not self.stop.is_set():
            try:
                conn, _ = self.listener.accept()
            except TimeoutError:
                continue
            except OSError:
                break
            conn.settimeout(POLL)
            self.sockets.append(conn)
            thread = threading.Thread(target=self._serve, args=(conn,), daemon=True)
            self.threads.append(thread)
            thread.start()

    def _serve(self, conn: socket.socket) -> None:
        server: socket.socket | None = None
        try:
            while (frame := _frame(conn, self.stop)) is not None:
                header, pdu = frame
                self.codes.append(pdu[0])
                if pdu[0] in self.refused:
                    tid, _, _, unit = MBAP.unpack(header)
                    conn.sendall(MBAP.pack(tid, 0, 3, unit) + bytes([pdu[0] | 0x80, ILLEGAL_FUNCTION]))
                    continue
                if server is None:
                    server = socket.create_connection(self.upstream, timeout=10)
                    server.settimeout(POLL)
                    self.sockets.append(server)
                server.sendall(header + pdu)
                reply = _frame(server, self.stop)
                if reply is None:
                    return
                conn.sendall(b"".join(reply))
        except OSError:
            return
        finally:
            for sock in (conn, server):
                if sock is not None:
                    with suppress(OSError):
                        sock.close()

    def close(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(timeout=5)
        self.listener.close()
        for sock in self.sockets:
            with suppress(OSError):
                sock.close()


@contextmanager
def refusing_proxy(host: str, port: int, refused: Collection[int] = ()) -> Iterator[RefusingProxy]:
    """A RefusingProxy in front of host:port that refuses the function codes in `refused`."""
    proxy = RefusingProxy((host, port), refused)
    try:
        yield proxy
    finally:
        proxy.close()
