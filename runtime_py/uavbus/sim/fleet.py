"""Runs a fleet scenario (uavbus.sim.scenario): vehicles and ground stations as `uavbus_node` processes
and/or in-process Python nodes, their links, the link models (loss, delay, connectivity by range from the
flight model), the timeline of events, and the measurements: delivery per flow, reconvergence after each
event, routing frames per link per second, hops. Writes `summary.json` and `timeline.png`.

How the parts meet (docs/scenarios.md):
 - one clock: CLOCK_MONOTONIC. t = 0 is `epoch`, passed to every process (`--epoch-ms`), so all vehicles,
   C or Python, sample the same flight model (ub_motion) at the same t, and the launcher knows where each
   one is without reading its GPS;
 - every entity runs automatic routes (ub_route); each node's table starts with itself and the peers of its
   flows (the operator's knowledge); relays are learned;
 - a flow is a subscription at its destination (it re-requests by itself after outages, as the paper says), or,
   with `admin:`, a row of a Python ground station's administration table (subscription or publication), which
   the flow outlives when that ground station goes out of range (docs/pubsub.md, "Who keeps a row alive");
 - a link's model is applied per port with the runtime's impairment (ub_ports_set_link_impairment(), stdin
   `link impair` of uavbus_node; memlink faults in process): loss, delay, jitter always, loss 1 while out of
   range or failed;
 - a vehicle that joins gets its links created on the running peers at run time (`link add`,
   Node.add_link), and the ground station announces it to everybody (MEMBERSHIP add_entity);
 - a ground station may `move` (a new motion from the event on): its radio links follow the range model;
 - `signed: true` (or `identity`): one fleet key, every node signs and refuses unsigned frames (routing frames
   included), and every station has its own identity (issued at run time under OUT/keys: ground stations
   `admin`, vehicles `vehicle,relay`) from which its node takes origin authentication; `signed: group`: the
   fleet key alone (bench mode: any key holder can speak for anyone, docs/security.md).
"""

from __future__ import annotations

import json
import math
import signal
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from uavbus.sim.flight import FlightModel, VehicleDirectories
from uavbus.sim.nullmodem import NullModem
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeError, NodeProcess, ProcessGroup
from uavbus.sim.protocol import ERROR, FLOWS, READY, ROUTES, STATS
from uavbus.sim.scenario import FlowSpec, LinkSpec, Scenario, Station

__all__ = ["FleetRun", "FlowTrack"]

STEP_S = 0.005          # loop turn: Python nodes serviced, events fired
VEHICLE_UPDATE_S = 0.02  # Python vehicles' directories refreshed (50 Hz)
RANGE_STEP_S = 0.1       # range model evaluated
ROUTES_EVERY_S = 2.0     # routing counters sampled
FLOWS_MS = 100           # C destinations report their flows
START_DELAY_S = 1.5      # processes start before t = 0


@dataclass
class LinkEnd:
    station: str
    name: str       # link name at this end ("to_uav2")
    index: int      # link[index] of the station
    spec: str = ""  # port spec ("udp:bind=...,peer=...") for sockets and serial


@dataclass
class RunLink:
    spec: LinkSpec
    ends: tuple[LinkEnd, LinkEnd]
    seed: int
    modem: NullModem | None = None
    memlink: Any = None
    created: bool = False    # both ends exist (a link to a vehicle that joins later is created then)
    out_of_range: bool = False
    failed: bool = False

    @property
    def cut(self) -> bool:
        return self.out_of_range or self.failed

    def label(self) -> str:
        return f"{self.spec.a}-{self.spec.b}"


@dataclass
class Member:
    station: Station
    model: FlightModel
    links: list[LinkEnd] = field(default_factory=list)
    model_t0: float = 0.0    # scenario time at which `model` starts (a ground station's `move`)
    proc: NodeProcess | None = None
    node: Any = None         # uavbus.Node for run: python
    dirs: VehicleDirectories | None = None
    up: bool = False
    starting: bool = False   # process started, waiting for its ready event
    flows_seen: dict[int, dict[tuple[str, str], int]] = field(default_factory=dict)  # run -> flow -> count
    routes_seen: list[tuple[float, int, dict[str, int]]] = field(default_factory=list)  # (t, run, link -> frames)

    @property
    def name(self) -> str:
        return self.station.name

    def next_index(self) -> int:
        used = {e.index for e in self.links}
        return next(i for i in range(8) if i not in used)


@dataclass
class FlowTrack:
    spec: FlowSpec
    count: int = 0
    hops: int | None = None
    first: float | None = None                       # t of the first delivery
    last: float | None = None                        # t of the last delivery
    times: list[float] = field(default_factory=list)  # Python destinations: every delivery
    gaps: set[tuple[float, float]] = field(default_factory=set)
    bins: dict[int, int] = field(default_factory=dict)  # delivery count per 0.5 s
    expected: float = 0.0             # deliveries expected while both ends were up
    expected_connected: float = 0.0   # ... and a path existed
    delivered_connected: float = 0.0
    run_s: float = math.inf           # the scenario's duration: what is expected is counted in [0, run_s)
    in_run: int = 0                   # deliveries in [0, run_s), the ones the expectations are about

    def add(self, t: float, n: int = 1) -> None:
        self.count += n
        if t >= 0.0:  # before t = 0 the processes are still starting
            key = int(t / 0.5)
            self.bins[key] = self.bins.get(key, 0) + n
            if t < self.run_s:
                self.in_run += n


class FleetRun:
    def __init__(self, scenario: Scenario, out_dir: str | Path, *, program: str | Path | None = None,
                 catalogue: str | Path | None = None, log: Callable[[str], None] | None = None) -> None:
        from uavbus.sim.build import node_program
        from uavbus.sim.hitl import catalogue_for

        self.sc = scenario
        self.out = Path(out_dir)
        self.out.mkdir(parents=True, exist_ok=True)
        self.program = Path(program) if program else node_program()
        self.catalogue_path = Path(catalogue) if catalogue else catalogue_for(self.program)
        self.log = log or (lambda s: print(s, flush=True))
        self.group = ProcessGroup()
        self.alloc = PortAllocator()
        self.members: dict[str, Member] = {s.name: Member(s, FlightModel(s.motion)) for s in scenario.stations}
        self.links: list[RunLink] = []
        self.flows = {f.name: FlowTrack(f, run_s=scenario.duration_s) for f in scenario.flows}
        self.timeline: list[dict[str, Any]] = []   # fired events, range transitions
        self.epoch = 0.0
        self.catalogue: Any = None
        self.announcements: list[tuple[Any, int]] = []  # (Membership of a Python ground station, row)
        self.admin_rows: dict[str, tuple[Any, int]] = {}  # flow name -> (Admin of its ground station, row)
        self.final_stats: dict[str, dict[str, Any]] = {}  # process name -> its last `stats` event
        self._calls: list[tuple[float, Callable[[FleetRun, float], None]]] = []
        self.connectivity0: dict[str, bool] = {}  # per flow, a path at t = 0 (before any event)
        self._modems: list[NullModem] = []

    # ---- time ------------------------------------------------------------------------------------------
    def t(self) -> float:
        return time.monotonic() - self.epoch

    def call_at(self, t: float, fn: Callable[[FleetRun, float], None]) -> None:
        """Calls fn(run, t) from the loop once scenario time `t` is reached (an operator's action that the
        file format has no word for, e.g. a second administrator's row)."""
        self._calls.append((t, fn))
        self._calls.sort(key=lambda c: c[0])

    # ---- set-up ----------------------------------------------------------------------------------------
    def _plan_links(self) -> None:
        """Names, indexes and port specs of every link end (links to late joiners included)."""
        names: dict[tuple[str, str], int] = {}
        for k, spec in enumerate(self.sc.links):
            ends = []
            for me, peer in ((spec.a, spec.b), (spec.b, spec.a)):
                n = names[(me, peer)] = names.get((me, peer), 0) + 1
                member = self.members[me]
                end = LinkEnd(me, f"to_{peer}" if n == 1 else f"to_{peer}_{n}", member.next_index())
                member.links.append(end)
                ends.append(end)
            link = RunLink(spec, (ends[0], ends[1]), seed=self.sc.seed * 1000 + 2 * k)
            ext = [e for e in link.ends if self.members[e.station].station.external]
            if ext:
                # The external member's port is its own; the launcher's end faces it (the same serial device,
                # TCP the other way round, UDP mirrored). Nothing is relayed: the bytes go straight to it.
                from uavbus.sim.scenario import peer_port

                mine = next(e for e in link.ends if e is not ext[0])
                port = self.members[ext[0].station].station.port
                mine.spec, ext[0].spec = peer_port(port), ""
                self.links.append(link)
                continue
            if spec.transport == "udp":
                pa, pb = self.alloc.addr(), self.alloc.addr()
                link.ends[0].spec, link.ends[1].spec = f"udp:bind={pa},peer={pb}", f"udp:bind={pb},peer={pa}"
            elif spec.transport == "tcp":
                addr = self.alloc.addr()
                link.ends[0].spec, link.ends[1].spec = f"tcp:connect={addr}", f"tcp:listen={addr}"
            elif spec.transport == "serial":
                link.modem = NullModem(link.label())
                link.modem.start()
                self._modems.append(link.modem)
                link.ends[0].spec = f"serial:device={link.modem.path_a},baud=115200"
                link.ends[1].spec = f"serial:device={link.modem.path_b},baud=115200"
            if spec.encoding == "compact" and spec.transport != "memory":
                for e in link.ends:
                    e.spec += ",encoding=compact"
            self.links.append(link)
        joins = self.sc.joins()
        for m in self.members.values():
            # Links to a vehicle that joins later are created on this end when it joins (membership at run time).
            m.links = [e for e in m.links if self._peer_of(e) not in joins or m.name in joins]
            for i, e in enumerate(sorted(m.links, key=lambda e: e.index)):
                e.index = i

    def _peer_of(self, end: LinkEnd) -> str:
        link = self._link_of(end)
        return link.spec.b if end.station == link.spec.a else link.spec.a

    def _link_of(self, end: LinkEnd) -> RunLink:
        return next(link for link in self.links if end in link.ends)

    def _config(self, m: Member) -> Path:
        """This node's table: itself with its links, and the peers of its flows (the operator's knowledge); an
        administrator also knows the ends of the flows it sets up. Signed scenarios get the fleet key."""
        peers = sorted(({f.source for f in self.sc.flows if f.destination == m.name} |
                        {f.destination for f in self.sc.flows if f.source == m.name} |
                        {x for f in self.sc.flows if f.admin == m.name for x in (f.source, f.destination)})
                       - {m.name})
        links = [e.name for e in sorted(m.links, key=lambda e: e.index)]
        if [e.index for e in sorted(m.links, key=lambda e: e.index)] != list(range(len(links))):
            # Indexes have holes (links added at run time, then a restart): keep positions with placeholders.
            by_index = {e.index: e.name for e in m.links}
            links = [by_index.get(i, f"unused{i}") for i in range(max(by_index) + 1)]
        me: dict[str, Any] = {"name": m.name, "links": links}
        fixed = {}   # external neighbours without routing: no HELLO will teach the route, so it is pinned here
        for e in m.links:
            other = self.members[self._peer_of(e)].station
            if other.external and not other.routing:
                fixed[other.name] = fixed.get(other.name, 0) | (1 << e.index)
        if fixed:
            me["linktoentity"] = {name: f"0x{mask:08x}" for name, mask in sorted(fixed.items())}
            peers = sorted(set(peers) | set(fixed))
        doc = {"system": self.sc.name, "entities": [me] + [{"name": p} for p in peers],
               "nodes": {m.name: [m.name]}}
        path = self.out / "configs" / f"{m.name}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(doc, indent=1) + "\n")
        if self.sc.signed:
            from uavbus.sim.secure import signed_config

            # One fleet key for every node (created once, mode 0600); counters in configs/state/.
            path = signed_config(path, path.parent, keys_dir=self.out / "keys", name=f"{m.name}.signed.json")
            if self.sc.signed_mode == "identity":
                self._identity(path)
        return path

    def _identity(self, path: Path) -> None:
        """Names the stations' identities in signed config `path`; the first call issues them all (a new
        authority per output folder, identities replaced on a rerun: new keys, next serials)."""
        import json
        import shutil

        from uavbus import keys

        kdir = self.out / "keys"
        if not getattr(self, "_issued", False):
            if not (kdir / "authority.key").exists():
                keys.authority_create(str(kdir))
            for st in self.sc.stations:
                keys.issue(st.name, "admin" if st.kind == "gcs" else "vehicle,relay", 30, None, str(kdir), None, True)
            self._issued = True
        doc = json.loads(path.read_text(encoding="utf-8"))
        name = doc["entities"][0]["name"]
        certs = path.parent / "state" / f"{name}.certs"   # each node its own copy (it rewrites it as it learns)
        shutil.copyfile(kdir / keys.CERTS_NAME, certs)
        doc["security"].update({"authority": str((kdir / "authority.pub").resolve()),
                                "identity": str(kdir.resolve() / "{entity}.id"),
                                "certificates": f"state/{name}.certs",
                                "revocations": f"state/{name}.revocations.ubr"})
        path.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")

    def _argv(self, m: Member) -> list[str]:
        argv = [str(self.program), "--config", str(self._config(m)), "--node", m.name, "--stats-ms", "0",
                "--route", self.sc.routing.route_arg(), "--epoch-ms", str(int(self.epoch * 1000)),
                "--flows-ms", str(FLOWS_MS), "--motion", m.station.motion]
        gaps = [f.gap_ms for f in self.sc.flows if f.destination == m.name]
        if gaps:
            argv += ["--flow-gap-ms", str(min(gaps))]
        if m.station.is_vehicle:
            argv += ["--produce", m.name]
        for e in m.links:
            if e.spec:
                argv += ["--port", f"{e.name}={e.spec}"]
        for f in self.sc.flows:
            if f.destination == m.name and f.admin is None:
                argv += ["--subscribe", f"{m.name}:{f.content}@{f.source}/{f.period_ms}"]
        return argv

    def _start_process(self, m: Member) -> None:
        argv = self._argv(m)
        if m.proc is None:
            m.proc = self.group.add(NodeProcess(argv, m.name))
        else:
            m.proc.argv = argv
        for e in m.links:  # a rebooting computer's UART loses what was queued for it
            link = self._link_of(e)
            if link.modem is not None:
                link.modem.flush("a" if e is link.ends[0] else "b")
        m.proc.start()
        m.starting = True

    def _start_python(self, m: Member) -> None:
        from uavbus import Node

        node = Node(self.catalogue, config=self._config(m), node=m.name)
        for e in m.links:
            if e.spec:
                node.open_port(e.name, e.spec)
        node.enable_routing(**self.sc.routing.node_options())
        if m.station.is_vehicle:
            m.dirs = VehicleDirectories(node, m.model)
        for f in self.sc.flows:
            if f.destination == m.name and f.admin is None:
                node.subscribe(m.name, f.content, source=f.source, period_ms=f.period_ms)
            elif f.destination == m.name:
                node.bind(f.content)   # storage for what an administrator will have sent here (idempotent)
        node.on_data(lambda msg, me=m.name: self._on_message(me, msg))
        m.node = node
        m.up = True

    def _connect_memory(self) -> None:
        from uavbus import MemLink

        for link in self.links:
            a, b = (self.members[e.station] for e in link.ends)
            if link.spec.transport == "memory" and a.node is not None and b.node is not None and link.memlink is None:
                link.memlink = MemLink(a.node, link.ends[0].name, b.node, link.ends[1].name, seed=link.seed)

    def start(self) -> None:
        from uavbus import Catalogue

        self.catalogue = Catalogue.load(self.catalogue_path)
        self.epoch = time.monotonic() + START_DELAY_S
        self._plan_links()
        joins = self.sc.joins()
        for m in self.members.values():
            if m.name in joins:
                continue
            if m.station.external:
                m.up = True   # there already (the scenario says so); measured, never started
            elif m.station.run == "process":
                self._start_process(m)
            else:
                self._start_python(m)
        for link in self.links:
            link.created = all(e.station not in joins for e in link.ends)
        # Where everybody stands at t = 0 is the starting state, not an event.
        pos = self._positions(0.0)
        for link in self.links:
            link.out_of_range = pos[link.spec.a].distance(pos[link.spec.b]) > link.spec.range_m
        self._connect_memory()
        self.connectivity0 = self._connectivity()
        deadline = time.monotonic() + 15.0
        while any(m.starting for m in self.members.values()):
            self._service()
            time.sleep(STEP_S)
            if time.monotonic() > deadline:
                late = [m.name for m in self.members.values() if m.starting]
                raise NodeError(f"not ready within 15 s: {', '.join(late)}")
        for link in self.links:
            if link.created:
                self._impair(link)
        for f in self.sc.admin_flows:
            # The operator fills the administration table (paper Figure 5) and activates the rows.
            adm = self.members[f.admin].node.admin(f.admin)
            row = adm.add(f.content, f.source, f.destination, f.period_ms, kind=f.kind)
            adm.activate(row)
            self.admin_rows[f.name] = (adm, row)
        self.log(f"[{self.sc.name}] {len(self.sc.vehicles)} vehicles, {len(self.sc.ground_stations)} ground "
                 f"stations, {len(self.links)} links, {len(self.flows)} flows"
                 f"{', signed' if self.sc.signed else ''}; t=0 in {-self.t():.1f} s")

    # ---- link models -------------------------------------------------------------------------------------
    def _impair(self, link: RunLink) -> None:
        s = link.spec
        loss = 1.0 if link.cut else s.loss
        for k, e in enumerate(link.ends):
            m = self.members[e.station]
            if not (m.up and link.created):
                continue
            seed = link.seed + k
            if s.transport == "memory":
                continue
            rate = s.bandwidth_bps // 8  # bytes per second the medium carries (ub_impair.h)
            if m.proc is not None:
                text = "off" if not (loss or s.delay_ms or s.jitter_ms or rate) else (
                    f"loss={loss:.6f},delay={s.delay_ms},jitter={s.jitter_ms},rate={rate},seed={seed}")
                m.proc.send(f"link impair {e.name} {text}")
            elif m.node is not None:
                m.node.set_link_impairment(e.name, loss=loss, delay=s.delay_ms, jitter=s.jitter_ms, seed=seed,
                                           rate=rate)
        if link.memlink is not None:
            link.memlink.set_faults({"loss_ppm": round(loss * 1e6), "delay_ms": s.delay_ms, "jitter_ms": s.jitter_ms})

    def _positions(self, t: float) -> dict[str, Any]:
        return {name: m.model.sample(t - m.model_t0) for name, m in self.members.items()}

    def _range_step(self, t: float) -> None:
        pos = self._positions(t)
        for link in self.links:
            if math.isinf(link.spec.range_m):
                continue
            d = pos[link.spec.a].distance(pos[link.spec.b])
            out = d > link.spec.range_m
            if out != link.out_of_range:
                link.out_of_range = out
                self._mark(t, "out_of_range" if out else "in_range", (link.spec.a, link.spec.b),
                           f"{'out of' if out else 'back in'} range {link.label()} ({d:.0f} m)")
                self._impair(link)

    # ---- events ------------------------------------------------------------------------------------------
    def _mark(self, t: float, kind: str, target: tuple[str, ...], text: str) -> None:
        self.timeline.append({"t": round(t, 3), "event": kind, "target": list(target), "text": text,
                              "connectivity": self._connectivity()})
        self.log(f"[{self.sc.name}] t={t:6.2f}  {text}")

    def _fire(self, kind: str, target: tuple[str, ...], t: float) -> None:
        if kind == "kill":
            m = self.members[target[0]]
            if m.proc is not None:
                m.proc.kill(signal.SIGKILL)
            else:
                self._kill_python(m)
            m.up = False
        elif kind == "restart":
            m = self.members[target[0]]
            if m.station.run == "process":
                self._start_process(m)
            else:
                self._start_python(m)
                self._connect_memory()
                self._restore_admin_rows(m)
                for e in m.links:
                    if self._link_of(e).created:
                        self._impair(self._link_of(e))
        elif kind in ("fail_link", "restore_link"):
            for link in self.links:
                if link.spec.pair == frozenset(target):
                    link.failed = kind == "fail_link"
                    self._impair(link)
        elif kind == "add":
            self._join(self.members[target[0]])
        self._mark(t, kind, target, f"{kind} {' '.join(target)}")

    def _kill_python(self, m: Member) -> None:
        """A ground station in the launcher dies: its node goes with its tables, sockets and administration
        rows, as a GCS process killed with -9 would (what it administered lives on at its keepers)."""
        if m.node is not None:
            m.node.close()
            m.node = None
        m.dirs = None

    def _restore_admin_rows(self, m: Member) -> None:
        """A restarted ground station's operator fills its administration table again (it was lost with the
        process): rows of the flows it administers, activated."""
        for f in self.sc.admin_flows:
            if f.admin == m.name:
                adm = m.node.admin(f.admin)
                row = adm.add(f.content, f.source, f.destination, f.period_ms, kind=f.kind)
                adm.activate(row)
                self.admin_rows[f.name] = (adm, row)

    def _move(self, name: str, motion: str, t: float) -> None:
        m = self.members[name]
        m.model, m.model_t0 = FlightModel(motion), t
        self._mark(t, "move", (name,), f"move {name}")

    def _join(self, m: Member) -> None:
        """A vehicle joins: its links are created on the running peers (membership at run time), it starts,
        and the ground stations announce it."""
        for link in self.links:
            if m.name not in (link.spec.a, link.spec.b) or link.created:
                continue
            other = next(e for e in link.ends if e.station != m.name)
            peer = self.members[other.station]
            other.index = peer.next_index()
            peer.links.append(other)
            if peer.proc is not None:
                peer.proc.send(f"link add {peer.name} {other.index} {other.name} {other.spec}".rstrip())
            else:
                peer.node.add_link(peer.name, other.index, other.name)
                if other.spec:
                    peer.node.open_port(other.name, other.spec)
            link.created = True
        if m.station.run == "process":
            self._start_process(m)
        else:
            self._start_python(m)
            self._connect_memory()
        for g in self.sc.ground_stations:
            gm = self.members[g.name]
            targets = [n for n, o in self.members.items() if o.up and n not in (m.name, g.name)
                       and not (o.station.external and not o.station.routing)]
            if gm.node is not None:
                ms = gm.node.membership(max_retries=25)
                self.announcements += [(ms, row) for row in ms.announce(m.name, targets)]
            elif gm.proc is not None and gm.up:
                gm.proc.send(f"announce {m.name} {' '.join(targets)}")

    # ---- measurements ------------------------------------------------------------------------------------
    def _on_message(self, dest: str, msg: Any) -> None:
        t = self.t()
        for tr in self.flows.values():
            f = tr.spec
            if f.destination == dest and f.source == msg.source and f.content == msg.name:
                tr.add(t)
                tr.times.append(t)
                tr.hops = msg.hops
                tr.last = t
                if tr.first is None:
                    tr.first = t

    def _on_process_event(self, m: Member, ev: dict[str, Any]) -> None:
        kind = ev.get("event")
        run = int(ev.get("_run", 0))
        if kind == READY and m.starting and run == m.proc.starts:
            m.starting = False
            m.up = True
            for e in m.links:
                link = self._link_of(e)
                if link.created:
                    self._impair(link)
        elif kind == FLOWS:
            seen = m.flows_seen.setdefault(run, {})
            t = ev["t_ms"] / 1000.0 - self.epoch
            for fl in ev["flows"]:
                tr = next((x for x in self.flows.values() if x.spec.destination == fl["entity"] and
                           x.spec.source == fl["source"] and x.spec.content == fl["content"]), None)
                if tr is None:
                    continue
                key = (fl["source"], fl["content"])
                delta = fl["count"] - seen.get(key, 0)
                seen[key] = fl["count"]
                if delta > 0:
                    tr.add(t, delta)
                tr.hops = fl["hops"] or tr.hops
                tr.last = max(tr.last or -1e9, fl["last_ms"] / 1000.0 - self.epoch)
                first = fl["first_ms"] / 1000.0 - self.epoch
                tr.first = first if tr.first is None else min(tr.first, first)
                for a, b in fl["recent_gaps"]:
                    tr.gaps.add((round(a / 1000.0 - self.epoch, 3), round(b / 1000.0 - self.epoch, 3)))
        elif kind == ROUTES:
            # The hello/update budget: fast hellos (liveness on links carrying traffic, docs/routing.md "Transport
            # evidence") are counted apart.
            frames = {name: int(li["frames_out"]) - int(li.get("fast_hellos_out", 0))
                      for name, li in ev.get("links", {}).items()}
            m.routes_seen.append((ev["t_ms"] / 1000.0 - self.epoch, run, frames))
        elif kind == STATS:
            self.final_stats[m.name] = ev
        elif kind == ERROR:
            self.log(f"[{self.sc.name}] {m.name}: {ev.get('message')}")

    def _drain(self) -> None:
        for m in self.members.values():
            if m.proc is None:
                continue
            cursor = getattr(m, "_cursor", 0)
            events = m.proc.events
            while cursor < len(events):
                self._on_process_event(m, events[cursor])
                cursor += 1
            m._cursor = cursor  # type: ignore[attr-defined]
            if m.up and not m.proc.running:
                m.up = False
                self.log(f"[{self.sc.name}] {m.name} exited unexpectedly: {m.proc.stderr_tail()[-300:]}")

    def _sample_routes(self) -> None:
        t = self.t()
        for m in self.members.values():
            if not m.up:
                continue
            if m.proc is not None:
                m.proc.send("routes")
            elif m.node is not None:
                frames = {name: li["frames_out"] - li.get("fast_hellos_out", 0) for name, li in m.node.route_links().items()}
                m.routes_seen.append((t, 0, frames))

    def _connectivity(self) -> dict[str, bool]:
        """Per flow: both ends up and a path of created, uncut links between them."""
        up = {n for n, m in self.members.items() if m.up or m.starting}
        adj: dict[str, set[str]] = {n: set() for n in up}
        for link in self.links:
            if link.created and not link.cut and link.spec.a in up and link.spec.b in up:
                adj[link.spec.a].add(link.spec.b)
                adj[link.spec.b].add(link.spec.a)
        out = {}
        for name, tr in self.flows.items():
            f = tr.spec
            seen, todo = {f.source}, deque([f.source]) if f.source in up else deque()
            while todo:
                for y in adj[todo.popleft()] - seen:
                    seen.add(y)
                    todo.append(y)
            out[name] = f.source in up and f.destination in up and f.destination in seen
        return out

    def _expect_step(self, dt: float) -> None:
        up = {n for n, m in self.members.items() if m.up}
        conn = self._connectivity()
        for name, tr in self.flows.items():
            f = tr.spec
            if f.source in up and f.destination in up:
                tr.expected += dt * 1000.0 / f.period_ms
                if conn[name]:
                    tr.expected_connected += dt * 1000.0 / f.period_ms

    # ---- the loop ----------------------------------------------------------------------------------------
    def _service(self) -> None:
        for m in self.members.values():
            if m.node is not None and m.up:
                m.node.service()
        self._drain()

    def run(self) -> dict[str, Any]:
        try:
            self.start()
            self._loop()
            return self.finish()
        finally:
            self.close()

    def _loop(self) -> None:
        pending = list(self.sc.events)
        next_vehicle = next_range = next_routes = 0.0
        last = self.t()
        while True:
            t = self.t()
            if t >= self.sc.duration_s:
                break
            if t >= 0.0:
                while pending and pending[0].t <= t:
                    e = pending.pop(0)
                    if e.kind == "move":
                        self._move(e.target[0], e.motion, t)
                    else:
                        self._fire(e.kind, e.target, t)
                while self._calls and self._calls[0][0] <= t:
                    self._calls.pop(0)[1](self, t)
                if t >= next_range:
                    self._range_step(t)
                    next_range = t + RANGE_STEP_S
                if t >= next_routes:
                    self._sample_routes()
                    next_routes = t + ROUTES_EVERY_S
                self._expect_step(t - max(last, 0.0))
            if t >= next_vehicle:
                for m in self.members.values():
                    if m.dirs is not None and m.up:
                        m.dirs.update(max(t, 0.0), VEHICLE_UPDATE_S)
                next_vehicle = t + VEHICLE_UPDATE_S
            last = t
            self._service()
            time.sleep(STEP_S)

    def counters(self) -> dict[str, dict[str, Any]]:
        """Node counters per station: Python nodes read now, processes from their last `stats` event."""
        out: dict[str, dict[str, Any]] = {}
        for name, m in self.members.items():
            if m.node is not None:
                out[name] = m.node.counters()
                origin = m.node.security.origin_status()
            elif name in self.final_stats:
                out[name] = dict(self.final_stats[name].get("node", {}))
                origin = (self.final_stats[name].get("security") or {}).get("origin")
            else:
                continue
            if origin is not None:   # signed with identities: what origin authentication did
                out[name]["origin"] = {k: origin[k] for k in ("sealed", "opened", "bad_origin", "no_origin",
                                                              "no_identity") if k in origin}
        return out

    def finish(self) -> dict[str, Any]:
        self._sample_routes()
        for m in self.members.values():
            if m.proc is not None and m.up:
                m.proc.send("stats")
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            self._service()
            time.sleep(STEP_S)
        from uavbus.sim.fleet_report import summarize, plot_timeline

        summary = summarize(self)
        (self.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        try:
            plot_timeline(self, self.out / "timeline.png")
        except ImportError:
            self.log(f"[{self.sc.name}] matplotlib is not installed (pip install 'uavbus[demo]'): no timeline.png")
        return summary

    def close(self) -> None:
        for m in self.members.values():
            if m.node is not None:
                m.node.close()
                m.node = None
        self.group.close()
        for nm in self._modems:
            nm.close()
        self._modems = []

