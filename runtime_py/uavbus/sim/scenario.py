"""Fleet scenario files (`uavbus sim SCENARIO`, docs/scenarios.md): YAML in, a validated `Scenario` out.

Every error names the file and line and says what to do (`fleet.yaml:14: link [uav1, uav9]: 'uav9' is not
a vehicle or ground station of this scenario (known: gcs1, uav1, ...)`). The model is plain frozen
dataclasses; `uavbus.sim.fleet` runs it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["Scenario", "Station", "LinkSpec", "FlowSpec", "EventSpec", "RoutingSpec", "ScenarioError",
           "load_scenario", "parse_scenario"]

MAX_LINKS = 8  # the paper's links per entity (UB_MAX_LINKS_PER_ENTITY)
TRANSPORTS = ("udp", "tcp", "serial", "memory")
MODELS = ("radio", "wire")
EVENT_KINDS = ("kill", "restart", "add", "fail_link", "restore_link", "move")
FLOW_KINDS = ("subscription", "publication")
PRODUCED = ("gpsOut", "imuOut", "navFilterState")
DATUM = {"lat": 32.3738, "lon": -84.9664, "alt": 120.0}


class ScenarioError(ValueError):
    """A scenario file that cannot run; the message is `file:line: what is wrong, what to do`."""


@dataclass(frozen=True)
class RoutingSpec:
    hello_ms: int = 200
    update_ms: int = 0           # 0: 4 * hello_ms
    dead_misses: int = 2
    parallel: str = "all"

    def route_arg(self) -> str:
        """uavbus_node --route text."""
        parts = [f"hello={self.hello_ms}", f"dead={self.dead_misses}", f"parallel={self.parallel}"]
        if self.update_ms:
            parts.append(f"update={self.update_ms}")
        return ",".join(parts)

    def node_options(self) -> dict[str, Any]:
        """Node.enable_routing() keyword arguments."""
        out: dict[str, Any] = {"hello_ms": self.hello_ms, "dead_misses": self.dead_misses, "parallel": self.parallel}
        if self.update_ms:
            out["update_ms"] = self.update_ms
        return out


@dataclass(frozen=True)
class Station:
    """A vehicle or a ground station: one entity, hosted by a C process or in the launcher's process."""

    name: str
    kind: str                    # "vehicle" | "gcs"
    run: str                     # "process" (uavbus_node) | "python" (a Node in the launcher) | "external"
    motion: str                  # ub_motion text ("orbit:...", "waypoints:...", "static:...")
    line: int
    port: str = ""               # run: external: the member's own port (its end of its one link)
    routing: bool = True         # run: external: it runs automatic routes (False: a fixed table, e.g. firmware)

    @property
    def is_vehicle(self) -> bool:
        return self.kind == "vehicle"

    @property
    def external(self) -> bool:
        """A node the launcher did not start (an emulated board, a real flight computer, a node elsewhere):
        connected to, measured, never started, killed or restarted."""
        return self.run == "external"


@dataclass(frozen=True)
class LinkSpec:
    a: str
    b: str
    transport: str
    model: str                   # "radio" (connected while in range) | "wire" (always)
    range_m: float
    loss: float
    delay_ms: int
    jitter_ms: int
    line: int
    bandwidth_bps: int = 0       # bits/s the link carries (the impairment's byte rate, bandwidth_bps / 8); 0: no limit
    encoding: str = "full"       # the ports' wire encoding: "full" or "compact" (docs/wire-format.md)

    @property
    def pair(self) -> frozenset[str]:
        return frozenset((self.a, self.b))


@dataclass(frozen=True)
class FlowSpec:
    name: str
    content: str
    source: str
    destination: str
    period_ms: int
    line: int
    admin: str | None = None     # ground station whose administration table sets the flow up (None: the
                                 # destination subscribes by itself)
    kind: str = "subscription"   # the administration row's type (FLOW_KINDS)

    @property
    def gap_ms(self) -> int:
        """Silence that counts as an outage: three periods, at least 300 ms."""
        return max(3 * self.period_ms, 300)


@dataclass(frozen=True)
class EventSpec:
    t: float
    kind: str                    # EVENT_KINDS
    target: tuple[str, ...]      # one name, or the two ends of a link
    line: int
    motion: str = ""             # move: the station's new motion, sampled from the event's time

    def describe(self) -> str:
        return f"{self.kind} {'-'.join(self.target)}"


@dataclass(frozen=True)
class Scenario:
    name: str
    source: str                  # file name, for messages
    duration_s: float
    seed: int
    routing: RoutingSpec
    stations: tuple[Station, ...]
    links: tuple[LinkSpec, ...]
    flows: tuple[FlowSpec, ...]
    events: tuple[EventSpec, ...]
    datum: dict[str, float] = field(default_factory=lambda: dict(DATUM))
    signed: bool = False         # every node signs with one fleet key and refuses unsigned frames
    signed_mode: str = "identity"  # with `signed`: "identity" (each station its own, origin-authenticated) or "group"

    @property
    def admin_flows(self) -> list[FlowSpec]:
        return [f for f in self.flows if f.admin is not None]

    def station(self, name: str) -> Station:
        return next(s for s in self.stations if s.name == name)

    @property
    def vehicles(self) -> list[Station]:
        return [s for s in self.stations if s.is_vehicle]

    @property
    def ground_stations(self) -> list[Station]:
        return [s for s in self.stations if not s.is_vehicle]

    def joins(self) -> dict[str, float]:
        """Vehicles that join later: name -> time of their `add` event."""
        return {e.target[0]: e.t for e in self.events if e.kind == "add"}


# ---- YAML with lines ---------------------------------------------------------------------------------


class _Src:
    """Raises file:line errors for one document."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, node: Any, msg: str) -> ScenarioError:
        line = node.start_mark.line + 1 if node is not None and hasattr(node, "start_mark") else 1
        return ScenarioError(f"{self.source}:{line}: {msg}")


def _line(node: Any) -> int:
    return node.start_mark.line + 1


def _mapping(src: _Src, node: Any, what: str, allowed: dict[str, bool]) -> dict[str, Any]:
    """A YAML mapping as {key: value node}; unknown keys, repeated keys and missing required keys are errors
    (`allowed`: key -> required)."""
    import yaml

    if not isinstance(node, yaml.MappingNode):
        raise src.fail(node, f"{what} must be a mapping (key: value)")
    out: dict[str, Any] = {}
    for k, v in node.value:
        if not isinstance(k, yaml.ScalarNode):
            raise src.fail(k, f"{what}: keys must be plain words")
        if k.value in out:
            raise src.fail(k, f"{what}: '{k.value}' given twice; keep one")
        if k.value not in allowed:
            raise src.fail(k, f"{what}: unknown key '{k.value}' (expected: {', '.join(sorted(allowed))})")
        out[k.value] = v
    for k, required in allowed.items():
        if required and k not in out:
            raise src.fail(node, f"{what}: '{k}' is required")
    return out


def _seq(src: _Src, node: Any, what: str) -> list[Any]:
    import yaml

    if not isinstance(node, yaml.SequenceNode):
        raise src.fail(node, f"{what} must be a list")
    return list(node.value)


def _scalar(src: _Src, node: Any, what: str) -> str:
    import yaml

    if not isinstance(node, yaml.ScalarNode):
        raise src.fail(node, f"{what} must be a single value")
    return str(node.value)


def _number(src: _Src, node: Any, what: str, lo: float | None = None, hi: float | None = None,
            integer: bool = False) -> float:
    text = _scalar(src, node, what)
    try:
        value = float(text)
    except ValueError:
        raise src.fail(node, f"{what}: '{text}' is not a number") from None
    if not math.isfinite(value) or (integer and value != int(value)):
        raise src.fail(node, f"{what}: '{text}' must be a {'whole ' if integer else ''}number")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        rng = f"{lo if lo is not None else '-inf'} .. {hi if hi is not None else 'inf'}"
        raise src.fail(node, f"{what}: {text} is out of range ({rng})")
    return int(value) if integer else value


def _name(src: _Src, node: Any, what: str) -> str:
    text = _scalar(src, node, what)
    if not 1 <= len(text) <= 12 or not all(c.isalnum() or c in "_.-" for c in text):
        raise src.fail(node, f"{what}: '{text}' is not an entity name (1 to 12 characters A-Z a-z 0-9 _ . -)")
    return text


def _choice(src: _Src, node: Any, what: str, choices: tuple[str, ...]) -> str:
    text = _scalar(src, node, what)
    if text not in choices:
        raise src.fail(node, f"{what}: '{text}' is not one of {', '.join(choices)}")
    return text


def _motion(src: _Src, node: Any, what: str) -> str:
    from uavbus._bindings.ub_motion import MotionError
    from uavbus.sim.flight import FlightModel

    text = _scalar(src, node, what)
    try:
        FlightModel(text)  # the C parser: one grammar for uavbus_node --motion and Python
    except MotionError as e:
        raise src.fail(node, f"{what}: {e.detail}") from None
    return text


# ---- the document ------------------------------------------------------------------------------------


def _routing(src: _Src, node: Any) -> RoutingSpec:
    m = _mapping(src, node, "routing", {"hello_ms": False, "update_ms": False, "dead_misses": False,
                                        "parallel": False})
    hello = int(_number(src, m["hello_ms"], "routing.hello_ms", 10, 65535, True)) if "hello_ms" in m else 200
    update = int(_number(src, m["update_ms"], "routing.update_ms", hello, 65535, True)) if "update_ms" in m else 0
    dead = int(_number(src, m["dead_misses"], "routing.dead_misses", 1, 16, True)) if "dead_misses" in m else 2
    parallel = _choice(src, m["parallel"], "routing.parallel", ("all", "best")) if "parallel" in m else "all"
    return RoutingSpec(hello, update, dead, parallel)


def _radio(src: _Src, node: Any | None) -> dict[str, float]:
    out = {"range_m": math.inf, "loss": 0.0, "delay_ms": 0, "jitter_ms": 0, "bandwidth_bps": 0}
    if node is None:
        return out
    m = _mapping(src, node, "radio", {"range_m": False, "loss": False, "delay_ms": False, "jitter_ms": False,
                                      "bandwidth_bps": False})
    _link_model_values(src, m, "radio", out)
    return out


def _link_model_values(src: _Src, m: dict[str, Any], what: str, out: dict[str, float]) -> None:
    if "bandwidth_bps" in m:  # the impairment's byte rate (ub_impair.h): bandwidth_bps / 8 bytes per second
        out["bandwidth_bps"] = _number(src, m["bandwidth_bps"], f"{what}.bandwidth_bps", 80, 8_000_000_000, True)
    if "range_m" in m:
        out["range_m"] = _number(src, m["range_m"], f"{what}.range_m", 1.0)
    if "loss" in m:
        out["loss"] = _number(src, m["loss"], f"{what}.loss", 0.0, 0.99)
    if "delay_ms" in m:
        out["delay_ms"] = _number(src, m["delay_ms"], f"{what}.delay_ms", 0, 10000, True)
    if "jitter_ms" in m:
        out["jitter_ms"] = _number(src, m["jitter_ms"], f"{what}.jitter_ms", 0, 10000, True)


def _stations(src: _Src, node: Any, kind: str, seen: dict[str, int]) -> list[Station]:
    out = []
    what = "vehicles" if kind == "vehicle" else "ground_stations"
    for item in _seq(src, node, what):
        m = _mapping(src, item, what[:-1] if kind == "vehicle" else "ground station",
                     {"name": True, "run": False, "motion": False, "position": False, "port": False,
                      "routing": False})
        name = _name(src, m["name"], "name")
        if name in seen:
            raise src.fail(m["name"], f"'{name}' is already used on line {seen[name]}; names are unique")
        seen[name] = _line(m["name"])
        run = _choice(src, m["run"], f"{name}.run", ("process", "python", "external")) if "run" in m else (
            "process" if kind == "vehicle" else "python")
        port, routing = "", True
        if run == "external":
            if "port" not in m:
                raise src.fail(item, f"{name}: run: external needs 'port': the member's own end of its link, e.g. "
                                     "port: \"serial:device=/dev/pts/5\" (a board's UART), "
                                     "\"tcp:listen=10.0.0.2:5001\" or \"udp:bind=127.0.0.1:6001,peer=127.0.0.1:6002\"")
            port = _external_port(src, m["port"], f"{name}.port")
            if "routing" in m:
                routing = _choice(src, m["routing"], f"{name}.routing", ("true", "false")) == "true"
        else:
            for k in ("port", "routing"):
                if k in m:
                    raise src.fail(m[k], f"{name}.{k}: only for run: external (the launcher makes the ports of "
                                         "the members it starts)")
        if "motion" in m and "position" in m:
            raise src.fail(m["position"], f"{name}: give motion or position, not both")
        if "position" in m:
            p = _mapping(src, m["position"], f"{name}.position", {"n": False, "e": False, "alt": False})
            coords = {k: _number(src, p[k], f"{name}.position.{k}") if k in p else 0.0 for k in ("n", "e", "alt")}
            motion = f"static:n={coords['n']:g},e={coords['e']:g},alt={coords['alt']:g}"
        elif "motion" in m:
            motion = _motion(src, m["motion"], f"{name}.motion")
        elif kind == "vehicle" and run != "external":
            raise src.fail(item, f"vehicle {name}: 'motion' is required (e.g. motion: \"orbit:r=150,v=12\")")
        else:
            motion = "static:n=0,e=0"   # an external member flies its own model; this one is for range only
        out.append(Station(name, kind, run, motion, _line(m["name"]), port, routing))
    return out


def _external_port(src: _Src, node: Any, what: str) -> str:
    """An external member's own port spec: serial:device=PATH, tcp:listen=|connect=H:P, udp:bind=H:P,peer=H:P.
    The launcher's end of the link is its mirror (peer_port())."""
    text = _scalar(src, node, what)
    try:
        peer_port(text)
    except ValueError as e:
        raise src.fail(node, f"{what}: {e}") from None
    return text


def peer_port(port: str, baud: int = 115200) -> str:
    """The port spec of the launcher's end facing an external member whose own port is `port`: the same serial
    device (the other side of a board's UART, e.g. QEMU's pty), TCP connect for listen and listen for connect,
    UDP with bind and peer swapped."""
    kind, _, rest = port.partition(":")
    fields = dict(kv.partition("=")[::2] for kv in rest.split(",") if kv)
    if kind == "serial" and fields.get("device"):
        return f"serial:device={fields['device']},baud={fields.get('baud', baud)}"
    if kind == "tcp" and ("listen" in fields) != ("connect" in fields):
        return f"tcp:connect={fields['listen']}" if "listen" in fields else f"tcp:listen={fields['connect']}"
    if kind == "udp" and fields.get("bind") and fields.get("peer"):
        return f"udp:bind={fields['peer']},peer={fields['bind']}"
    raise ValueError(f"'{port}' is not a port the launcher can face: give serial:device=PATH, tcp:listen=HOST:PORT, "
                     "tcp:connect=HOST:PORT or udp:bind=HOST:PORT,peer=HOST:PORT (the member's own end)")


def _two_names(src: _Src, node: Any, what: str, names: dict[str, int]) -> tuple[str, str]:
    items = _seq(src, node, what)
    if len(items) != 2:
        raise src.fail(node, f"{what}: give the two ends, e.g. [uav1, uav2]")
    a, b = (_known(src, n, what, names) for n in items)
    if a == b:
        raise src.fail(node, f"{what}: both ends are '{a}'")
    return a, b


def _known(src: _Src, node: Any, what: str, names: dict[str, int]) -> str:
    name = _scalar(src, node, what)
    if name not in names:
        raise src.fail(node, f"{what}: '{name}' is not a vehicle or ground station of this scenario "
                             f"(known: {', '.join(sorted(names))})")
    return name


def _links(src: _Src, node: Any, names: dict[str, int], radio: dict[str, float],
           stations: dict[str, Station]) -> list[LinkSpec]:
    out: list[LinkSpec] = []
    for item in _seq(src, node, "links"):
        m = _mapping(src, item, "link", {"between": False, "mesh": False, "transport": False, "model": False,
                                         "range_m": False, "loss": False, "delay_ms": False, "jitter_ms": False,
                                         "bandwidth_bps": False, "encoding": False})
        if ("between" in m) == ("mesh" in m):
            raise src.fail(item, "link: give either 'between: [a, b]' or 'mesh: [names...]' (or mesh: all)")
        values = dict(radio)
        model = _choice(src, m["model"], "link.model", MODELS) if "model" in m else "radio"
        if model == "wire":
            values["range_m"] = math.inf
        _link_model_values(src, m, "link", values)
        transport = _choice(src, m["transport"], "link.transport", TRANSPORTS) if "transport" in m else "udp"
        encoding = _choice(src, m["encoding"], "link.encoding", ("full", "compact")) if "encoding" in m else "full"
        if "between" in m:
            pairs = [_two_names(src, m["between"], "link.between", names)]
        else:
            import yaml

            if isinstance(m["mesh"], yaml.ScalarNode):
                if m["mesh"].value != "all":
                    raise src.fail(m["mesh"], "link.mesh: give a list of names, or all")
                members = list(names)
            else:
                members = [_known(src, n, "link.mesh", names) for n in _seq(src, m["mesh"], "link.mesh")]
            pairs = [(a, b) for i, a in enumerate(members) for b in members[i + 1:]]
        for a, b in pairs:
            ext = [x for x in (a, b) if stations[x].external]
            if len(ext) == 2:
                raise src.fail(item, f"link [{a}, {b}]: both ends are external; the launcher connects its own "
                                     "members to external ones, not two external members to each other")
            if ext:
                kind = stations[ext[0]].port.partition(":")[0]
                if "transport" in m and transport != kind:
                    raise src.fail(m["transport"], f"link [{a}, {b}]: {ext[0]} is external on a {kind} port "
                                                   f"('{stations[ext[0]].port}'); leave transport out or say {kind}")
                if any(ext[0] in (link.a, link.b) for link in out):
                    raise src.fail(item, f"link [{a}, {b}]: {ext[0]} is external with one port: one link to it")
                if values["bandwidth_bps"] or encoding != "full":
                    raise src.fail(item, f"link [{a}, {b}]: bandwidth_bps and encoding are not for a link to an "
                                         "external member (its own end is not the launcher's)")
                out.append(LinkSpec(a, b, kind, model, values["range_m"], values["loss"], int(values["delay_ms"]),
                                    int(values["jitter_ms"]), _line(item), 0, "full"))
                continue
            if transport == "memory" and (stations[a].run != "python" or stations[b].run != "python"):
                raise src.fail(item, f"link [{a}, {b}]: transport memory joins two run: python entities "
                                     "(one process); use udp, tcp or serial for a process")
            if transport == "memory" and (values["bandwidth_bps"] or encoding != "full"):
                raise src.fail(item, f"link [{a}, {b}]: bandwidth_bps and encoding need a udp, tcp or serial "
                                     "transport (a port's impairment and encoding); memory links have neither")
            out.append(LinkSpec(a, b, transport, model, values["range_m"], values["loss"], int(values["delay_ms"]),
                                int(values["jitter_ms"]), _line(item), int(values["bandwidth_bps"]), encoding))
    counts: dict[str, int] = {}
    for link in out:
        for end in (link.a, link.b):
            counts[end] = counts.get(end, 0) + 1
            if counts[end] > MAX_LINKS:
                raise src.fail(node, f"'{end}' has more than {MAX_LINKS} links (the paper's limit per entity); "
                                     "use fewer links or a smaller mesh")
    return out


def _flows(src: _Src, node: Any, names: dict[str, int], stations: dict[str, Station]) -> list[FlowSpec]:
    out = []
    for item in _seq(src, node, "flows"):
        m = _mapping(src, item, "flow", {"name": False, "content": True, "source": True, "destination": True,
                                         "period_ms": True, "admin": False, "kind": False})
        content = _choice(src, m["content"], "flow.content", PRODUCED)
        source = _known(src, m["source"], "flow.source", names)
        dest = _known(src, m["destination"], "flow.destination", names)
        if not stations[source].is_vehicle:
            raise src.fail(m["source"], f"flow.source: '{source}' is a ground station; simulated vehicles "
                                        f"produce {', '.join(PRODUCED)}")
        if source == dest:
            raise src.fail(item, "flow: source and destination are the same entity")
        period = int(_number(src, m["period_ms"], "flow.period_ms", 10, 60000, True))
        name = _scalar(src, m["name"], "flow.name") if "name" in m else f"{content}:{source}>{dest}"
        if any(f.name == name for f in out):
            raise src.fail(item, f"flow name '{name}' used twice; give each flow its own name")
        admin = None
        if "admin" in m:
            admin = _known(src, m["admin"], "flow.admin", names)
            st = stations[admin]
            if st.is_vehicle or st.run != "python":
                raise src.fail(m["admin"], f"flow.admin: '{admin}' must be a ground station with run: python (its "
                                           "administration table is the Python GCS API)")
        if "kind" in m and admin is None:
            raise src.fail(m["kind"], "flow.kind: only with 'admin' (the type of the administration row)")
        kind = _choice(src, m["kind"], "flow.kind", FLOW_KINDS) if "kind" in m else "subscription"
        if any(f.source == source and f.destination == dest and f.content == content for f in out):
            raise src.fail(item, f"flow: {content} from {source} to {dest} is listed twice")
        out.append(FlowSpec(name, content, source, dest, period, _line(item), admin, kind))
    return out


def _events(src: _Src, node: Any, names: dict[str, int], stations: dict[str, Station], duration: float,
            links: list[LinkSpec]) -> list[EventSpec]:
    out = []
    for item in _seq(src, node, "events"):
        m = _mapping(src, item, "event", {"t": True, "motion": False, **{k: False for k in EVENT_KINDS}})
        kinds = [k for k in EVENT_KINDS if k in m]
        if len(kinds) != 1:
            raise src.fail(item, f"event: give exactly one of {', '.join(EVENT_KINDS)} with its time t")
        kind = kinds[0]
        t = _number(src, m["t"], "event.t", 0.0, duration)
        if kind in ("fail_link", "restore_link"):
            target: tuple[str, ...] = _two_names(src, m[kind], kind, names)
            if not any(link.pair == frozenset(target) for link in links):
                raise src.fail(m[kind], f"{kind}: no link between {target[0]} and {target[1]} in 'links'")
        else:
            target = (_known(src, m[kind], kind, names),)
            st = stations[target[0]]
            if kind in ("kill", "restart") and st.external:
                raise src.fail(m[kind], f"{kind}: '{st.name}' is external (not started by the launcher): it cannot "
                                        "be killed or restarted from here; cut its link (fail_link) instead")
            if kind in ("kill", "restart") and st.run == "python" and any(
                    link.transport == "memory" and st.name in (link.a, link.b) for link in links):
                raise src.fail(m[kind], f"{kind}: '{st.name}' has a memory link (inside the launcher's process); "
                                        "a ground station that is killed and restarted needs udp, tcp or serial links")
            if kind in ("kill", "restart") and st.run == "python" and st.is_vehicle:
                raise src.fail(m[kind], f"{kind}: '{st.name}' runs in the launcher (run: python) as a vehicle; "
                                        "only processes (run: process) and ground stations can be killed and "
                                        "restarted")
            if kind in ("add", "move") and st.external:
                raise src.fail(m[kind], f"{kind}: '{st.name}' is external: it is there when the run starts and "
                                        "moves by itself")
            if kind == "add" and not st.is_vehicle:
                raise src.fail(m[kind], "add: only vehicles join during a run; start ground stations at t=0")
            if kind == "move" and st.is_vehicle:
                raise src.fail(m[kind], f"move: '{st.name}' is a vehicle, whose own process flies its motion; "
                                        "move ground stations (give vehicles waypoints instead)")
        motion = ""
        if kind == "move":
            if "motion" not in m:
                raise src.fail(item, "move: give the new motion, e.g. motion: \"waypoints:v=40,loop=0,pts=0/0;-2000/0\"")
            motion = _motion(src, m["motion"], "event.motion")
        elif "motion" in m:
            raise src.fail(m["motion"], f"event.motion: only with move (this event is {kind})")
        out.append(EventSpec(t, kind, target, _line(item), motion))
    out.sort(key=lambda e: (e.t, e.line))
    # Life cycle: restart after kill, no kill before an add, one add per vehicle.
    alive: dict[str, bool] = {n: True for n in names}
    added = set()
    for e in out:
        if e.kind == "add":
            if e.target[0] in added:
                raise src.fail(None, f"add {e.target[0]} twice (line {e.line})")
            added.add(e.target[0])
    for n in added:
        alive[n] = False
    for e in out:
        name = e.target[0]
        if e.kind == "add":
            alive[name] = True
        elif e.kind == "kill":
            if not alive[name]:
                raise ScenarioError(f"{src.source}:{e.line}: kill {name}: it is not running at t={e.t:g} "
                                    "(not started yet, or killed already)")
            alive[name] = False
        elif e.kind == "restart":
            if alive[name]:
                raise ScenarioError(f"{src.source}:{e.line}: restart {name}: it is running at t={e.t:g}; kill it "
                                    "first")
            alive[name] = True
    return out


def _check_external(src: _Src, stations: dict[str, Station], links: list[LinkSpec], flows: list[FlowSpec]) -> None:
    """An external member needs its one link; one without routing (a fixed entity table, as the firmware has)
    is reached only from the member it is linked to, whose mask toward it the launcher pins."""
    for st in stations.values():
        if not st.external:
            continue
        peers = [link.b if link.a == st.name else link.a for link in links if st.name in (link.a, link.b)]
        if not peers:
            raise ScenarioError(f"{src.source}:{st.line}: {st.name} is external but no link reaches it; add "
                                f"{{between: [SOMEONE, {st.name}]}} to links")
        if st.routing:
            continue
        for f in flows:
            if st.name in (f.source, f.destination):
                other = f.destination if f.source == st.name else f.source
                if other not in peers:
                    raise ScenarioError(f"{src.source}:{f.line}: flow {f.name}: {st.name} is external with "
                                        f"routing: false, reached only through {peers[0]} (no route is learned "
                                        f"to it); make {peers[0]} the other end, or give it routing")


def parse_scenario(text: str, source: str = "<scenario>") -> Scenario:
    import yaml

    src = _Src(source)
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        line = mark.line + 1 if mark is not None else 1
        raise ScenarioError(f"{source}:{line}: not valid YAML: {e.problem or e}") from None
    if root is None:
        raise ScenarioError(f"{source}:1: empty file; a scenario needs at least duration_s and vehicles")
    m = _mapping(src, root, "scenario", {"name": False, "duration_s": True, "seed": False, "routing": False,
                                         "datum": False, "radio": False, "ground_stations": False, "signed": False,
                                         "vehicles": True, "links": False, "flows": False, "events": False})
    duration = _number(src, m["duration_s"], "duration_s", 1.0, 3600.0)
    seed = int(_number(src, m["seed"], "seed", 0, 2**31, True)) if "seed" in m else 1
    routing = _routing(src, m["routing"]) if "routing" in m else RoutingSpec()
    datum = dict(DATUM)
    if "datum" in m:
        d = _mapping(src, m["datum"], "datum", {"lat": False, "lon": False, "alt": False})
        for k, (lo, hi) in (("lat", (-89.0, 89.0)), ("lon", (-180.0, 180.0)), ("alt", (-500.0, 10000.0))):
            if k in d:
                datum[k] = _number(src, d[k], f"datum.{k}", lo, hi)
    radio = _radio(src, m.get("radio"))
    seen: dict[str, int] = {}
    stations = (_stations(src, m["ground_stations"], "gcs", seen) if "ground_stations" in m else [])
    stations += _stations(src, m["vehicles"], "vehicle", seen)
    if not any(s.is_vehicle for s in stations):
        raise src.fail(m["vehicles"], "vehicles: list at least one vehicle")
    if datum != DATUM:
        suffix = f",lat0={datum['lat']:g},lon0={datum['lon']:g},alt0={datum['alt']:g}"
        stations = [Station(s.name, s.kind, s.run, s.motion + (suffix if ":" in s.motion else ":" + suffix[1:]),
                            s.line) for s in stations]
    by_name = {s.name: s for s in stations}
    links = _links(src, m["links"], seen, radio, by_name) if "links" in m else []
    flows = _flows(src, m["flows"], seen, by_name) if "flows" in m else []
    events = _events(src, m["events"], seen, by_name, duration, links) if "events" in m else []
    _check_external(src, by_name, links, flows)
    if datum != DATUM:
        events = [EventSpec(e.t, e.kind, e.target, e.line, e.motion + suffix) if e.motion else e for e in events]
    name = _scalar(src, m["name"], "name") if "name" in m else Path(source).stem
    signed, mode = False, "identity"
    if "signed" in m:
        text = _choice(src, m["signed"], "signed", ("true", "false", "identity", "group"))
        signed = text != "false"
        mode = "group" if text == "group" else "identity"
    return Scenario(name, source, duration, seed, routing, tuple(stations), tuple(links), tuple(flows), tuple(events),
                    datum, signed, mode)


def load_scenario(path: str | Path) -> Scenario:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ScenarioError(f"{p}: cannot read the scenario: {e.strerror}") from None
    return parse_scenario(text, str(p))
