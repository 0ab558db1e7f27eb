"""An attacker on the links of a multi-process scenario (issue 11): capture, forge, replay, inject.

    tap = insert_udp_tap(topo, ("gcs", "gcsPortDatalink1"), ("primary", "onboardPortDatalink1"), alloc)
    ...
    tap.inject("a>b", forge(cat, "onboardSet", src="gcs1", dest="rmax1ob1", payload=b"\\x42" * n))
    tap.inject("b>a", *tap.frames("b>a"))     # replay what it captured

`UdpTap` sits on a UDP link as a relay between its two ends (each end's `peer` is rewritten to the
tap), like a radio in range of both: it forwards and records every datagram, and what it injects
arrives from the address the receiving end expects from its peer, i.e. with a spoofed source. The
forging helpers build frames with the public wire format only: unsigned, signed with a key the
attacker guessed, or with a key id nobody has. Nothing here uses a fleet key.
"""

from __future__ import annotations

import os
import select
import socket
import threading
import time
from typing import Any

from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_sec
from uavbus.catalogue import Catalogue
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.topology import Topology

__all__ = ["UdpTap", "insert_udp_tap", "forge", "frame_header", "tcp_connect"]


def _split(addr: str) -> tuple[str, int]:
    host, _, port = addr.rpartition(":")
    return host, int(port)


def _spec_param(spec: str, key: str) -> str:
    for kv in spec.split(":", 1)[1].split(","):
        k, _, v = kv.partition("=")
        if k == key:
            return v
    raise KeyError(f"{spec!r} has no {key}=")


class UdpTap:
    """A recording relay between UDP end A (address `a`) and end B (`b`). A sends to `toward_a`'s
    address (the tap's side facing A), B to `toward_b`'s. Directions are "a>b" and "b>a"."""

    def __init__(self, a: str, b: str, facing_a: str, facing_b: str) -> None:
        self.a, self.b = _split(a), _split(b)
        self.sock_a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)   # talks to A (as B's stand-in)
        self.sock_b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)   # talks to B (as A's stand-in)
        self.sock_a.bind(_split(facing_a))
        self.sock_b.bind(_split(facing_b))
        self.captured: list[tuple[float, str, bytes]] = []
        self.forwarding = True
        self.injected = {"a>b": 0, "b>a": 0}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._wake_r, self._wake_w = os.pipe()
        self._thread = threading.Thread(target=self._run, name="udp-tap", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.sock_a, self.sock_b, self._wake_r], [], [], 0.5)
            for s in ready:
                if s is self._wake_r:
                    continue
                try:
                    data, _src = s.recvfrom(65536)
                except OSError:
                    continue
                direction = "a>b" if s is self.sock_a else "b>a"
                with self._lock:
                    self.captured.append((time.monotonic(), direction, data))
                    forward = self.forwarding
                if forward:
                    self._send(direction, data)

    def _send(self, direction: str, data: bytes) -> None:
        try:
            if direction == "a>b":
                self.sock_b.sendto(data, self.b)
            else:
                self.sock_a.sendto(data, self.a)
        except OSError:
            pass   # the end is down (a restart): the datagram is lost, as on a radio

    def inject(self, direction: str, *datagrams: bytes) -> int:
        """Sends datagrams toward B ("a>b") or A ("b>a") from the address that end trusts."""
        for d in datagrams:
            self._send(direction, d)
        with self._lock:
            self.injected[direction] += len(datagrams)
        return len(datagrams)

    def frames(self, direction: str, since: float = 0.0, until: float | None = None,
               admin: int | None = None) -> list[bytes]:
        """Captured datagrams of one direction in [since, until), optionally of one admin code."""
        with self._lock:
            got = list(self.captured)
        return [d for t, dr, d in got if dr == direction and t >= since and (until is None or t < until)
                and (admin is None or (len(d) > 48 and d[48] == admin))]

    def close(self) -> None:
        self._stop.set()
        os.write(self._wake_w, b"x")
        self._thread.join(timeout=2.0)
        for s in (self.sock_a, self.sock_b):
            s.close()
        os.close(self._wake_r)
        os.close(self._wake_w)


def insert_udp_tap(topo: Topology, end_a: tuple[str, str], end_b: tuple[str, str],
                   alloc: PortAllocator) -> UdpTap:
    """Puts a `UdpTap` on the UDP connection between (node, link) ends `end_a` and `end_b` of `topo`
    (before the processes start): each end's peer becomes the tap."""
    c = topo.find(*end_a)
    if c.transport != "udp" or {c.a, c.b} != {end_a, end_b}:
        raise ValueError(f"no UDP connection between {end_a} and {end_b}")
    spec_a, spec_b = (c.spec_a, c.spec_b) if c.a == end_a else (c.spec_b, c.spec_a)
    bind_a, bind_b = _spec_param(spec_a, "bind"), _spec_param(spec_b, "bind")
    facing_a, facing_b = alloc.addr(), alloc.addr()
    tap = UdpTap(bind_a, bind_b, facing_a, facing_b)
    new_a, new_b = f"udp:bind={bind_a},peer={facing_a}", f"udp:bind={bind_b},peer={facing_b}"
    if c.a == end_a:
        c.spec_a, c.spec_b = new_a, new_b
    else:
        c.spec_a, c.spec_b = new_b, new_a
    return tap


def frame_header(cat: Catalogue, content: str | None, src: str, dest: str, admin: int = 0, counter: int = 1,
                 hop_limit: int = 8, payload_size: int = 0) -> uf.FrameHeader:
    """The header of a frame `src` -> `dest` about catalogue instance `content` (None: no content)."""
    if content is not None:
        inst = cat.instance(content)
        dir_id, fingerprint = inst.id, inst.type.fingerprint
    else:
        dir_id, fingerprint = bytes(16), 0
    return uf.FrameHeader(dir_id=bytes(dir_id), dest_id=dest.encode().ljust(12, b"\0"),
                          src_id=src.encode().ljust(12, b"\0"), admin=admin, hop_limit=hop_limit,
                          payload_size=payload_size, seq=counter & 0xFFFFFFFF, fingerprint=fingerprint,
                          counter_hi=counter >> 32)


def forge(cat: Catalogue, content: str | None, src: str, dest: str, payload: bytes, *, admin: int = 0,
          counter: int = 1, mode: str = "unsigned", key: bytes | None = None, key_id: int = 1) -> bytes:
    """A frame as an attacker makes it: `mode` "unsigned", "signed" or "encrypted" (then with `key`,
    which the attacker guessed: default 32 random bytes)."""
    h = frame_header(cat, content, src, dest, admin, counter, payload_size=len(payload))
    if mode == "unsigned":
        return uf.ub_frame_finish(h, payload)
    sec: Any = ub_sec.ub_sec_new({key_id: key or os.urandom(32)})
    flags = uf.FLAG_SIGNED if mode == "signed" else uf.FLAG_ENCRYPTED
    return ub_sec.ub_sec_protect(sec, uf.FrameHeader(**{**h.__dict__, "flags": flags, "key_id": key_id}), payload)


def tcp_connect(addr: str, timeout: float = 2.0) -> socket.socket:
    """A TCP connection to a node's listening port (a takeover attempt)."""
    s = socket.create_connection(_split(addr), timeout=timeout)
    s.setblocking(False)
    return s
