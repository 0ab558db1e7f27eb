"""The console's model of the bus: one thread owns the uavbus.Node and everything the web pages show.

A `uavbus.Node` is not thread-safe, so the web server never touches it: it hands work to the node thread
(`Console.submit()`), which runs it between two polls of the node. Work that asks another entity over the
bus (INSPECT, through `Remote.begin()`) is a generator that yields each `RemoteCall` and is resumed when the
answer (or the refusal, or the timeout) is in, so a silent entity never holds up the others, the plots or
the fleet view.

What the thread keeps up to date by itself:
 - every frame received (the node's frame tap): who was heard when, over which link, after how many hops;
 - every delivery (DATA addressed to the console's entity): the last `history_s` per (content, source),
   for the live plots and the per-flow rate, bandwidth and jitter;
 - the fleet: each known entity's position (read over the bus from the directory the console's position
   file names for it), its link table when the entity lets this operator read it, routes when routing runs.
"""

from __future__ import annotations

import concurrent.futures
import math
import queue
import secrets
import statistics
import threading
import time
from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass, field
from typing import Any

from uavbus.errors import NoAnswerError, UbError
from uavbus.remote import RemoteCall, split_name
from uavbus.tools.common import flatten, jsonable
from uavbus.units import units_of

CONFIRM_TTL_S = 60.0   # a prepared action must be confirmed within this time
STALE_S = 4.0          # an entity not heard for this long is "stale"
LINKS_S = 2.0          # a remote entity's link table is read again after this long
QUIET_S = 5.0          # an entity that did not answer is asked again after this long
LINK_LOCAL = (9, 10, 20)  # UB_ADMIN_HELLO, UB_ADMIN_ROUTE_UPDATE, UB_ADMIN_LINK_HELLO: never forwarded


def _hop_count(hop_limit: int, default: int) -> int:
    return default - hop_limit + 1 if 0 < hop_limit <= default else 0


@dataclass
class Heard:
    """What the frame tap saw of one source."""

    last: float = 0.0          # time.monotonic() of its last frame
    frames: int = 0
    hops: int = 0              # links its last frame crossed
    link: str = ""             # the console's link it arrived on


@dataclass
class Flow:
    """The deliveries of one (content, source) to the console, kept for `history_s`."""

    content: str
    source: str
    samples: deque[tuple[float, int, Any]] = field(default_factory=deque)   # (t_s monotonic, bytes, Message)
    total: int = 0

    def trim(self, horizon: float) -> None:
        while self.samples and self.samples[0][0] < horizon:
            self.samples.popleft()

    def stats(self, now: float, window_s: float, started: float) -> dict[str, Any]:
        """Rate, bandwidth and jitter over the last `window_s`, divided by the time actually observed: from
        the first to the last message in the window (a flow younger than the window is not diluted by the
        time before it started), or up to now once the flow has gone quiet (so a stopped flow decays)."""
        since = max(now - window_s, started)
        ts = [(t, n) for t, n, _ in self.samples if t >= since]
        gaps = [b[0] - a[0] for a, b in zip(ts, ts[1:])]
        rate = bw = None
        if len(ts) >= 2:
            mean = statistics.fmean(gaps)
            if now - ts[-1][0] <= 2.0 * mean + 0.5:
                span = ts[-1][0] - ts[0][0]
                rate, bw = (len(ts) - 1) / span, sum(n for _, n in ts[1:]) / span
            else:
                span = max(now - ts[0][0], 1e-3)
                rate, bw = len(ts) / span, sum(n for _, n in ts) / span
        jitter = statistics.pstdev(gaps) * 1000.0 if len(gaps) >= 2 else None
        return {"content": self.content, "source": self.source, "messages": self.total,
                "rate_hz": round(rate, 2) if rate is not None else None,
                "bytes_per_s": round(bw, 1) if bw is not None else None,
                "jitter_ms": round(jitter, 2) if jitter is not None else None,
                "mean_gap_ms": round(statistics.fmean(gaps) * 1000.0, 2) if gaps else None,
                "last_age_s": round(now - self.samples[-1][0], 2) if self.samples else None}


@dataclass
class Pending:
    """An action prepared by the page and waiting for the operator's confirm."""

    what: str                  # the sentence shown in the confirm step
    run: Callable[[], Any]     # runs on the node thread (may return a generator of RemoteCalls)
    made: float


class Console:
    """The node thread and the state the pages read. Every public method whose name ends in `_now` runs on
    the node thread (submit() it); the rest may be called from any thread."""

    def __init__(self, node: Any, *, admin_entity: str | None = None, positions: dict[str, str] | None = None,
                 history_s: float = 30.0, fleet_period_s: float = 1.0, remote_timeout: float = 2.0,
                 poll_s: float = 0.005) -> None:
        self.node = node
        self.me = admin_entity or node.local_entities[0]
        self.positions_spec = dict(positions or {})
        self.history_s, self.fleet_period_s, self.remote_timeout, self.poll_s = \
            history_s, fleet_period_s, remote_timeout, poll_s
        self.started = time.monotonic()
        self.configured = [e.name for e in node.config.entities] if node.config is not None else []
        self.heard: dict[str, Heard] = {}
        self.neighbour: dict[str, str] = {}        # console link -> the entity heard on it one hop away
        self.flows: dict[tuple[str, str], Flow] = {}
        self.positions: dict[str, dict[str, Any]] = {}
        self.remote_links: dict[str, dict[str, Any]] = {}   # entity -> {"rows": [...]} or {"error": reason}
        self.ever_known: set[str] = set()
        self.removed: set[str] = set()
        self.pending: dict[str, Pending] = {}
        self.events: deque[dict[str, Any]] = deque(maxlen=200)  # what the operator did and how it ended
        self._jobs: queue.SimpleQueue[tuple[Callable[[], Any], concurrent.futures.Future[Any]]] = queue.SimpleQueue()
        self._tasks: list[tuple[Generator[Any, Any, Any], RemoteCall | None, concurrent.futures.Future[Any]]] = []
        self._fleet_task: Generator[Any, Any, Any] | None = None
        self._fleet_call: RemoteCall | None = None
        self._fleet_next = 0.0
        self._quiet: dict[str, float] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        from uavbus._bindings.ub_frame import DEFAULT_HOP_LIMIT, ub_frame_parse

        self._parse, self._hop_default = ub_frame_parse, DEFAULT_HOP_LIMIT
        node.on_frame(self._on_frame)
        node.on_data(self._on_data)
        self.admin = node.admin(self.me)

    # -- the node thread -----------------------------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self._loop, name="uavbus-node", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)

    def submit(self, fn: Callable[..., Any], *args: Any) -> concurrent.futures.Future[Any]:
        """Runs fn(*args) on the node thread. If it returns a generator, the generator may yield RemoteCalls
        and gets each one's result (or exception) back; the future holds what it finally returns."""
        fut: concurrent.futures.Future[Any] = concurrent.futures.Future()
        self._jobs.put((lambda: fn(*args), fut))
        return fut

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                self.node.poll(self.poll_s)
            except Exception as exc:  # noqa: BLE001 - a callback error must not end the console
                self.events.append({"t": time.time(), "what": "node", "error": f"{type(exc).__name__}: {exc}"})
            self.pump()

    def pump(self) -> None:
        """Everything the node thread does besides polling the node: the pages' jobs, the remote requests in
        flight, the fleet's refresh. Call it after each poll when the node is driven by another loop (a
        simulation that polls its nodes itself) instead of start()."""
        while True:
            try:
                fn, fut = self._jobs.get_nowait()
            except queue.Empty:
                break
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                out = fn()
            except Exception as exc:  # noqa: BLE001 - handed to the waiting request
                fut.set_exception(exc)
                continue
            if isinstance(out, Generator):
                self._tasks.append((out, None, fut))
            else:
                fut.set_result(out)
        self._step_tasks()
        self._step_fleet()

    def _step_tasks(self) -> None:
        keep = []
        for gen, call, fut in self._tasks:
            while True:
                if call is not None and not call.step():
                    keep.append((gen, call, fut))
                    break
                try:
                    if call is None:
                        call = next(gen)
                    else:
                        try:
                            value = call.result()
                        except Exception as exc:  # noqa: BLE001 - thrown into the task, which may handle it
                            call = gen.throw(exc)
                        else:
                            call = gen.send(value)
                except StopIteration as stop:
                    fut.set_result(stop.value)
                    break
                except Exception as exc:  # noqa: BLE001
                    fut.set_exception(exc)
                    break
        self._tasks = keep

    def remote(self, entity: str) -> Any:
        return self.node.remote(entity, timeout=self.remote_timeout)

    # -- what the tap and the deliveries tell ---------------------------------------------------------
    def _on_frame(self, link: str, direction: str, frame: bytes, t_ms: int) -> None:
        if direction != "rx":
            return
        try:
            h = self._parse(frame)
        except (UbError, ValueError):
            return
        src = h.src_id.rstrip(b"\0").decode("ascii", "replace")
        rec = self.heard.get(src)
        if rec is None:
            rec = self.heard[src] = Heard()
        rec.last = time.monotonic()
        rec.frames += 1
        if h.admin in LINK_LOCAL:  # hellos and route updates never travel further: the sender is the neighbour
            self.neighbour[link] = src
            if not rec.link:
                rec.link, rec.hops = link, 1
            return
        rec.link = link
        rec.hops = _hop_count(h.hop_limit, self._hop_default)
        if rec.hops == 1:
            self.neighbour[link] = src

    def _on_data(self, msg: Any) -> None:
        key = (msg.name, msg.source)
        f = self.flows.get(key)
        if f is None:
            f = self.flows[key] = Flow(*key)
        now = time.monotonic()
        f.samples.append((now, len(msg.raw), msg))
        f.total += 1
        f.trim(now - self.history_s)

    # -- fleet ---------------------------------------------------------------------------------------
    def _step_fleet(self) -> None:
        if self._fleet_task is None:
            if time.monotonic() < self._fleet_next:
                return
            self._fleet_task = self._g_fleet_round()
            self._fleet_call = None
        try:
            if self._fleet_call is not None and not self._fleet_call.step():
                return
            if self._fleet_call is None:
                self._fleet_call = next(self._fleet_task)
            else:
                try:
                    value = self._fleet_call.result()
                except Exception as exc:  # noqa: BLE001
                    self._fleet_call = self._fleet_task.throw(exc)
                else:
                    self._fleet_call = self._fleet_task.send(value)
        except StopIteration:
            self._fleet_task, self._fleet_call = None, None
            self._fleet_next = time.monotonic() + self.fleet_period_s

    def fixed_position(self, entity: str) -> dict[str, Any] | None:
        """A position the console's file gives as "@N,E" metres (a ground station that does not move)."""
        spec = self.positions_spec.get(entity) or ""
        if not spec.startswith("@"):
            return None
        try:
            n, e = (float(x) for x in spec[1:].split(","))
        except ValueError:
            return {"error": f"position {spec!r}: write @NORTH,EAST in metres"}
        return {"n": n, "e": e, "d": 0.0, "spec": spec}

    def position_of(self, entity: str) -> str | None:
        spec = self.positions_spec.get(entity, self.positions_spec.get("*"))
        return spec if spec and not spec.startswith("@") else None  # "": no position of its own; "@": fixed

    def _g_fleet_round(self) -> Generator[RemoteCall, Any, None]:
        """One pass over the remote entities: position, then (every LINKS_S) the link table. An entity that
        did not answer is asked again only after QUIET_S, so a silent one costs little; its state shows."""
        names = [e["name"] for e in self.node.entities() if not e["local"]]
        for name in names:
            if name in self.removed or time.monotonic() < self._quiet.get(name, 0.0):
                continue
            spec = self.position_of(name)
            if spec:
                try:
                    value = yield self.remote(name).begin("get", spec)
                    self.positions[name] = _position(value, spec)
                except NoAnswerError:
                    self._quiet[name] = time.monotonic() + QUIET_S
                    continue
                except UbError as exc:
                    self.positions[name] = {"error": _reason(exc), "spec": spec}
                except (KeyError, TypeError, ValueError) as exc:
                    self.positions[name] = {"error": str(exc), "spec": spec}
            links = self.remote_links.get(name)
            if links is None or time.monotonic() - links.get("t", 0.0) > LINKS_S:
                try:
                    rows = yield self.remote(name).begin("table", "links")
                    self.remote_links[name] = {"rows": rows, "t": time.monotonic()}
                except NoAnswerError:
                    self._quiet[name] = time.monotonic() + QUIET_S
                except UbError as exc:
                    self.remote_links[name] = {"error": _reason(exc), "t": time.monotonic()}

    def fleet_now(self) -> dict[str, Any]:
        """Every entity the node knows (configured, learned, heard, removed) with state, position, links,
        routes; and the console's own links with their neighbour and counters."""
        now = time.monotonic()
        table = {e["name"]: e for e in self.node.entities()}
        self.removed -= set(table)
        self.removed |= self.ever_known - set(table)
        self.ever_known |= set(table)
        routes: dict[str, Any] = {}
        route_links: dict[str, Any] = {}
        if self.node.routing:
            try:
                routes = self.node.routing.table(self.me)
                route_links = self.node.routing.links()
            except UbError:
                pass
        link_counters = self.node.link_counters()
        own_links = []
        for name, c in link_counters.items():
            rl = route_links.get(name, {})
            own_links.append({"link": name, "neighbour": rl.get("neighbour") or self.neighbour.get(name),
                              "frames_in": c.get("frames_in", 0), "frames_out": c.get("frames_out", 0),
                              "bytes_in": c.get("bytes_in", 0), "bytes_out": c.get("bytes_out", 0),
                              "cost": rl.get("cost"), "port": (c.get("port") or {}).get("spec")})
        names = list(dict.fromkeys([*self.configured, *table, *sorted(self.heard), *sorted(self.removed)]))
        out = []
        for name in names:
            e = table.get(name)
            heard = self.heard.get(name)
            local = bool(e and e["local"])
            if name in self.removed and e is None:
                state = "revoked"
            elif local:
                state = "alive"
            elif heard is not None and now - heard.last <= STALE_S:
                state = "alive"
            elif (routes.get(name) or {}).get("reachable"):
                state = "alive"  # its routing updates arrive (the engine declares a silent one dead)
            else:
                state = "stale"
            r = routes.get(name) or {}
            via = None
            if heard is not None and heard.hops > 1:
                via = self.neighbour.get(heard.link)
            if r.get("reachable") and r.get("next_hop") and r.get("next_hop") != name:
                via = r.get("next_hop")
            item: dict[str, Any] = {
                "name": name, "state": state, "local": local,
                "origin": "configured" if name in self.configured else
                          "learned" if e is not None or name in self.removed else "heard",
                "in_table": e is not None, "hops": 0 if local else (heard.hops if heard else None),
                "last_heard_s": round(now - heard.last, 2) if heard else None,
                "frames": heard.frames if heard else 0, "link": heard.link if heard else None, "via": via,
                "route": {k: r.get(k) for k in ("reachable", "next_hop", "link", "metric", "learned")} if r else None,
                "position": self.fixed_position(name) or self.positions.get(name),
                "position_spec": self.positions_spec.get(name, self.positions_spec.get("*")),
            }
            if local:
                item["links"] = own_links
                item["position"] = item["position"] or {"n": 0.0, "e": 0.0, "d": 0.0, "origin": True}
            elif name in self.remote_links:
                item["links"] = self.remote_links[name].get("rows")
                item["links_error"] = self.remote_links[name].get("error")
            out.append(item)
        return {"me": self.me, "routing": self.node.routing.enabled, "entities": out, "t": time.time()}

    # -- administration table -------------------------------------------------------------------------
    def admin_now(self) -> dict[str, Any]:
        rows = []
        for r in self.admin.rows():
            rows.append({"row": r.get("row"), "content": r["content"], "source": r.get("source"),
                         "destination": r.get("destination"), "period_ms": r.get("period_ms"),
                         "type": r.get("kind"), "status": r.get("status"), "active": r.get("active"),
                         "reason": r.get("nack_reason"), "relayed": r.get("nack_relayed"),
                         "attempts": r.get("attempts")})
        policy = _policy_of(self.node)
        return {"me": self.me, "rows": rows, "administrators": policy,
                "certified_roles": _certified_roles(self.node, self.me)}

    # -- flows and plots -----------------------------------------------------------------------------
    def flows_now(self, window_s: float = 5.0) -> list[dict[str, Any]]:
        now = time.monotonic()
        out = []
        for f in sorted(self.flows.values(), key=lambda f: (f.content, f.source)):
            f.trim(now - self.history_s)
            s = f.stats(now, window_s, self.started)
            if f.samples:
                s["fields"] = numeric_fields(f.samples[-1][2].value)
            out.append(s)
        return out

    def series_now(self, keys: list[tuple[str, str, str]], since: float) -> dict[str, Any]:
        """Points (t, value) of each (content, source, field) received after `since` (unix seconds)."""
        offset = time.time() - time.monotonic()
        out: dict[str, Any] = {}
        for content, source, fld in keys:
            f = self.flows.get((content, source))
            pts: list[tuple[float, float]] = []
            if f is not None:
                for t, _, msg in f.samples:
                    tu = t + offset
                    if tu <= since:
                        continue
                    v = _field(msg.value, fld)
                    if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)):
                        pts.append((round(tu, 4), float(v)))
            out[f"{content}@{source}:{fld}"] = pts
        return {"series": out, "t": time.time()}

    # -- confirm step --------------------------------------------------------------------------------
    def prepare(self, what: str, run: Callable[[], Any]) -> dict[str, Any]:
        now = time.monotonic()
        for k in [k for k, p in self.pending.items() if now - p.made > CONFIRM_TTL_S]:
            del self.pending[k]
        cid = secrets.token_urlsafe(12)
        self.pending[cid] = Pending(what, run, now)
        return {"confirm": cid, "what": what}

    def take(self, cid: str) -> Pending | None:
        p = self.pending.pop(cid, None)
        if p is None or time.monotonic() - p.made > CONFIRM_TTL_S:
            return None
        return p


def _reason(exc: UbError) -> str:
    reason = getattr(exc, "reason", None)
    return str(reason) if reason else exc.detail if hasattr(exc, "detail") else str(exc)


def _field(value: Any, path: str) -> Any:
    cur = value
    for part in path.replace("]", "").replace("[", ".").split("."):
        if part == "":
            continue
        try:
            cur = cur[int(part)] if isinstance(cur, list) else cur[part]
        except (KeyError, IndexError, ValueError, TypeError):
            return None
    return cur


def numeric_fields(value: Any) -> list[str]:
    """Paths of the numeric leaves of a decoded value (what a plot can show)."""
    return [p for p, v in flatten(value) if isinstance(v, (int, float)) and not isinstance(v, bool)]


def _position(value: Any, spec: str) -> dict[str, Any]:
    """A local-frame position from a directory value: a vector with x/y/z (north, east, down) or a
    latitude/longitude pair (shown relative to the first fix, flat-earth)."""
    if isinstance(value, dict) and {"x", "y"} <= set(value):
        return {"n": float(value["x"]), "e": float(value["y"]), "d": float(value.get("z", 0.0)), "spec": spec}
    if isinstance(value, dict):
        lat = next((value[k] for k in ("latitudeDeg", "latitude", "lat") if k in value), None)
        lon = next((value[k] for k in ("longitudeDeg", "longitude", "lon") if k in value), None)
        if lat is not None and lon is not None:
            return {"lat": float(lat), "lon": float(lon), "alt": float(value.get("altitudeMsl", 0.0)), "spec": spec}
        for k in ("positionNed", "position"):
            if k in value:
                return _position(value[k], spec)
    raise ValueError(f"{spec}: not a position (give a vector with x, y, z or a latitude/longitude directory)")


def _policy_of(node: Any) -> list[str] | None:
    """The configuration's administrators, when its security section names them (None: everyone may)."""
    cfg = node.config
    path = getattr(cfg, "path", None)
    if not path:
        return None
    try:
        import json

        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError):
        return None
    sec = doc.get("security") if isinstance(doc, dict) else None
    admins = sec.get("administrators") if isinstance(sec, dict) else None
    return list(admins) if isinstance(admins, list) else None


def _certified_roles(node: Any, me: str) -> list[str] | None:
    """The roles `me`'s certificate gives it, when the node has identities (then targets decide who
    administers on the requester's certificate, a name list only narrowing it); None without identities."""
    ident = getattr(node, "identity", None)
    if ident is None:
        return None
    from uavbus._bindings import ub_ident

    try:
        bits = ident.store.roles(ub_ident.entity_id(me), int(time.time()))
    except UbError:  # no valid certificate of its own (expired, revoked): no role at all
        return []
    return [name for name, bit in ub_ident.ROLES.items() if bits & bit]


def describe_fields(catalogue: Any, name: str, value: Any) -> list[dict[str, Any]]:
    """Rows of the variable browser for directory `name`: field path, value, unit, description."""
    inst, path = split_name(catalogue, name)
    units = units_of(catalogue, inst.type)
    rows = []
    for p, v in flatten(value):
        full = f"{name}.{p}" if p else name
        u = units.get(_strip_indices(".".join(str(x) for x in path) + ("." if path and p else "") + p), {})
        rows.append({"field": full, "value": jsonable(v), "unit": u.get("unit"), "doc": u.get("doc"),
                     "numeric": isinstance(v, (int, float)) and not isinstance(v, bool)})
    return rows


def _strip_indices(path: str) -> str:
    import re

    return re.sub(r"\[\d+\]", "", path)
