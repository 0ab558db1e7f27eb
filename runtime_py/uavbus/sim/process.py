"""Child processes speaking the `uavbus_node` protocol: JSON lines on stdout, line commands on stdin.

`NodeProcess` starts one program (normally ``uavbus_node``, programs/node/README.md), reads its stdout in
a thread (every line a JSON event: ready, stats, rebound, error, ... -- docs/program-protocol.md, the names
from `uavbus.sim.protocol`; a line that is not UTF-8, not JSON or not an object is kept as a ``text``
event with the reason, counted in ``bad_lines``, and never stops the reader),
keeps the tail of stderr for error messages, and can be sent commands, killed with -9 and restarted with
the same arguments. `ProcessGroup` owns several and guarantees that every process it started is gone when
it closes -- on success, on an exception, on Ctrl-C, and at interpreter exit (atexit). Each child runs in
its own session (so a terminal Ctrl-C reaches only the driver, which then stops the children in order),
and asks the kernel to SIGTERM it if the driver itself dies (PR_SET_PDEATHSIG), so no node outlives a
crashed test run.
"""

from __future__ import annotations

import atexit
import collections
import ctypes
import json
import os
import signal
import subprocess
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from uavbus.sim.protocol import ERROR, READY, STATS

__all__ = ["NodeError", "NodeProcess", "ProcessGroup", "is_addr_in_use"]

Event = dict[str, Any]

_PR_SET_PDEATHSIG = 1


try:  # resolved here, not in the child: loading a library between fork and exec can deadlock
    _prctl: Callable[..., int] | None = ctypes.CDLL(None, use_errno=True).prctl
except (OSError, AttributeError):  # not Linux/glibc: the ProcessGroup's cleanup still applies
    _prctl = None


def _child_setup() -> None:  # runs in the child between fork and exec
    if _prctl is not None:
        _prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM))


class NodeError(RuntimeError):
    """A node did not start, exited early, or did not send an expected event in time."""


def is_addr_in_use(err: BaseException) -> bool:
    """True when a start failed because a port was taken meanwhile (retry with fresh ports)."""
    text = str(err).lower()
    return "address already in use" in text or "eaddrinuse" in text or "in use" in text


class NodeProcess:
    """One child process. ``argv[0]`` is the program; ``name`` labels messages."""

    def __init__(self, argv: Sequence[str], name: str, *, cwd: str | Path | None = None,
                 env: dict[str, str] | None = None, stderr_lines: int = 40) -> None:
        self.argv = [str(a) for a in argv]
        self.name = name
        self.cwd = str(cwd) if cwd else None
        self.env = env
        self.events: list[Event] = []
        self.starts = 0
        self.bad_lines = 0  # stdout lines that were not UTF-8 JSON objects (kept as "text" events)
        self._stderr: collections.deque[str] = collections.deque(maxlen=stderr_lines)
        self._cond = threading.Condition()
        self._proc: subprocess.Popen[bytes] | None = None
        self._threads: list[threading.Thread] = []

    # -- life cycle ---------------------------------------------------------------------------------------
    def start(self) -> NodeProcess:
        if self.running:
            raise NodeError(f"{self.name}: already running (pid {self.pid})")
        self._stderr.clear()
        # Binary pipes: each line is decoded here, so bytes a node should never have written cannot kill
        # the reader thread (a decode error inside a text-mode iterator would).
        self._proc = subprocess.Popen(
            self.argv, cwd=self.cwd, env=self.env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, start_new_session=True, preexec_fn=_child_setup)
        self.starts += 1
        run = self.starts
        self._threads = [
            threading.Thread(target=self._read_stdout, args=(self._proc, run), daemon=True,
                             name=f"{self.name}-stdout"),
            threading.Thread(target=self._read_stderr, args=(self._proc,), daemon=True,
                             name=f"{self.name}-stderr"),
        ]
        for t in self._threads:
            t.start()
        return self

    @property
    def pid(self) -> int | None:
        return self._proc.pid if self._proc else None

    @property
    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    @property
    def returncode(self) -> int | None:
        return self._proc.poll() if self._proc else None

    def stderr_tail(self) -> str:
        return "\n".join(self._stderr)

    def kill(self, sig: int = signal.SIGKILL) -> None:
        """Sends `sig` to the process group (kill -9 by default) and waits for the exit."""
        if self._proc is None or self._proc.poll() is not None:
            return
        try:
            os.killpg(self._proc.pid, sig)
        except ProcessLookupError:
            pass
        try:
            self._proc.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            os.killpg(self._proc.pid, signal.SIGKILL)
            self._proc.wait(timeout=5.0)
        self._join()

    def stop(self, timeout: float = 3.0) -> int | None:
        """Orderly stop: ``quit`` on stdin, then SIGTERM, then SIGKILL. Returns the exit status."""
        p = self._proc
        if p is None:
            return None
        if p.poll() is None:
            try:
                self.send("quit")
                p.wait(timeout=timeout / 2)
            except (OSError, subprocess.TimeoutExpired, NodeError):
                pass
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGTERM)
                p.wait(timeout=timeout / 2)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                pass
        if p.poll() is None:
            self.kill(signal.SIGKILL)
        self._join()
        return p.poll()

    def restart(self, ready_timeout: float = 5.0) -> Event:
        self.stop()
        self.start()
        return self.wait_ready(ready_timeout)

    def _join(self) -> None:
        for t in self._threads:
            t.join(timeout=2.0)
        if self._proc is not None and self._proc.stdin is not None:
            try:
                self._proc.stdin.close()
            except OSError:
                pass

    # -- I/O ----------------------------------------------------------------------------------------------
    def send(self, line: str) -> None:
        """Writes one command line (e.g. ``rebind onboardPortIPC udp:bind=...``) to the node's stdin."""
        if self._proc is None or self._proc.stdin is None or self._proc.poll() is not None:
            raise NodeError(f"{self.name}: cannot send {line!r}: not running{self._exit_note()}")
        try:
            self._proc.stdin.write((line.rstrip("\n") + "\n").encode("utf-8"))
            self._proc.stdin.flush()
        except BrokenPipeError as e:
            raise NodeError(f"{self.name}: cannot send {line!r}: stdin closed{self._exit_note()}") from e

    @staticmethod
    def _parse_line(raw: bytes) -> Event | None:
        """One stdout line as an event; None for a blank line. Never raises."""
        try:
            line = raw.decode("utf-8").strip()
        except UnicodeDecodeError:
            return {"event": "text", "text": raw.decode("utf-8", "replace").strip(), "reason": "not UTF-8"}
        if not line:
            return None
        try:
            ev = json.loads(line)
        except ValueError:
            return {"event": "text", "text": line, "reason": "not JSON"}
        if not isinstance(ev, dict):
            return {"event": "text", "text": line, "reason": "not a JSON object"}
        return ev

    def _read_stdout(self, proc: subprocess.Popen[bytes], run: int) -> None:
        assert proc.stdout is not None
        for raw in proc.stdout:
            ev = self._parse_line(raw)
            if ev is None:
                continue
            ev["_run"] = run
            ev["_rx_mono"] = time.monotonic()
            with self._cond:
                if ev.get("event") == "text" and "reason" in ev:
                    self.bad_lines += 1
                self.events.append(ev)
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def _read_stderr(self, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stderr is not None
        for raw in proc.stderr:
            self._stderr.append(raw.decode("utf-8", "replace").rstrip("\n"))

    def _exit_note(self) -> str:
        rc = self.returncode
        if rc is None:
            return ""
        tail = self.stderr_tail()
        return f" (exited with status {rc}{': ' + tail if tail else ''})"

    # -- waiting ------------------------------------------------------------------------------------------
    def mark(self) -> int:
        """Index of the next event; pass to wait_event(since=...) to wait for events after now."""
        with self._cond:
            return len(self.events)

    def wait_event(self, match: Callable[[Event], bool] | str, timeout: float, since: int = 0,
                   what: str = "") -> Event:
        """The first event at index >= `since` that matches (a predicate, or an event name)."""
        pred = (lambda e: e.get("event") == match) if isinstance(match, str) else match
        what = what or (f"'{match}' event" if isinstance(match, str) else "expected event")
        deadline = time.monotonic() + timeout
        i = since
        with self._cond:
            while True:
                while i < len(self.events):
                    ev = self.events[i]
                    i += 1
                    if ev.get("event") == ERROR and what == READY:
                        raise NodeError(f"{self.name}: {ev.get('message')}")
                    if pred(ev):
                        return ev
                left = deadline - time.monotonic()
                if self._proc is not None and self._proc.poll() is not None and i >= len(self.events):
                    # give the readers a moment to drain what the process wrote before exiting
                    if not any(t.is_alive() for t in self._threads) or left <= 0:
                        raise NodeError(f"{self.name}: exited before {what}{self._exit_note()}")
                if left <= 0:
                    raise NodeError(f"{self.name}: no {what} within {timeout:.1f} s{self._exit_note()}; "
                                    f"stderr: {self.stderr_tail() or '(empty)'}")
                self._cond.wait(min(left, 0.1))

    def wait_ready(self, timeout: float = 5.0) -> Event:
        run = self.starts
        return self.wait_event(lambda e: e.get("event") == READY and e.get("_run") == run, timeout,
                               since=0, what=READY)

    def request_stats(self, timeout: float = 3.0) -> Event:
        """Sends ``stats`` and returns the next stats event."""
        m = self.mark()
        self.send("stats")
        return self.wait_event(STATS, timeout, since=m)

    def last(self, name: str) -> Event | None:
        with self._cond:
            for ev in reversed(self.events):
                if ev.get("event") == name:
                    return ev
        return None

    def all(self, name: str) -> list[Event]:
        with self._cond:
            return [e for e in self.events if e.get("event") == name]


_live_groups: weakref.WeakSet[ProcessGroup] = weakref.WeakSet()


def _cleanup_all() -> None:
    for g in list(_live_groups):
        g.close()


atexit.register(_cleanup_all)


class ProcessGroup:
    """Owns processes and other closeables (null-modems); closes them all, last started first."""

    def __init__(self) -> None:
        self.procs: dict[str, NodeProcess] = {}
        self._closers: list[Callable[[], None]] = []
        _live_groups.add(self)

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def add(self, proc: NodeProcess) -> NodeProcess:
        if proc.name in self.procs and self.procs[proc.name] is not proc:
            raise ValueError(f"process name {proc.name!r} used twice")
        self.procs[proc.name] = proc
        return proc

    def spawn(self, argv: Sequence[str], name: str, ready_timeout: float = 5.0, **kw: Any) -> NodeProcess:
        """Starts a process and waits for its ``ready`` event (stopping it again if that fails)."""
        proc = self.add(NodeProcess(argv, name, **kw))
        proc.start()
        try:
            proc.wait_ready(ready_timeout)
        except BaseException:
            proc.stop()
            self.procs.pop(name, None)
            raise
        return proc

    def on_close(self, fn: Callable[[], None]) -> None:
        self._closers.append(fn)

    def __getitem__(self, name: str) -> NodeProcess:
        return self.procs[name]

    def close(self) -> dict[str, int | None]:
        """Stops every process (orderly, then by force) and runs the close hooks. Returns exit statuses."""
        status: dict[str, int | None] = {}
        for name, proc in reversed(list(self.procs.items())):
            try:
                status[name] = proc.stop()
            except Exception:  # keep stopping the others
                proc.kill()
                status[name] = proc.returncode
        while self._closers:
            fn = self._closers.pop()
            try:
                fn()
            except Exception:
                pass
        _live_groups.discard(self)
        return status
