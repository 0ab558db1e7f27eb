"""Free ports on 127.0.0.1 for multi-process tests that run beside other test suites.

A port is taken by binding 127.0.0.1:0 (the kernel picks a free one), reading it back, checking it is also
free for the other protocol (a port may serve UDP in one run and TCP in the next), and closing. There is a
window between closing and the node binding it, so callers that start processes retry with fresh ports
when a node reports the address in use (see `sim.process.is_addr_in_use`). Ports handed out by one
allocator are never handed out again by it, so the ports of one topology are distinct.
"""

from __future__ import annotations

import errno
import socket

__all__ = ["PortAllocator"]

HOST = "127.0.0.1"


class PortAllocator:
    def __init__(self, host: str = HOST, attempts: int = 50) -> None:
        self.host = host
        self.attempts = attempts
        self.issued: set[int] = set()

    def _probe(self, kind: int, port: int) -> int:
        s = socket.socket(socket.AF_INET, kind)
        try:
            if kind == socket.SOCK_STREAM:
                # A server rebinding after a restart uses SO_REUSEADDR; probing with it would hide nothing.
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((self.host, port))
            return int(s.getsockname()[1])
        finally:
            s.close()

    def port(self) -> int:
        """A port free for both UDP and TCP on the host, not issued before by this allocator."""
        for _ in range(self.attempts):
            try:
                p = self._probe(socket.SOCK_DGRAM, 0)
                if p in self.issued:
                    continue
                self._probe(socket.SOCK_STREAM, p)
            except OSError as e:
                if e.errno == errno.EADDRINUSE:
                    continue
                raise
            self.issued.add(p)
            return p
        raise RuntimeError(f"portalloc: no free port on {self.host} after {self.attempts} attempts; "
                           "is the ephemeral range exhausted? (check `ss -s`)")

    def addr(self) -> str:
        """``HOST:PORT`` of a fresh port, ready for a port spec."""
        return f"{self.host}:{self.port()}"
