"""A pty null-modem: two serial "devices" whose bytes cross over, like a cable or a radio modem pair.

Each side is a pty pair; a node opens the *slave* path (``/dev/pts/N``) as its serial device, exactly as
it would open ``/dev/ttyUSB0``. A relay thread copies what one side's node writes (read from that side's
master) into the other side's master, so it arrives on the other slave. Optionally, and seeded, the relay
cuts the stream into random chunks and inserts garbage bytes: the receiver's frame decoder must resync.

Why the harness keeps its own descriptor to each slave open: on Linux, reading a master whose slave has
no open descriptor fails with EIO, so a node killed with -9 would otherwise break the relay; and the
slave's termios (set raw here) persist across a node restart. Nothing is dropped silently: bytes that
cannot be written because a side's input queue is full (its node is dead or stalled) are counted in
`dropped`.

`byte_rate` makes the pair a slow radio (a 57,600-baud serial radio moves 5,760 bytes/s): each direction
carries at most that many bytes per second, in order. What a node writes faster waits in the relay's buffer
(`buffer_bytes`, a radio's transmit buffer) and, when that is full, in the pty, whose writer then gets EAGAIN:
flow control pushes back on the sending node (its serial driver counts it), as RTS/CTS does on a radio.
"""

from __future__ import annotations

import errno
import os
import pty
import random
import select
import termios
import threading
import time
import tty
from dataclasses import dataclass, field

__all__ = ["NullModem", "RelayFaults", "RelayCounters"]


@dataclass(frozen=True)
class RelayFaults:
    """Seeded serial faults applied by the relay to both directions.

    chunk_max: bytes are written in random chunks of 1..chunk_max (0 = as read).
    garbage_p: probability, per chunk written, of inserting 1..garbage_max random bytes before it.
    """

    chunk_max: int = 0
    garbage_p: float = 0.0
    garbage_max: int = 8
    seed: int = 0


@dataclass
class RelayCounters:
    """Per direction ("a>b", "b>a"): bytes relayed, bytes injected by a third party (inject()), chunks
    written, garbage bytes inserted, bytes dropped."""

    relayed: dict[str, int] = field(default_factory=lambda: {"a>b": 0, "b>a": 0})
    injected: dict[str, int] = field(default_factory=lambda: {"a>b": 0, "b>a": 0})
    chunks: dict[str, int] = field(default_factory=lambda: {"a>b": 0, "b>a": 0})
    garbage: dict[str, int] = field(default_factory=lambda: {"a>b": 0, "b>a": 0})
    dropped: dict[str, int] = field(default_factory=lambda: {"a>b": 0, "b>a": 0})


def _open_pty() -> tuple[int, int, str]:
    master, slave = pty.openpty()
    tty.setraw(slave, termios.TCSANOW)  # no echo, no line editing, no CR/LF translation: 8-bit clean
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


class NullModem:
    """Two cross-connected pty pairs. ``nm.path_a`` / ``nm.path_b`` are the device paths for the two ends.

    Use as a context manager, or call ``start()`` / ``close()``.
    """

    def __init__(self, name: str = "serial", faults: RelayFaults | None = None, byte_rate: int = 0,
                 buffer_bytes: int = 2048) -> None:
        if byte_rate < 0 or buffer_bytes < 1:
            raise ValueError(f"byte_rate {byte_rate}, buffer_bytes {buffer_bytes}: give bytes per second >= 0 "
                             "(0: as fast as the ptys go) and a buffer of at least one byte")
        self.name = name
        self.faults = faults or RelayFaults()
        self.byte_rate = byte_rate
        self.buffer_bytes = buffer_bytes
        self._rng = random.Random(self.faults.seed)
        self.counters = RelayCounters()
        self._master_a, self._slave_a, self.path_a = _open_pty()
        self._master_b, self._slave_b, self.path_b = _open_pty()
        self._wake_r, self._wake_w = os.pipe()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._tx_lock = threading.Lock()  # one writer per side at a time: inject() never splits a relayed chunk

    def __enter__(self) -> NullModem:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=f"nullmodem-{self.name}", daemon=True)
            self._thread.start()

    def close(self) -> None:
        """Stops the relay and closes every descriptor; safe to call twice."""
        if self._thread is not None:
            self._stop.set()
            os.write(self._wake_w, b"x")
            self._thread.join(timeout=2.0)
            self._thread = None
        for attr in ("_master_a", "_slave_a", "_master_b", "_slave_b", "_wake_r", "_wake_w"):
            fd = getattr(self, attr)
            if fd >= 0:
                os.close(fd)
                setattr(self, attr, -1)

    def flush(self, side: str = "ab") -> None:
        """Discards the bytes queued toward side "a" and/or "b" and not yet read by its node: what a
        rebooting computer's UART would lose (else a restarted node reads data from before its crash)."""
        for s, fd in (("a", self._slave_a), ("b", self._slave_b)):
            if s in side and fd >= 0:
                termios.tcflush(fd, termios.TCIFLUSH)

    def snapshot(self) -> dict[str, dict[str, int]]:
        with self._lock:
            c = self.counters
            return {"relayed": dict(c.relayed), "injected": dict(c.injected), "chunks": dict(c.chunks),
                    "garbage": dict(c.garbage), "dropped": dict(c.dropped)}

    def inject(self, side: str, data: bytes) -> int:
        """Writes `data` toward side "a" or "b" as a third transmitter on the medium would (an attacker on
        the radio, tests/system/test_admin_security.py): between the relayed chunks, never inside one.
        Returns the bytes written (the rest is counted as dropped)."""
        if side not in ("a", "b"):
            raise ValueError(f"side {side!r}: 'a' or 'b'")
        fd, key = (self._master_a, "b>a") if side == "a" else (self._master_b, "a>b")
        with self._tx_lock:
            written = self._write_all(fd, key, data)
        with self._lock:
            self.counters.injected[key] += written
        return written

    # -- relay -------------------------------------------------------------------------------------------
    def _chunks(self, data: bytes) -> list[bytes]:
        f = self.faults
        if f.chunk_max <= 0 and f.garbage_p <= 0.0:
            return [data]
        out: list[bytes] = []
        i = 0
        while i < len(data):
            n = self._rng.randint(1, f.chunk_max) if f.chunk_max > 0 else len(data) - i
            out.append(data[i:i + n])
            i += n
        return out

    def _write(self, fd: int, key: str, data: bytes) -> None:
        with self._tx_lock:
            self._write_chunks(fd, key, data)

    def _write_chunks(self, fd: int, key: str, data: bytes) -> None:
        f = self.faults
        for chunk in self._chunks(data):
            if f.garbage_p > 0.0 and self._rng.random() < f.garbage_p:
                junk = bytes(self._rng.getrandbits(8) for _ in range(self._rng.randint(1, max(1, f.garbage_max))))
                written = self._write_all(fd, key, junk)
                with self._lock:
                    self.counters.garbage[key] += written
            written = self._write_all(fd, key, chunk)
            with self._lock:
                self.counters.relayed[key] += written
                self.counters.chunks[key] += 1

    def _write_all(self, fd: int, key: str, data: bytes) -> int:
        """Writes what the pty takes without blocking; the rest is counted as dropped."""
        done = 0
        while done < len(data):
            try:
                done += os.write(fd, data[done:])
            except BlockingIOError:
                break
            except OSError as e:  # pragma: no cover - pty closed under us during shutdown
                if e.errno in (errno.EIO, errno.EBADF):
                    break
                raise
        if done < len(data):
            with self._lock:
                self.counters.dropped[key] += len(data) - done
        return done

    def _run(self) -> None:
        pairs = {self._master_a: (self._master_b, "a>b"), self._master_b: (self._master_a, "b>a")}
        if self.byte_rate > 0:
            self._run_paced(pairs)
            return
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master_a, self._master_b, self._wake_r], [], [], 0.5)
            except (OSError, ValueError):
                return
            for fd in ready:
                if fd == self._wake_r:
                    return
                try:
                    data = os.read(fd, 4096)
                except (BlockingIOError, InterruptedError):
                    continue
                except OSError as e:
                    if e.errno == errno.EIO:  # cannot happen while we hold the slave; be safe anyway
                        continue
                    return
                if data:
                    dst, key = pairs[fd]
                    self._write(dst, key, data)

    def _run_paced(self, pairs: dict[int, tuple[int, str]]) -> None:
        """The relay at `byte_rate`: each direction's bytes wait in a buffer and leave at the rate; a full
        buffer stops reading that side, so its pty fills and the node's writes are pushed back."""
        backlog = {fd: bytearray() for fd in pairs}
        sent = {fd: 0 for fd in pairs}           # bytes sent since `since`
        since = {fd: time.monotonic() for fd in pairs}
        while not self._stop.is_set():
            readable = [fd for fd in pairs if len(backlog[fd]) < self.buffer_bytes]
            waiting = any(backlog.values())
            try:
                ready, _, _ = select.select(readable + [self._wake_r], [], [], 0.002 if waiting else 0.5)
            except (OSError, ValueError):
                return
            if self._wake_r in ready:
                return
            for fd in ready:
                try:
                    data = os.read(fd, self.buffer_bytes - len(backlog[fd]))
                except (BlockingIOError, InterruptedError):
                    continue
                except OSError as e:
                    if e.errno == errno.EIO:
                        continue
                    return
                if data:
                    if not backlog[fd]:  # the medium was idle: its clock starts now
                        since[fd], sent[fd] = time.monotonic(), 0
                    backlog[fd] += data
            now = time.monotonic()
            for fd, (dst, key) in pairs.items():
                allowed = int((now - since[fd]) * self.byte_rate) - sent[fd]
                if allowed <= 0 or not backlog[fd]:
                    continue
                chunk = bytes(backlog[fd][:allowed])
                del backlog[fd][:allowed]
                sent[fd] += len(chunk)
                self._write(dst, key, chunk)
