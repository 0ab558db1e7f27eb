"""The paper's HITL set-up (Table 2, figure 11) on one machine: three C node processes + the Python GCS.

    rmax1ob1 (primary), rmax1ob2 (secondary), fcs20 (backup): `uavbus_node` processes (Contract 2)
    gcs1: a Python `uavbus.Node` in this process, driving the global administration table

Links as in `uavbus.sim.topology.table2`. The GCS's event loop runs in the calling thread: every wait
here (`run_for`, `run_until`, waiting for a child's event) keeps polling the GCS node, so its sockets
never back up while the driver waits for something else. Received DATA goes into one `StreamMeter` per
(content, source) with latency = time.monotonic() - the timeTag `time` the C node stamped
(CLOCK_MONOTONIC) at the update.

Used by tests/system/ and examples/demo/hitl_demo.py; `close()` (or the context manager) stops every
process and null-modem, on success, on failure and on Ctrl-C.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uavbus.sim.build import PROGRAM_DIR, REPO, node_program
from uavbus.sim.metrics import StreamMeter
from uavbus.sim.nullmodem import RelayFaults
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeError, NodeProcess, ProcessGroup, is_addr_in_use
from uavbus.sim.protocol import ERROR, READY, REBOUND, STATS
from uavbus.sim.topology import TABLE2_NODES, Topology, table2

__all__ = ["HitlOptions", "Hitl", "catalogue_for", "timetag_latency_ms", "timetag_s", "C_NODES"]

C_NODES = ("secondary", "backup", "primary")   # start order: the TCP server before its client


def catalogue_for(program: Path) -> Path:
    """The catalogue the program was built with: <build>/examples/uavbus/flightsw/flightsw.catalogue.json
    for <build>/programs/node/uavbus_node ($UAVBUS_CATALOGUE overrides)."""
    if os.environ.get("UAVBUS_CATALOGUE"):
        return Path(os.environ["UAVBUS_CATALOGUE"])
    build = program.resolve().parents[len(PROGRAM_DIR.parts)]
    p = build / "examples" / "uavbus" / "flightsw" / "flightsw.catalogue.json"
    if not p.exists():
        raise FileNotFoundError(f"{p}: no catalogue beside {program}; build the examples with CMake")
    return p


def timetag_s(value: Any) -> float | None:
    """The directory's timeTag `time` in seconds (CLOCK_MONOTONIC of its source); None without one."""
    try:
        tt = value["time"]
        stamp = float(tt["seconds"]) + float(tt["microseconds"]) * 1e-6
    except (KeyError, TypeError, IndexError):
        return None
    return stamp if stamp > 0.0 else None


def timetag_latency_ms(value: Any, now: float) -> float | None:
    """now (time.monotonic()) minus the directory's timeTag `time`, in ms; None without a timeTag."""
    stamp = timetag_s(value)
    return None if stamp is None else (now - stamp) * 1000.0


@dataclass
class HitlOptions:
    config: Path = REPO / "examples" / "configs" / "table2.json"
    program: Path | None = None               # default: sim.build.node_program()
    catalogue: Path | None = None             # default: the program's build catalogue
    impair: str | None = None                 # e.g. "loss=0.2,reorder=0.2,seed=1": every link, C and Python
    serial_faults: RelayFaults | None = None  # garbage/chunking on both pty null-modems
    record: Path | None = None                # GCS binary log (received frames)
    stats_ms: int = 500
    node_args: dict[str, list[str]] = field(default_factory=dict)   # extra args per C node
    node_logs: Path | None = None             # each C node records what it receives and sends: <dir>/<node>.ublog
                                              # (a restart keeps the earlier run's as <node>.run<N>.ublog)
    gcs_links: tuple[str, ...] | None = None  # open only these GCS links (None = both)
    gcs_binds: tuple[str, ...] = ("gpsOut", "imuOut", "navFilterState")   # storage for what gcs1 receives
    start_gcs: bool = True
    # Nodes the harness does not start (an emulated board, a real flight computer): node -> {its link:
    # the serial device of that link} (e.g. {"backup": {"onboardPortDatalink1": board.pty}}). The other
    # end opens the device directly; the member cannot be killed or restarted from here.
    external: dict[str, dict[str, str]] = field(default_factory=dict)
    ready_timeout: float = 8.0
    start_attempts: int = 3


def _impair_kwargs(text: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for kv in text.split(","):
        k, _, v = kv.partition("=")
        out[k.strip()] = int(v) if k.strip() in ("seed", "delay", "jitter") else float(v)
    return out


class Hitl:
    def __init__(self, opts: HitlOptions | None = None) -> None:
        self.opts = opts or HitlOptions()
        self.program = Path(self.opts.program) if self.opts.program else node_program()
        self.catalogue_path = Path(self.opts.catalogue) if self.opts.catalogue else catalogue_for(self.program)
        self.group = ProcessGroup()
        self.alloc = PortAllocator()
        self.topo: Topology | None = None
        self.gcs: Any = None            # uavbus.Node
        self.admin: Any = None
        self.meters: dict[tuple[str, str], StreamMeter] = {}
        self.messages: list[tuple[float, str, str, int, bytes]] = []   # (t, name, source, seq, raw)
        self.t0 = time.monotonic()
        self.marks: list[tuple[float, str]] = []
        self.on_message: Callable[[Any], None] | None = None
        # called with the topology before any process starts (e.g. to put an attacker's tap on a link)
        self.on_topology: Callable[[Topology], None] | None = None

    # -- set-up -------------------------------------------------------------------------------------------
    def __enter__(self) -> Hitl:
        try:
            self.start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        for attempt in range(self.opts.start_attempts):
            try:
                self._start_once()
                self.t0 = time.monotonic()
                return
            except NodeError as e:
                if not is_addr_in_use(e) or attempt + 1 == self.opts.start_attempts:
                    raise
                self._stop_all()   # a port was taken meanwhile by someone else: new ports, new start

    def _start_once(self) -> None:
        self.topo = table2(self.opts.config, self.alloc, serial_faults=self.opts.serial_faults)
        for node, ends in self.opts.external.items():
            for link, device in ends.items():
                self.topo.external(node, link, device)
        if self.on_topology is not None:
            self.on_topology(self.topo)
        for name in C_NODES:
            if name in self.opts.external:
                continue
            self.group.spawn(self.node_argv(name), name, ready_timeout=self.opts.ready_timeout, cwd=REPO)
        if self.opts.start_gcs:
            self._start_gcs()

    def node_argv(self, name: str) -> list[str]:
        assert self.topo is not None
        argv = [str(self.program), "--config", str(self.opts.config), "--node", name,
                "--stats-ms", str(self.opts.stats_ms), *self.topo.port_args(name)]
        if self.opts.impair:
            argv += ["--impair", self.opts.impair]
        if self.opts.node_logs is not None:
            Path(self.opts.node_logs).mkdir(parents=True, exist_ok=True)
            argv += ["--record", str(Path(self.opts.node_logs) / f"{name}.ublog"), "--record-tx"]
        return argv + list(self.opts.node_args.get(name, []))

    def node_logs(self, name: str) -> list[Path]:
        """The logs C node `name` wrote, oldest run first (with HitlOptions.node_logs)."""
        if self.opts.node_logs is None:
            return []
        d = Path(self.opts.node_logs)
        runs = sorted(d.glob(f"{name}.run*.ublog"), key=lambda p: int(p.stem.rsplit(".run", 1)[1]))
        return [*runs, *([d / f"{name}.ublog"] if (d / f"{name}.ublog").exists() else [])]

    def _start_gcs(self) -> None:
        from uavbus import Catalogue, Node   # room B's binding; imported late so the harness works without it

        assert self.topo is not None
        cat = Catalogue.load(str(self.catalogue_path))
        self.gcs = Node(cat, config=str(self.opts.config), node="gcs")
        for content in self.opts.gcs_binds:
            self.gcs.bind(content)
        if self.opts.impair:
            self.gcs.set_impairment(**_impair_kwargs(self.opts.impair))
        if self.opts.record:
            Path(self.opts.record).parent.mkdir(parents=True, exist_ok=True)
            self.gcs.record(str(self.opts.record))
        for link, spec in self.topo.specs("gcs").items():
            if self.opts.gcs_links is None or link in self.opts.gcs_links:
                self.gcs.open_port(link, spec)
        self.gcs.on_data(self._on_data)
        self.admin = self.gcs.admin(TABLE2_NODES["gcs"])

    def restart_gcs(self) -> None:
        """A new GCS process, in effect: the Python node is closed (tables and replay state lost) and
        made again from the same config (a signing GCS continues its persisted counter)."""
        if self.gcs is not None:
            self.gcs.close()
            self.gcs = None
        self._start_gcs()

    def _on_data(self, msg: Any) -> None:
        now = time.monotonic()
        value = msg.value
        value = value.to_dict() if hasattr(value, "to_dict") else value
        key = (msg.name, msg.source)
        m = self.meters.get(key)
        if m is None:
            m = self.meters[key] = StreamMeter(msg.name, msg.source, getattr(msg, "dest", "gcs1"))
        stamp = timetag_s(value)
        m.add(now, None if stamp is None else (now - stamp) * 1000.0, value, stamp=stamp)
        self.messages.append((now, msg.name, msg.source, int(getattr(msg, "seq", 0)), bytes(msg.raw)))
        if self.on_message is not None:
            self.on_message(msg)

    # -- running ------------------------------------------------------------------------------------------
    def mark(self, label: str) -> float:
        t = time.monotonic()
        self.marks.append((t, label))
        return t

    def poll(self, timeout: float = 0.01) -> None:
        if self.gcs is not None:
            self.gcs.poll(timeout=timeout)
        else:
            time.sleep(timeout)

    def run_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.poll(min(0.01, max(0.0, deadline - time.monotonic())))

    def run_until(self, cond: Callable[[], Any], timeout: float, what: str) -> Any:
        """Polls the GCS until cond() is truthy; raises TimeoutError naming `what` otherwise."""
        deadline = time.monotonic() + timeout
        while True:
            r = cond()
            if r:
                return r
            if time.monotonic() >= deadline:
                raise TimeoutError(f"{what}: not within {timeout:.1f} s")
            self.poll(0.01)

    def child_event(self, name: str, match: Callable[[dict[str, Any]], bool] | str, timeout: float,
                    since: int = 0) -> dict[str, Any]:
        proc = self.group[name]
        pred = (lambda e: e.get("event") == match) if isinstance(match, str) else match

        def found() -> dict[str, Any] | None:
            for ev in proc.events[since:]:
                if pred(ev):
                    return ev
            if not proc.running:
                raise NodeError(f"{name}: exited{proc._exit_note()}")
            return None

        return self.run_until(found, timeout, f"{name}: event {match if isinstance(match, str) else ''}")

    def child_stats(self, name: str, timeout: float = 3.0) -> dict[str, Any]:
        proc = self.group[name]
        m = proc.mark()
        proc.send("stats")
        return self.child_event(name, STATS, timeout, since=m)

    def add_row(self, kind: str, content: str, source: str, destination: str, period_ms: int) -> Any:
        row = self.admin.add(content=content, source=source, destination=destination, period_ms=period_ms,
                             kind=kind)
        self.admin.activate(row)
        return row

    def wait_status(self, row: Any, status: str, timeout: float) -> dict[str, Any]:
        return self.run_until(lambda: (s := self.admin.status(row)) and s.get("status") == status and s,
                              timeout, f"admin row {row}: status {status!r} (now {self.admin.status(row)})")

    def meter(self, name: str, source: str) -> StreamMeter:
        return self.meters.setdefault((name, source), StreamMeter(name, source, "gcs1"))

    def wait_data(self, name: str, source: str, count: int, timeout: float, since: float = 0.0) -> None:
        self.run_until(lambda: self.meter(name, source).count(since) >= count, timeout,
                       f"{count} x {name} from {source} at gcs1 (got {self.meter(name, source).count(since)})")

    # -- faults -------------------------------------------------------------------------------------------
    def kill(self, name: str) -> None:
        if name in self.opts.external:
            raise NodeError(f"{name}: an external member (not started by this harness): it cannot be killed here")
        self.group[name].kill()

    def restart(self, name: str) -> dict[str, Any]:
        proc: NodeProcess = self.group[name]
        if proc.running:
            proc.stop()
        assert self.topo is not None
        for c in self.topo.connections:   # a rebooted computer's UART holds nothing from before
            if c.modem is not None:
                c.modem.flush("".join(side for side, end in (("a", c.a), ("b", c.b)) if end[0] == name))
        if self.opts.node_logs is not None:  # the new run must not overwrite the log of the one before
            current = Path(self.opts.node_logs) / f"{name}.ublog"
            if current.exists():
                current.rename(current.with_name(f"{name}.run{proc.starts}.ublog"))
        proc.start()
        run = proc.starts
        return self.child_event(name, lambda e: e.get("event") == READY and e.get("_run") == run,
                                self.opts.ready_timeout)

    def rebind(self, name: str, link: str, spec: str, timeout: float = 3.0) -> dict[str, Any]:
        proc = self.group[name]
        m = proc.mark()
        proc.send(f"rebind {link} {spec}")

        def answered(e: dict[str, Any]) -> bool:
            return e.get("event") in (REBOUND, ERROR)

        ev = self.child_event(name, answered, timeout, since=m)
        if ev.get("event") == ERROR:
            raise NodeError(f"{name}: rebind {link} {spec}: {ev.get('message')}")
        return ev

    # -- tear-down ----------------------------------------------------------------------------------------
    def _stop_all(self) -> dict[str, int | None]:
        status = self.group.close()
        self.group = ProcessGroup()
        if self.gcs is not None:
            try:
                self.gcs.close()
            finally:
                self.gcs = None
        if self.topo is not None:
            self.topo.close()
            self.topo = None
        return status

    def close(self) -> dict[str, int | None]:
        """Stops everything; returns the C nodes' exit statuses (0 = clean exit after quit)."""
        return self._stop_all()
