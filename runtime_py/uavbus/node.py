"""Node: a Python process's router. All routing, framing, duplicate suppression, publish/subscribe
and admin tables run in the C runtime (uavbus._ub); Python hosts directories as wire images,
drives the loop (poll/select on the ports' descriptors, then service + tick) and reads counters.

    cat = Catalogue.load("flightsw.catalogue.json")
    node = Node(cat, config="examples/configs/table2.json", node="gcs")
    node.open_ports_from_config()
    node.subscribe("gcs1", "imuOut", source="fcs20", period_ms=20)
    for msg in node.messages(timeout=1.0):
        print(msg.name, msg.source, msg.value)
"""

from __future__ import annotations

import logging
import select
import struct
import sys
import time
from collections import deque
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Sequence

from uavbus._bindings import (ub_admin, ub_frag, ub_frame, ub_ident, ub_inspect, ub_link, ub_log, ub_member, ub_memlink,
                              ub_node, ub_nodecfg, ub_origin, ub_ports, ub_pubsub, ub_route, ub_rxring, ub_sec)
from uavbus._bindings.ub_error import ConfigError, InvalidArgumentError, NotFoundError, UbError
from uavbus.catalogue import Catalogue, CatalogueError, Instance, read_member, refused
from uavbus.config import Config, load_config
from uavbus.directory import Directory
from uavbus.enums import catalogue_enums

if TYPE_CHECKING:
    from uavbus.remote import Remote

Clock = Callable[[], float]
log = logging.getLogger("uavbus")
INBOX_MAX = 10000  # messages kept for messages() when no on_data callback consumes them
# Record memory of a node's delivery ring (ub_rxring.h): deliveries beyond it in one C call take the
# per-delivery callback instead (counted as "spilled" in counters()["python"]["ring"]), never lost.
RING_BYTES = 1 << 20
RING_MAX_RECORDS = 4096
# Deliveries held in Python after a full ring spilled them, until the next drain (dispatch or receive()).
# A node run with dispatch=False whose owner never calls receive() would otherwise grow without bound;
# beyond this they are dropped, counted in counters()["python"]["ring"]["spill_dropped"].
SPILL_MAX = 65536


def monotonic_ms() -> float:
    """CLOCK_MONOTONIC in ms: the clock of the C node program, so latencies compare on one machine."""
    return time.monotonic() * 1000.0


class Message:
    """One DATA delivery: the router already unpacked it into the bound directory; `raw` is a copy
    of that image at delivery time. Names and `value` (the decoded dict) are computed on first use:
    a receiver that only counts or forwards pays for none of them."""

    __slots__ = ("instance", "entity", "seq", "t_ms", "raw", "catalogue", "hop_limit", "_src", "_dest", "_value")

    def __init__(self, instance: Instance, entity: str, src_id: bytes, dest_id: bytes, seq: int, t_ms: int,
                 raw: bytes, catalogue: Catalogue, hop_limit: int = 0) -> None:
        self.instance, self.entity, self.seq, self.t_ms, self.raw = instance, entity, seq, t_ms, raw
        self.catalogue, self._src, self._dest, self.hop_limit = catalogue, src_id, dest_id, hop_limit
        self._value: dict[str, Any] | None = None

    @property
    def hops(self) -> int:
        """Links the frame crossed, from its hop limit on arrival (senders write UB_DEFAULT_HOP_LIMIT)."""
        top = ub_frame.DEFAULT_HOP_LIMIT
        return top - self.hop_limit + 1 if 0 < self.hop_limit <= top else 0

    @property
    def name(self) -> str:
        """The content (instance) name, e.g. "gpsOut"."""
        return self.instance.name

    @property
    def source(self) -> str:
        """The entity that sent it."""
        return ub_node.entity_name(self._src)

    @property
    def dest(self) -> str:
        """The entity it was addressed to."""
        return ub_node.entity_name(self._dest)

    @property
    def value(self) -> dict[str, Any]:
        """The delivered value as a nested dict (decoded from `raw` on first use; enum members as IntEnum)."""
        if self._value is None:
            t = self.instance.type
            self._value = catalogue_enums(self.catalogue).apply(t, self.catalogue.decode(t, self.raw))
        return self._value

    def __repr__(self) -> str:
        return f"<Message {self.name} {self.source}->{self.dest} seq={self.seq} t_ms={self.t_ms}>"


class _Sink:
    """What the C hooks call (through ffi handles); only queues, so no Python error escapes into C."""

    def __init__(self, node: "Node") -> None:
        self.node = node
        self.pending: list[tuple[int, int, bytes, bytes, int, int, bytes, int]] = []
        self.frames: list[tuple[int, int, bytes, int]] = []
        self.spill_dropped = 0

    def on_deliver(self, entity: int, instance: int, src_id: bytes, dest_id: bytes, seq: int, now_ms: int,
                   hop_limit: int = 0) -> None:
        if len(self.pending) >= SPILL_MAX:
            self.spill_dropped += 1
            return
        # Copy the image now: a later delivery in the same C call overwrites the bound storage.
        d = self.node._dirs.get(instance)  # a top-level Directory's buffer is exactly the wire image
        self.pending.append((entity, instance, src_id, dest_id, seq, now_ms, d._buf[:] if d is not None else b"",
                             hop_limit))

    def on_tap(self, link_id: int, direction: int, frame: bytes, now_ms: int) -> None:
        # Installed only while Python frame callbacks exist (Node.on_frame). The node has one tap, so
        # a running recording is fed from here too, by the same C writer.
        log = self.node._log
        if log is not None:
            ub_log.ub_log_write(log, link_id, direction, frame, now_ms)  # never raises: counted in its stats
        if len(self.frames) < INBOX_MAX:
            self.frames.append((link_id, direction, frame, now_ms))
        else:
            self.node._frames_dropped += 1


class Node:
    """One router (ub_node_t) with its ports, bindings and tables. Not thread-safe: use it from the
    thread that polls it. The engines around the core are sub-objects, as in C they are services of the
    node: `routing` (Routing), `wire` (compact links, MTUs, fragments), `security`, `inspect` (the INSPECT
    requester), and `admin(entity)` / `membership()`, created on first use."""

    def __init__(self, catalogue: Catalogue | str | Path, config: str | Path | Config | None = None,
                 node: str | None = None,
                 clock: Clock | None = None, *, hop_limit: int = 0, first_seq: int | None = None,
                 timing: dict[str, int] | None = None, random_seed: int | None = None,
                 ring_records: int | None = None) -> None:
        """`catalogue`: a Catalogue or the path of a `.catalogue.json`. `config` (a path or a Config from
        load_config) is applied through the C loader, hosting the entities of `node` (from its "nodes")
        or of its "hosts"; a refused file raises ConfigError. `clock()` returns ms (default
        CLOCK_MONOTONIC; an injected clock makes the node never sleep, for tests and simulations).
        `first_seq`: the first sequence number this node sends (default: the wall clock in microseconds,
        ub_node_seq_seed(), so a restarted process is not taken for duplicates of the one before);
        `hop_limit`, `timing` (ub_pubsub timing, ms) and `random_seed` (seeded request ids, tests only) as in
        ub_node.h.
        `ring_records`: capacity of the delivery ring (default: ~1 MiB of records, 64 to 4096)."""
        self.catalogue = catalogue if isinstance(catalogue, Catalogue) else Catalogue.load(catalogue)
        enums = catalogue_enums(self.catalogue)
        self._enums = enums if enums else None  # enum members read as IntEnum (catalogues that record them)
        self.name = node or "python"
        self._clock: Clock = clock or monotonic_ms
        self._real_clock = clock is None
        try:
            c_catalogue = self.catalogue.c_catalogue
        except (TypeError, ValueError, AttributeError, OverflowError, KeyError) as exc:
            raise CatalogueError(f"{self.catalogue.origin}: the C router cannot use this catalogue "
                                 f"({type(exc).__name__}: {exc}); regenerate it with `uavbus gen`") from None
        first_transfer = first_seq
        if first_seq is None:
            # From the wall clock in microseconds, not 1, as uavbus_node does: receivers keep a 64-frame
            # duplicate window per source, and a restarted GCS (or the next tool hosting the same entity) whose
            # numbers landed inside the previous one's window would have its first frames dropped as
            # duplicates. Milliseconds were not enough: `uavbus list` sends ~755 requests in well under 755 ms.
            now_ns = time.time_ns()
            first_seq = ub_node.ub_node_seq_seed(now_ns // 1000)
            first_transfer = (now_ns // 1_000_000) & 0xFFFF  # fragment transfers: +1 each, ms clock as before
        # Request ids come from the OS (ub_random_os); random_seed: the seeded, guessable ids of tests.
        self._c = ub_node.ub_node_new(c_catalogue, hop_limit, first_seq, timing, random_seed)
        self.wire = Wire(self, first_transfer)  # compact links, MTUs, fragments
        self._sink = _Sink(self)
        self._handle = ub_node.new_handle(self._sink)
        # Deliveries go to a C-side ring drained once per turn (one cffi call, no callback per frame); a
        # full ring spills to the sink's per-delivery callback, counted, keeping the order (ub_rxring.h).
        image_cap = max((i.type.packed_size for i in self.catalogue.instances), default=0)
        stride = ub_rxring.HEADER + (image_cap + 7) // 8 * 8
        self._ring = ub_rxring.Ring(ring_records or max(64, min(RING_MAX_RECORDS, RING_BYTES // stride)), image_cap)
        ub_rxring.ub_rxring_attach(self._ring, self._c, self._handle)
        self._records = struct.Struct(ub_rxring.RECORD_HEADER.format + f"{self._ring.stride - ub_rxring.HEADER}s")
        self._held: list[tuple[int, int, bytes, bytes, int, int, bytes, int]] = []  # after a callback raised
        self._columns: dict[tuple[int, str], Any] = {}
        self._refusable = any(i.type.refusable for i in self.catalogue.instances)
        self._dirs: dict[int, Directory] = {}
        self._callbacks: list[Callable[[Message], Any]] = []
        self._frame_callbacks: list[Callable[[str, str, bytes, int], Any]] = []
        self._frames_dropped = 0
        self._local_names: dict[int, str] = {}  # entity-table index -> name (the table only grows)
        self._dest_ids: dict[str, Any] = {}     # entity name -> its 12-byte ID as C memory, for send()
        self._inbox: deque[Message] = deque()
        self._inbox_dropped = 0
        self._callback_errors = 0
        self._refused_payloads = 0
        self._memlinks: list[MemLink] = []
        self._service_hooks: list[Callable[[int], Any]] = []  # on_service(): adapters writing to devices
        self._kept: list[Any] = []  # Python transports (uavbus.pylink) C holds pointers to
        self._admins: dict[str, Admin] = {}
        self.routing = Routing(self)
        self._membership: Membership | None = None
        self.inspect = Inspection(self)
        self._ports: Any = None
        # An open port batches (udp batch=1): what a send queued leaves at the end of that send() or
        # send_many() (one flush, so a burst from send_many shares datagrams and a lone frame waits for nothing).
        self._batching = False
        self._foreign_handlers: dict[str, Any] = {}  # link -> cffi handle of its foreign-traffic handler
        self._pollfds = ub_ports.pollfd_array()
        self._log: Any = None
        self._closed = False
        self.notices: list[str] = []  # one-time notices of the ports (also logged to the "uavbus" logger)
        self.config: Config | None = None
        self.security = Security(self)
        #: the node's identity (store, revocation service) when its config names an authority, else None
        self.identity: ub_ident.NodeIdentity | None = None
        if config is not None:
            cfg = config if isinstance(config, Config) else load_config(config)
            if node is not None:
                cfg = cfg.select_node(node)
            try:
                ub_nodecfg.ub_nodecfg_apply(cfg.c_config, self._c)
                # contents' priority classes on slow links (the "priorities" section; docs/pubsub.md)
                classes = ub_nodecfg.ub_nodecfg_apply_priorities(cfg.c_config, self._c, c_catalogue)
                if classes is not None:
                    self.wire._classes = classes  # the C node keeps a pointer: keep the table alive
                # keys, counter file and frame policy of the "security" section (C: ub_nodecfg_apply_security)
                applied = ub_nodecfg.ub_nodecfg_apply_security(cfg.c_config, self._c)
            except UbError as exc:
                raise ConfigError(exc.detail, cfg.path) from None
            if applied is not None:
                self.security._attach(*applied)
            # identity per entity: store, authorization by certified role, revocation service (issue 23)
            if ub_ident.cfg_has_identity(cfg.c_config):
                try:
                    self.identity = ub_ident.NodeIdentity(cfg.c_config, self._c, int(time.time()))
                except UbError as exc:
                    raise ConfigError(exc.detail, cfg.path) from None
                # ... and origin authentication from the same store, required on every frame to a local entity
                if applied is None:
                    raise ConfigError("field 'security.identity': identities need the fleet's group key too "
                                      "(security.keys): origin tags ride on signed frames", cfg.path)
                self.security._origin_from_identity(self.identity)
            self.config = cfg

    # -- time ----------------------------------------------------------------------------------
    def now(self) -> int:
        """The node's clock in ms (the injected clock, or CLOCK_MONOTONIC)."""
        return int(self._clock())

    # -- tables --------------------------------------------------------------------------------
    def add_entity(self, name: str, local: bool = False) -> int:
        """Adds an entity by hand (tests, tools); a config file does this through ub_nodecfg_apply."""
        return ub_node.ub_node_add_entity_name(self._c, name, local)

    def add_link(self, entity: str, index: int, name: str) -> int:
        """Creates link[`index`] of local `entity`, named `name` (detached); returns its link id."""
        return ub_node.ub_node_add_link(self._c, self.entity_index(entity), index, name)

    def set_mask(self, entity: str, dest: str, mask: int | str) -> None:
        """Link mask of local `entity` toward `dest`: an int (bit i = link[i]) or the paper's "0x00000110"."""
        if isinstance(mask, str):
            mask = ub_link.ub_link_mask_parse(mask)
        ub_node.ub_node_set_mask(self._c, self.entity_index(entity), self.entity_index(dest), mask)

    def remove_entity(self, name: str) -> None:
        """Removes remote entity `name` at run time, with every mask, duplicate window and routing state that
        named it; publish/subscribe and administration rows naming it are stopped (counted: counters())."""
        ub_node.ub_node_remove_entity(self._c, self.entity_index(name), self.now())
        self._dest_ids.pop(name, None)

    def remove_link(self, name: str) -> None:
        """Removes link slot `name` at run time: its port or memlink is closed first, its bit leaves every
        mask, the routing engine forgets its neighbour."""
        link_id = self.link_id(name)
        if self._ports is not None and ub_ports.ub_ports_describe(self._ports, name) is not None:
            ub_ports.ub_ports_close(self._ports, name)
        for m in list(self._memlinks):
            if m._ends_at(self, link_id):
                m.disconnect()
        ub_node.ub_node_remove_link(self._c, link_id)
        self.wire._forget(link_id)

    def mask(self, entity: str, dest: str) -> int:
        """Local `entity`'s current mask toward `dest` (bit i = link[i]), set by hand or by routing."""
        return ub_node.ub_node_get_mask(self._c, self.entity_index(entity), self.entity_index(dest))

    def mask_pinned(self, entity: str, dest: str) -> bool:
        """True when the mask was set by hand (set_mask() with a non-zero mask): routing leaves it alone."""
        return ub_node.ub_node_mask_pinned(self._c, self.entity_index(entity), self.entity_index(dest))

    def entity_index(self, name: str) -> int:
        """The entity-table index of `name` (NotFoundError if unknown)."""
        return ub_node.ub_node_find_entity(self._c, name)

    def link_id(self, name: str) -> int:
        """The link id of link `name` (NotFoundError if unknown)."""
        return ub_node.ub_node_find_link(self._c, name)

    def entities(self) -> list[dict[str, Any]]:
        """The entity table: index, name, local, and links (link[i] names) of local entities."""
        return ub_node.ub_node_entities(self._c)

    @property
    def local_entities(self) -> list[str]:
        """Names of the entities this node hosts."""
        return [e["name"] for e in self.entities() if e["local"]]

    # -- directories ---------------------------------------------------------------------------
    def bind(self, content: str) -> Directory:
        """Hosts instance `content`: binds a zeroed wire image to it (idempotent) and returns it."""
        inst = self.catalogue.instance(content)
        d = self._dirs.get(inst.index)
        if d is None:
            storage = ub_node.storage_new(inst.type.packed_size)
            ub_node.ub_node_bind(self._c, inst.index, storage)
            d = Directory(inst.type, storage, 0, inst, self._enums)
            self._dirs[inst.index] = d
        return d

    def directory(self, content: str) -> Directory | None:
        """The bound Directory of `content`, or None if it is not bound."""
        return self._dirs.get(self.catalogue.instance(content).index)

    # -- publish / subscribe -------------------------------------------------------------------
    def publish(self, entity: str, content: str, to: str, period_ms: int) -> int:
        """Local publication (no lease): `entity` sends `content` to `to` every period (binds it)."""
        inst = self.catalogue.instance(content)
        self.bind(content)
        return ub_pubsub.ub_pubsub_publish(self._c, self.entity_index(entity), inst.index, to, period_ms, self.now())

    def subscribe(self, entity: str, content: str, source: str, period_ms: int) -> int:
        """Local subscription: `entity` requests `content` from `source` (binds it here to receive)."""
        inst = self.catalogue.instance(content)
        self.bind(content)
        return ub_pubsub.ub_pubsub_subscribe(self._c, self.entity_index(entity), inst.index, source, period_ms,
                                             self.now())

    def stop(self, entity: str, row: int) -> None:
        """Stops row `row` of local `entity`'s publish/subscribe table (sends the STOP)."""
        ub_pubsub.ub_pubsub_stop(self._c, self.entity_index(entity), row, self.now())

    def send(self, entity: str, content: str, to: str) -> int:
        """One DATA frame now (binds `content` if needed). Returns the links that accepted it."""
        inst = self.catalogue.instance(content)
        self.bind(content)
        n = ub_node.ub_node_send_data(self._c, self.entity_index(entity), inst.index, to, self.now())
        if self._batching:
            ub_ports.ub_ports_flush(self._ports)
        self._dispatch()  # a local destination is delivered synchronously
        return n

    def publisher(self, entity: str, content: str, to: str) -> "Publisher":
        """A pre-resolved sender of `content` from local `entity` to `to`: set its `directory`, then
        `send()` (one C call). For high rates; Node.send() resolves the names on every call."""
        inst = self.catalogue.instance(content)
        directory = self.bind(content)
        dest = self._dest_ids.get(to)
        if dest is None:
            dest = self._dest_ids[to] = ub_node.entity_id_c(to)
        try:
            local = ub_node.ub_node_entity_is_local(self._c, self.entity_index(to))
        except NotFoundError:
            local = False  # unknown destination: send() reports it (UB_ERR_NOROUTE, counted no_route)
        return Publisher(self, directory, self.entity_index(entity), inst.index, dest, local)

    def pubsub_rows(self, entity: str) -> list[dict[str, Any]]:
        """The publish/subscribe table of local `entity` (paper Figure 4), one dict per row."""
        rows = []
        for k, r in ub_pubsub.ub_pubsub_rows(self._c, self.entity_index(entity)):
            r["row"] = k
            r["content"] = self.catalogue.instances[r["instance"]].name
            rows.append(r)
        return rows

    # -- automatic routes and membership -------------------------------------------------------------
    def enable_routing(self, parallel: str = "all", learn: bool = True, certified: bool = False,
                       **options: int) -> None:
        """Same as `node.routing.enable()` (kept for callers of the flat API)."""
        self.routing.enable(parallel, learn, certified, **options)

    def route_links(self) -> dict[str, dict[str, Any]]:
        """Same as `node.routing.links()` (kept for callers of the flat API)."""
        return self.routing.links()

    def membership(self, entity: str | None = None, **options: int) -> "Membership":
        """The membership requester (one per node), sending from local `entity` (default: the first local
        one). Options: retry_ms (default 200), max_retries (default 0: until answered)."""
        if self._membership is None:
            self._membership = Membership(self, entity or self.local_entities[0], options)
        return self._membership

    def remote(self, entity: str, timeout: float = 3.0) -> "Remote":
        """Same as `node.inspect.remote()`: the variable browser on entity `entity`, anywhere on the bus."""
        return self.inspect.remote(entity, timeout)

    def _inspector(self, **options: int) -> Any:
        # The C requester (bench/inspect_bench.py reads its counters); node.inspect owns it.
        return self.inspect._requester(**options)

    def admin(self, entity: str, **options: int) -> "Admin":
        """The global administration table hosted by local `entity` (created on first use;
        options: retry_ms, renew_ms, lease_ms, max_retries, max_stop_retries)."""
        adm = self._admins.get(entity)
        if adm is None:
            adm = Admin(self, entity, options)
            self._admins[entity] = adm
        return adm

    # -- receiving -----------------------------------------------------------------------------
    def on_data(self, callback: Callable[[Message], Any]) -> None:
        """Calls `callback(msg)` for every delivery, from poll() (never from inside C). While any
        callback is registered, messages() sees nothing (callbacks consume the deliveries)."""
        self._callbacks.append(callback)

    def on_frame(self, callback: Callable[[str, str, bytes, int], Any]) -> None:
        """Calls `callback(link_name, "rx" | "tx", frame, t_ms)` for every verified frame received
        on a link and every frame a transport accepted (the node's frame tap), from poll(). For
        monitors (spy, hz); a running record() keeps recording."""
        self._frame_callbacks.append(callback)
        ub_node.set_tap_sink(self._c, self._handle)

    def _dispatch_frames(self) -> None:
        frames, self._sink.frames = self._sink.frames, []
        names: dict[int, str] = {}
        for link_id, direction, frame, t_ms in frames:
            name = names.get(link_id)
            if name is None:
                name = names[link_id] = ub_node.link_name(self._c, link_id)
            for cb in list(self._frame_callbacks):
                cb(name, "tx" if direction else "rx", frame, t_ms)

    def _drain(self) -> list[tuple[int, int, bytes, bytes, int, int, bytes, int]]:
        """Every delivery not yet dispatched, oldest first: held back by a raising callback, then the ring's
        records (one C call), then those that found the ring full (the sink's callback), in that order."""
        ring = self._ring
        n = ub_rxring.ub_rxring_drain(ring) if ub_rxring.ub_rxring_pending(ring) else 0
        out = self._held
        if out:
            self._held = []
        if n:
            view = memoryview(ring.out_buf)[:n * ring.stride]
            out = out + [(e, i, s, d, q, t, img[:ln], h)
                         for t, i, q, e, ln, h, s, d, img in self._records.iter_unpack(view)]
        if self._sink.pending:
            out = out + self._sink.pending
            self._sink.pending = []
        return out

    def receive(self) -> "Deliveries":
        """Everything delivered since the last turn as one batch, without a Message per delivery: one C call
        drains the delivery ring. For high rates: use `service(dispatch=False)` or `poll(dispatch=False)` to
        run the node, then `receive()`; `Deliveries.column()` reads one field of every delivery, iterating
        gives Message objects (built on demand). on_data callbacks and messages() do not see these."""
        if self._refusable:
            # A catalogue with bools or narrow bitfields: each image is checked as _dispatch() does (what a
            # C node's unpack refuses is dropped and counted), so the batch is built from checked tuples.
            kept = []
            for rec in self._drain():
                if refused(self.catalogue.instances[rec[1]].type, rec[6]) is not None:
                    self._refused_payloads += 1
                else:
                    kept.append(rec)
            return Deliveries(self, b"", 0, kept)
        ring = self._ring
        n = ub_rxring.ub_rxring_drain(ring) if ub_rxring.ub_rxring_pending(ring) else 0
        extra = self._held + self._sink.pending if (self._held or self._sink.pending) else None
        self._held, self._sink.pending = [], []
        return Deliveries(self, ring.out_buf[:n * ring.stride] if n else b"", n, extra)

    def _dispatch(self) -> int:
        if self._sink.frames:
            self._dispatch_frames()
        pending = self._drain()
        instances, names, refusable = self.catalogue.instances, self._local_names, self._refusable
        for k, (entity, instance, src_id, dest_id, seq, now_ms, raw, hop_limit) in enumerate(pending):
            if refusable and refused(instances[instance].type, raw) is not None:
                # What a C node's generated unpack refuses (UB_ERR_RANGE, counted as bad_payload); this
                # node's wire-image storage took it as is, so the delivery is dropped and counted here.
                self._refused_payloads += 1
                continue
            local = names.get(entity)
            if local is None:
                local = names[entity] = _entity_at(self, entity)
            msg = Message(instances[instance], local, src_id, dest_id, seq, now_ms, raw, self.catalogue, hop_limit)
            if self._callbacks:
                for cb in list(self._callbacks):
                    try:
                        cb(msg)
                    except Exception:
                        # The caller sees the error; the deliveries after this one wait for the next turn.
                        self._callback_errors += 1
                        self._held[:0] = pending[k + 1:]
                        raise
            else:
                if len(self._inbox) >= INBOX_MAX:
                    self._inbox.popleft()
                    self._inbox_dropped += 1
                self._inbox.append(msg)
        return len(pending)

    # -- the loop ------------------------------------------------------------------------------
    def fds(self) -> list[tuple[int, int]]:
        """(fd, poll events) to wait on (select.POLLIN/POLLOUT bits), for selectors or asyncio."""
        if self._ports is None:
            return []
        return ub_ports.ub_ports_pollfds(self._ports, self._pollfds)

    def poll(self, timeout: float = 0.05, dispatch: bool = True) -> int:
        """One loop turn: waits up to `timeout` s for a descriptor (never sleeps with an injected
        clock and no descriptors), services ports and memlinks, ticks the tables, dispatches
        deliveries (with `dispatch=False` they wait for receive()). Returns the number of messages
        delivered (0 with dispatch=False)."""
        self._check_open()
        wait_ms = max(0, int(timeout * 1000))
        now = self.now()
        if self._ports is not None:
            wait_ms = ub_ports.ub_ports_poll_timeout(self._ports, now, wait_ms)
        if any(ub_memlink.ub_memlink_pending(m._c) for m in self._memlinks):
            wait_ms = min(wait_ms, 1)
        fds = self.fds()
        if fds and wait_ms >= 0:
            p = select.poll()
            for fd, events in fds:
                p.register(fd, events)
            p.poll(wait_ms)
        elif self._real_clock and wait_ms > 0:
            time.sleep(wait_ms / 1000.0)
        return self.service(dispatch=dispatch)

    def service(self, now_ms: int | None = None, dispatch: bool = True) -> int:
        """The non-blocking part of poll(): ports, memlinks, tick, dispatch (at `now_ms` or now; with
        `dispatch=False` the deliveries wait in the ring for receive())."""
        now = self.now() if now_ms is None else now_ms
        for hook in self._service_hooks:
            hook(now)
        if self._ports is not None:
            ub_ports.ub_ports_service(self._ports, now)
            for text in ub_ports.ub_ports_notices(self._ports):  # each reported once, e.g. a refused sender
                self.notices.append(text)
                log.warning("%s: %s", self.name, text)
        for m in self._memlinks:
            ub_memlink.ub_memlink_pump(m._c, now)
        ub_node.ub_node_tick(self._c, now)
        if self._batching:  # what the tick queued leaves now, not at the next poll()
            ub_ports.ub_ports_flush(self._ports)
        return self._dispatch() if dispatch else 0

    def messages(self, timeout: float | None = None, poll_s: float = 0.01) -> Iterator[Message]:
        """Deliveries as they come, driving poll() itself; stops after `timeout` s (wall clock)
        without a message (None: never)."""
        last = time.monotonic()
        while True:
            while self._inbox:
                last = time.monotonic()
                yield self._inbox.popleft()
            if timeout is not None and time.monotonic() - last >= timeout:
                return
            self.poll(poll_s)

    async def run(self, poll_s: float = 0.01) -> None:
        """asyncio helper: services the node whenever a port's descriptor is readable, and at least
        every `poll_s` (timers). Cancel the task to stop."""
        import asyncio

        loop = asyncio.get_running_loop()
        wake = asyncio.Event()
        watched: set[int] = set()
        try:
            while not self._closed:
                fds = {fd for fd, _ in self.fds()}
                for fd in fds - watched:
                    loop.add_reader(fd, wake.set)
                for fd in watched - fds:
                    loop.remove_reader(fd)
                watched = fds
                try:
                    await asyncio.wait_for(wake.wait(), poll_s)
                except asyncio.TimeoutError:
                    pass
                wake.clear()
                self.service()
        finally:
            for fd in watched:
                loop.remove_reader(fd)

    # -- ports ---------------------------------------------------------------------------------
    def _ports_obj(self) -> Any:
        if self._ports is None:
            self._ports = ub_ports.ub_ports_new(self._c)
        return self._ports

    def open_port(self, link: str, spec: str) -> None:
        """Opens (or, if open, switches at run time) the transport of `link`: "udp:bind=H:P,peer=H:P",
        "tcp:listen=H:P", "tcp:connect=H:P", "serial:device=PATH[,baud=N]" (Contract 1)."""
        ub_ports.ub_ports_open_text(self._ports_obj(), link, spec, self.now())
        self._note_batching()

    def open_ports_from_config(self) -> int:
        """Opens every port of the config's "ports" section that names a link of this node."""
        if self.config is None:
            raise InvalidArgumentError("open_ports_from_config() needs Node(..., config=...)")
        n = ub_ports.ub_ports_open_config(self._ports_obj(), self.config.c_config, self.now())
        self._note_batching()
        return n

    def _note_batching(self) -> None:
        names = [ub_node.link_counters(self._c, i)["name"] for i in ub_node.ub_node_links(self._c)]
        self._batching = ub_ports.ub_ports_batching(self._ports, names)

    def flush(self) -> int:
        """Sends what batching ports (udp `batch=1`) queued now; send(), send_many() and poll() do it
        themselves. Returns the frames a full socket buffer still holds back (the next poll() sends them)."""
        return 0 if self._ports is None else ub_ports.ub_ports_flush(self._ports)

    def set_foreign_handler(self, link: str, handler: Callable[[bytes], int | None] | None) -> None:
        """Gives `link`'s port a foreign-traffic handler (docs/adapters.md): every run of received bytes that is
        not a uavbus frame (serial, in stream order) or every datagram that is not uavbus (UDP) is passed to
        `handler(data)`, which returns how many bytes it took (None: all; the rest is counted refused). uavbus
        frames on the same link are routed as before, never passed to it. The C decoder does the splitting
        (one implementation); the port keeps the handler across a runtime switch. None removes it."""
        handle = ub_ports.ub_ports_set_foreign(self._ports_obj(), link, handler)
        self._foreign_handlers[link] = handle  # alive while C may call it

    def on_service(self, hook: Callable[[int], Any]) -> None:
        """Calls `hook(now_ms)` at each service() (poll()), before the ports are read: what a device adapter
        does on time (uavbus.adapters.UbxAdapter writes its receiver's configuration, keeps its time-out)."""
        self._service_hooks.append(hook)

    def remove_on_service(self, hook: Callable[[int], Any]) -> None:
        """Stops calling `hook` (no error when it was not set)."""
        if hook in self._service_hooks:
            self._service_hooks.remove(hook)

    def write_foreign(self, link: str, data: bytes) -> None:
        """Writes `data`, bytes that are not a uavbus frame (a legacy datalink message on a `legacy:` port, a
        device's command on a serial or TCP port), onto `link`'s port whole, between frames (docs/adapters.md).
        Raises when the transport cannot (UDP), the link is down or its transmit buffer is full."""
        ub_ports.ub_ports_write_foreign(self._ports_obj(), link, bytes(data), self.now())

    def close_port(self, link: str) -> None:
        """Closes the transport of `link` (the link stays, detached)."""
        ub_ports.ub_ports_close(self._ports_obj(), link)
        self._note_batching()

    def local_port(self, link: str) -> int:
        """The local UDP/TCP port number `link`'s transport is bound to (e.g. after bind=...:0)."""
        return ub_ports.ub_ports_local_port(self._ports_obj(), link)

    def port_info(self, link: str) -> dict[str, Any] | None:
        """The spec, counters (UDP: peers, foreign, no_peer...) and impairment of `link`'s port, or None."""
        return None if self._ports is None else ub_ports.ub_ports_describe(self._ports, link)

    def set_impairment(self, loss: float = 0.0, dup: float = 0.0, reorder: float = 0.0, delay: int = 0,
                       jitter: int = 0, hold: int = 0, seed: int = 0, rate: int = 0, mtu: int = 0,
                       prio: bool = False) -> None:
        """Seeded impairment in front of every socket/serial port, now and later (Contract 4). `rate`: bytes
        per second the medium carries (a 57,600-baud radio: 5760); `mtu`: its longest packet (0: no limit);
        `prio`: send by priority class on that budget (docs/pubsub.md, "Priorities on slow links")."""
        ub_ports.ub_ports_set_impairment(self._ports_obj(), loss, dup, reorder, delay, jitter, hold, seed, rate, mtu,
                                         prio)

    def set_link_impairment(self, link: str, loss: float = 0.0, dup: float = 0.0, reorder: float = 0.0,
                            delay: int = 0, jitter: int = 0, hold: int = 0, seed: int = 0, rate: int = 0,
                            mtu: int = 0, prio: bool = False) -> None:
        """The open port of `link` gets its own seeded impairment, over set_impairment()'s (e.g. loss=1: a
        radio out of range; rate=5760: a 57,600-baud radio; prio=True: by priority class); all zero removes it."""
        ub_ports.ub_ports_set_link_impairment(self._ports_obj(), link, loss, dup, reorder, delay, jitter, hold, seed,
                                              rate, mtu, prio)

    def _keep_alive(self, transport: Any) -> None:
        """Keeps a Python transport (uavbus.pylink.PyLink) alive as long as the node: C points at it."""
        self._kept.append(transport)

    # -- recording -----------------------------------------------------------------------------
    def record(self, path: str | Path, tx: bool = False, *, max_bytes: int = 0, max_ms: int = 0,
               max_files: int = 0) -> None:
        """Records received (and with tx=True sent) frames to a binary log with the C writer
        (docs/log-format.md). With max_bytes / max_ms a new file starts when the current one would grow
        past that size or is that old; max_files keeps the newest files (path, path's .0001, .0002...)."""
        self.stop_recording()
        self._log = ub_log.ub_log_open_path(str(path), self._c, self.name, tx, int(time.time() * 1000), self.now(),
                                            max_bytes=max_bytes, max_ms=max_ms, max_files=max_files)
        if not self._frame_callbacks:  # otherwise the Python tap feeds the log (_Sink.on_tap)
            ub_log.ub_log_install(self._c, self._log)

    def stop_recording(self) -> dict[str, int] | None:
        """Ends record(); returns the writer's counters (None if not recording)."""
        if self._log is None:
            return None
        if not self._frame_callbacks:
            ub_node.set_tap_sink(self._c, None)
        stats = ub_log.ub_log_stats(self._log)
        ub_log.ub_log_close(self._log)  # closes the file: the writer owns it
        self._log = None
        return stats

    # -- security (docs/security.md): node.security ---------------------------------------------------
    def add_key(self, path: str | Path) -> int:
        """Same as `node.security.add_key()` (kept for callers of the flat API)."""
        return self.security.add_key(path)

    def use_key(self, key_id: int) -> None:
        """Same as `node.security.use_key()`."""
        self.security.use_key(key_id)

    def remove_key(self, key_id: int) -> None:
        """Same as `node.security.remove_key()`."""
        self.security.remove_key(key_id)

    # -- counters ------------------------------------------------------------------------------
    def counters(self) -> dict[str, Any]:
        """The C node counters (drops by reason) plus what the Python layer itself dropped."""
        out = ub_node.ub_node_counters(self._c)
        if self.security.enabled:
            out["security"] = self.security.status()
        out["python"] = {"inbox_dropped": self._inbox_dropped, "callback_errors": self._callback_errors,
                         "frames_dropped": self._frames_dropped, "refused_payloads": self._refused_payloads,
                         "ring": {**ub_rxring.ub_rxring_counters(self._ring),
                                  "spill_dropped": self._sink.spill_dropped}}
        if self._log is not None:
            out["log"] = ub_log.ub_log_stats(self._log)
        return out

    def link_counters(self) -> dict[str, dict[str, Any]]:
        """Per link slot: C counters, drops by reason, bad frames by reason, and its port if open."""
        out = {}
        for link_id in ub_node.ub_node_links(self._c):
            c = ub_node.link_counters(self._c, link_id)
            c["link_id"] = link_id
            port = self.port_info(c["name"])
            if port is not None:
                c["port"] = port
            out[c.pop("name")] = c
        return out

    # -- life ----------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise InvalidArgumentError("node is closed")

    def close(self) -> None:
        """Closes ports and the log, detaches hooks and admin tables. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self.stop_recording()
        if self._ports is not None:
            ub_ports.ub_ports_close_all(self._ports)
        for adm in self._admins.values():
            adm._detach()
        if self._membership is not None:
            ub_member.ub_member_detach(self._membership._c)
        self.inspect._detach()
        self.routing.disable()
        for transport in self._kept:
            transport.detach()
        ub_rxring.ub_rxring_detach(self._ring)

    def __enter__(self) -> "Node":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<Node {self.name} entities={self.local_entities}>"


def _entity_at(node: Node, index: int) -> str:
    return ub_node.entity_name(ub_node.ub_node_entity_id(node._c, index))


class Publisher:
    """Node.publisher(): `directory` is the bound storage; send() originates one DATA frame from it."""

    __slots__ = ("node", "directory", "_c", "_entity", "_instance", "_dest", "_local", "_what", "_now")

    def __init__(self, node: Node, directory: Directory, entity: int, instance: int, dest: Any, local: bool) -> None:
        self.node, self.directory, self._c = node, directory, node._c
        self._entity, self._instance, self._dest, self._local = entity, instance, dest, local
        # Resolved once: send() is the per-frame path (only the clock is read per frame).
        self._what = directory.instance.name if directory.instance else ""
        self._now = node.now

    def send(self) -> int:
        """Returns the links whose transport accepted the frame (0: delivered locally, or every
        transport refused it: counted per link as tx_error/backpressure/detached)."""
        n = ub_node.ub_node_send_data_id(self._c, self._entity, self._instance, self._dest, self._now(), self._what)
        node = self.node
        if node._batching:
            ub_ports.ub_ports_flush(node._ports)
        if self._local:
            self.node._dispatch()  # a local destination is delivered synchronously
        return n

    def send_many(self, values: Sequence[Any] | bytes | bytearray | memoryview, field: str | None = None) -> int:
        """Sends len(values) frames in one C call (ub_send_many). With `field` (a plain scalar member): frame i
        carries values[i] in that field, the rest of the directory as set. Without: `values` are whole wire
        images (a sequence of bytes, or one buffer of n images back to back). The directory keeps the last
        value. Returns the sum over frames of the links whose transport accepted it (as send())."""
        d = self.directory
        t = d._type
        if field is not None:
            scalar = t._scalars.get(field)
            if scalar is None or not isinstance(scalar[0], struct.Struct):
                raise InvalidArgumentError(f"send_many: {t.name}.{field} is not a plain scalar member "
                                           f"(one of {', '.join(sorted(t._scalars))}); send whole images instead")
            packer, offset = scalar
            n = len(values)
            data = struct.pack(f"{packer.format[0]}{n}{packer.format[1:]}", *values)
            size = packer.size
        else:
            size, offset = t.packed_size, 0
            data = values if isinstance(values, (bytes, bytearray, memoryview)) else b"".join(values)
            if size == 0 or len(data) % size:
                raise InvalidArgumentError(f"send_many: {len(data)} bytes are not whole {t.name} images "
                                           f"({size} bytes each)")
            n = len(data) // size
        sent = ub_rxring.ub_send_many(self._c, self._entity, self._instance, self._dest, self.node.now(),
                                      d._offset + offset, size, data, n, d.instance.name if d.instance else "")
        if self.node._batching:  # the burst leaves now, several frames per datagram
            ub_ports.ub_ports_flush(self.node._ports)
        if self._local:
            self.node._dispatch()
        return sent


class Deliveries:
    """Node.receive(): one batch of deliveries as records (the ring's memory copied once), not objects.

    `len()` counts them; `column(content, field)` reads one plain scalar field of every delivery of
    `content`, in order, with one struct pass over the records; iterating builds a Message per delivery
    (only then: a receiver that reads columns pays for no objects)."""

    __slots__ = ("node", "records", "n", "extra")

    def __init__(self, node: Node, records: bytes, n: int,
                 extra: list[tuple[int, int, bytes, bytes, int, int, bytes, int]] | None) -> None:
        self.node, self.records, self.n, self.extra = node, records, n, extra

    def __len__(self) -> int:
        return self.n + (len(self.extra) if self.extra else 0)

    def column(self, content: str, field: str) -> list[Any]:
        node = self.node
        inst = node.catalogue.instance(content)
        key = (inst.index, field)
        col = node._columns.get(key)
        t = inst.type
        if col is None:
            scalar = t._scalars.get(field)
            if scalar is not None and isinstance(scalar[0], struct.Struct) and sys.byteorder == "little":
                # (instance, value) from each record: header and image in one little-endian pass.
                code, size, at = scalar[0].format[1:], scalar[0].size, ub_rxring.HEADER + scalar[1]
                col = struct.Struct(f"<8xI{at - 12}x{code}{node._ring.stride - at - size}x")
            else:
                t.field(field)  # an unknown member raises KeyError naming the members
                col = False
            node._columns[key] = col
        idx = inst.index
        if not col:
            return [read_member(t, field, img, 0) for _, i, _, _, _, _, img, _ in self._tuples() if i == idx]
        out = [v for i, v in col.iter_unpack(self.records) if i == idx] if self.n else []
        if self.extra:
            out += [read_member(t, field, img, 0) for _, i, _, _, _, _, img, _ in self.extra if i == idx]
        return out

    def rows(self, content: str) -> list[tuple[Any, ...]]:
        """Every delivery of `content` decoded to a flat tuple of its leaf values (the type's packed order,
        nested members and arrays flattened; Catalogue.decode() gives dicts), in order: one struct pass over
        the records."""
        node = self.node
        inst = node.catalogue.instance(content)
        t, idx = inst.type, inst.index
        key = (idx, "")
        rows = node._columns.get(key)
        if rows is None:
            fmt = t._struct.format
            fits = sys.byteorder == "little" and isinstance(fmt, str) and fmt.startswith("<")
            pad = node._ring.stride - ub_rxring.HEADER - t._struct.size
            # (instance, leaves...) of any record; and the leaves alone, for a batch of this content only
            rows = (struct.Struct(f"<8xI{ub_rxring.HEADER - 12}x{fmt[1:]}{pad}x"),
                    struct.Struct(f"<{ub_rxring.HEADER}x{fmt[1:]}{pad}x")) if fits and pad >= 0 else False
            node._columns[key] = rows
        if rows and self.n:
            # Each record's instance (u32 at byte 8): a batch of one content, the usual case, is unpacked
            # as is, with no per-row filtering or slicing.
            kinds = memoryview(self.records).cast("I")[2::node._ring.stride // 4]
            if kinds.tolist().count(idx) == self.n:
                out = list(rows[1].iter_unpack(self.records))
            else:
                out = [r[1:] for r in rows[0].iter_unpack(self.records) if r[0] == idx]
        else:
            out = [t._struct.unpack_from(img) for _, i, _, _, _, _, img, _ in self._tuples() if i == idx]
            return out
        if self.extra:
            out += [t._struct.unpack_from(img) for _, i, _, _, _, _, img, _ in self.extra if i == idx]
        return out

    def _tuples(self) -> list[tuple[int, int, bytes, bytes, int, int, bytes, int]]:
        recs = [(e, i, s, d, q, t, img[:ln], h)
                for t, i, q, e, ln, h, s, d, img in self.node._records.iter_unpack(self.records)] if self.n else []
        return recs + (self.extra or [])

    def __iter__(self) -> Iterator[Message]:
        node = self.node
        instances, names = node.catalogue.instances, node._local_names
        for entity, instance, src_id, dest_id, seq, now_ms, raw, hop_limit in self._tuples():
            local = names.get(entity)
            if local is None:
                local = names[entity] = _entity_at(node, entity)
            yield Message(instances[instance], local, src_id, dest_id, seq, now_ms, raw, node.catalogue, hop_limit)


class Admin:
    """The global administration table (paper Figure 5) on one local entity: the GCS API."""

    def __init__(self, node: Node, entity: str, options: dict[str, int] | None = None) -> None:
        self.node = node
        self.entity = entity
        self._c = ub_admin.ub_admin_new(node._c, node.entity_index(entity), options)

    def add(self, content: str, source: str, destination: str, period_ms: int, kind: str = "publication") -> int:
        """An inactive row: `kind` "publication" (request to the source) or "subscription" (to the
        destination). Returns the row index."""
        if kind not in ub_admin.ROW_TYPES:
            raise InvalidArgumentError(f"kind {kind!r}: use 'publication' or 'subscription'")
        inst = self.node.catalogue.instance(content)
        return ub_admin.ub_admin_add_row(self._c, inst.index, source, destination, period_ms, kind)

    def activate(self, row: int) -> None:
        """Activates `row`: the request goes out (then pending -> acknowledged -> active)."""
        ub_admin.ub_admin_set_active(self._c, row, True, self.node.now())

    def deactivate(self, row: int) -> None:
        """Deactivates `row`: the STOP goes out; the row stays, inactive."""
        ub_admin.ub_admin_set_active(self._c, row, False, self.node.now())

    def remove(self, row: int) -> None:
        """Removes an inactive `row` from the table."""
        ub_admin.ub_admin_remove_row(self._c, row)

    def status(self, row: int) -> dict[str, Any]:
        """status: "inactive" | "pending" | "acknowledged" | "active" | "failed" | "stopping" | "stale" (acknowledged,
        but the row's destination is here and its data stopped: ub_admin.h UB_ADMIN_STALE); nack_reason:
        None or the target's reason by name ("table_full", "not_authorized", "limit", "other_admin": another
        administrator keeps this flow, ...); nack_relayed: the reason is the source's, relayed by the
        destination of a subscription row."""
        s = ub_admin.ub_admin_row_status(self._c, row)
        s["content"] = self.node.catalogue.instances[s["instance"]].name
        return s

    def rows(self) -> list[dict[str, Any]]:
        """Every row's status (see status())."""
        out = []
        for k in range(ub_admin.MAX_ADMIN_ROWS):
            try:
                out.append(self.status(k))
            except NotFoundError:
                continue
        return out

    def _detach(self) -> None:
        ub_admin.ub_admin_detach(self._c)


class Membership:
    """Membership changes sent to other entities over the bus (MEMBERSHIP, admin code 11): each request is
    resent until the target answers; status() says done (changed or already so) or failed (reason)."""

    def __init__(self, node: Node, entity: str, options: dict[str, int] | None = None) -> None:
        self.node = node
        self.entity = entity
        self._c = ub_member.ub_member_new(node._c, node.entity_index(entity), **(options or {}))

    def request(self, op: str, target: str, subject: str = "", *, mask: int | str = 0, link_index: int = 0,
                link_name: str = "", port_spec: str = "") -> int:
        """Queues `op` ("add_entity", "remove_entity", "set_mask", "add_link", "remove_link") for entity
        `target`; returns the request row (it leaves at the next poll)."""
        if isinstance(mask, str):
            mask = ub_link.ub_link_mask_parse(mask)
        s = ub_member.spec(op, target, subject, mask, link_index, link_name, port_spec)
        return ub_member.ub_member_request(self._c, s, self.node.now())

    def announce(self, subject: str, targets: list[str]) -> list[int]:
        """The paper's announcement: tells each of `targets` that entity `subject` exists."""
        return [self.request("add_entity", t, subject) for t in targets]

    def status(self, row: int) -> dict[str, Any]:
        """{"status": "pending" | "done" | "failed", "changed" | "reason", "attempts", ...}."""
        return ub_member.ub_member_status(self._c, row)

    def forget(self, row: int) -> None:
        ub_member.ub_member_forget(self._c, row)


class Routing:
    """`node.routing`: the routing engine (ub_route.h, docs/routing.md). While it runs, every local entity is a
    router over its links and masks fill themselves; masks set by hand stay pinned. True while enabled."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._c: Any = None  # ub_route_t while enabled

    def enable(self, parallel: str = "all", learn: bool = True, certified: bool = False, **options: int) -> None:
        """Starts (or restarts) the engine. Options: hello_ms (default 1000), update_ms, trigger_gap_ms,
        source_gc_ms, dead_misses, initial_seqno, learn_expiry_ms (a learned entity no update advertised this
        long is removed; default source_gc_ms), max_dests (destinations one neighbour may advertise; entries for
        more are ignored and counted neighbour_limit; default UB_ROUTE_MAX_DESTS_PER_NEIGHBOUR, the whole
        entity table); parallel "all" | "best"; learn; certified: advertised destinations get routes only if the
        node's identity store certifies them (valid, unrevoked certificate at the wall clock; others are ignored
        and counted dest_refused), as `uavbus_node --route certified=1` (docs/security.md, "Routing from
        insiders"); needs identities (Node(config=...) naming an authority)."""
        store = None
        if certified:
            if self.node.identity is None:
                raise InvalidArgumentError("routing certified=True needs identities: name an authority in the "
                                           "configuration's \"security\" section (uavbus keys fleet), or drop "
                                           "certified=True")
            store = self.node.identity.store.c
        if self._c is not None:
            ub_route.ub_route_detach(self._c)
        self._c = ub_route.ub_route_new(self.node._c, self.node.now(), parallel, learn, store, **options)

    def disable(self) -> None:
        """Detaches the engine; the masks it wrote are cleared (pinned ones stay)."""
        if self._c is not None:
            ub_route.ub_route_detach(self._c)
            self._c = None

    @property
    def enabled(self) -> bool:
        """True while the engine runs (enable())."""
        return self._c is not None

    def __bool__(self) -> bool:
        return self.enabled

    def _need(self) -> Any:
        if self._c is None:
            raise InvalidArgumentError("routing is not enabled on this node (node.routing.enable())")
        return self._c

    def table(self, entity: str | None = None) -> dict[str, dict[str, Any]]:
        """What routing chose for local `entity` (default: the first local one), per known destination:
        reachable, next_hop, link (name), metric, seqno, mask, pinned, learned, starving, ..."""
        rt, node = self._need(), self.node
        me = node.entity_index(entity or node.local_entities[0])
        out = {}
        for e in node.entities():
            if e["index"] == me:
                continue
            r = ub_route.ub_route_get(rt, me, e["index"])
            r["link"] = ub_node.link_name(node._c, r["link_id"]) if r["link_id"] >= 0 else None
            out[e["name"]] = r
        return out

    def links(self) -> dict[str, dict[str, Any]]:
        """Per link: neighbour, costs (rxcost/txcost/cost) and routing frame counters."""
        rt, c = self._need(), self.node._c
        return {ub_node.link_name(c, lid): ub_route.ub_route_link_info(rt, lid) for lid in ub_node.ub_node_links(c)}

    def counters(self) -> dict[str, int]:
        """The engine's counters (frames, updates, route changes...)."""
        return ub_route.ub_route_counters(self._need())


class Wire:
    """`node.wire`: how frames look on each link (ub_node.h "Wire", docs/wire-format.md): the compact encoding,
    MTUs, and the fragments that carry directories above the payload limit or a link's MTU."""

    def __init__(self, node: Node, first_transfer: int) -> None:
        self.node = node
        # Every Python node can send and reassemble fragments (about UB_FRAG_SLOTS + UB_FRAG_TX_SLOTS times
        # UB_MAX_DIRECTORY bytes); transfers are numbered from the node's first sequence number.
        self._frag = ub_frag.ub_frag_new(first_transfer)
        ub_frag.ub_node_set_frag(node._c, self._frag)
        self._compact: dict[int, Any] = {}  # link id -> ub_compact_t the C link points to

    def set_encoding(self, link: str, encoding: str = "compact") -> None:
        """Sets `link` to the compact encoding ("compact": short indices agreed with the other end, which must
        be set alike; docs/wire-format.md) or back to full 64-byte headers ("full"). Ports opened with
        `encoding=compact` in their spec do this themselves."""
        if encoding not in ("compact", "full"):
            raise InvalidArgumentError(f"encoding {encoding!r}: use 'compact' or 'full'")
        link_id = self.node.link_id(link)
        state = ub_node.ub_node_link_set_compact(self.node._c, link_id, encoding == "compact",
                                                 f"encoding of link {link!r}")
        if state is None:
            self._compact.pop(link_id, None)
        else:
            self._compact[link_id] = state  # the C link keeps a pointer: keep the memory alive

    def set_mtu(self, link: str, mtu: int) -> None:
        """The largest frame `link` carries on the wire, in bytes after encoding (0: no limit; else 64..65535).
        Larger directories are sent in fragments; larger forwarded frames are dropped `too_big`."""
        if not 0 <= mtu <= 65535:
            raise InvalidArgumentError(f"mtu {mtu}: give 0 (no limit) or 64..65535 bytes")
        ub_node.ub_node_link_set_mtu(self.node._c, self.node.link_id(link), mtu,
                                     f"mtu {mtu} of link {link!r} (64..65535)")

    def set_priorities(self, classes: dict[str, str] | None) -> None:
        """Each content's priority class on slow links (docs/pubsub.md, "Priorities on slow links"): a dict
        instance name -> "command", "control", "telemetry" (the default of every content not named) or "bulk".
        A link whose transport queues by class (an impairment with `rate=` and `prio=1`) sends by it; admin
        frames are always "command", fragments "bulk". Give every node of a fleet the same table. None: every
        content telemetry."""
        if classes is None:
            self._classes = ub_node.ub_node_set_content_classes(self.node._c, None, "priorities")
            return
        cat = self.node.catalogue
        table = [ub_node.PRIO_CLASSES.index("telemetry")] * len(cat)
        for name, cls in classes.items():
            if cls not in ub_node.PRIO_CLASSES:
                raise InvalidArgumentError(
                    f"priority of {name!r}: {cls!r} is not a class (use one of {', '.join(ub_node.PRIO_CLASSES)})")
            try:
                table[cat.instance(name).index] = ub_node.PRIO_CLASSES.index(cls)
            except KeyError as e:
                raise InvalidArgumentError(f"priority of {name!r}: {e.args[0]}") from None
        # the C node keeps a pointer to the table: keep it alive
        self._classes = ub_node.ub_node_set_content_classes(self.node._c, table, "priorities")

    def fragment_counters(self) -> dict[str, int]:
        """The fragment state's counters (ub_frag.h): transfers sent, reassembled, timed out..."""
        return ub_frag.ub_node_frag_stats(self.node._c)

    def _forget(self, link_id: int) -> None:
        self._compact.pop(link_id, None)


class Security:
    """`node.security`: the frame security of the config's "security" section (docs/security.md): key rotation
    and counters. Calling it, `node.security()`, is status()."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._sec: Any = None      # ub_sec_t (kept alive with the node)
        self._counter: Any = None  # ub_counter_file_t

    def _attach(self, sec: Any, counter: Any) -> None:
        self._sec, self._counter = sec, counter

    def _origin_from_identity(self, identity: ub_ident.NodeIdentity) -> None:
        """Origin authentication keyed by the identity store, all in C (as uavbus_node does): each local
        entity's X25519 secret from its identity file, peers' keys from valid unrevoked certificates
        (ub_ident_peer_kx_key, wall clock), required on every frame to a local entity, and a revocation the
        revocation service accepts forgets the peer's pairwise keys at once."""
        names = self.node.local_entities
        ctx, missing = ub_origin.OriginContext.from_store(identity.store.c, [ub_node.entity_id(n) for n in names])
        ctx.attach(self.node._c)
        identity.forget_on_revocation(ctx.c)
        self._origin = ctx
        for eid in missing:
            text = (f"local entity {ub_node.entity_name(eid)} has no identity (put {{entity}} in security.identity): "
                    "it cannot send to other entities (counted no_identity)")
            self.node.notices.append(text)
            log.warning("%s", text)

    @property
    def enabled(self) -> bool:
        """True when the node's config has a "security" section."""
        return self._sec is not None

    def _need(self) -> Any:
        if self._sec is None:
            raise InvalidArgumentError("this node runs without security (its config has no \"security\" section)")
        return self._sec

    def add_key(self, path: str | Path) -> int:
        """Key rotation, step 1: accept the key in `path` (a key file); returns its id."""
        key_id, key = ub_sec.ub_keyfile_load(str(path))
        ub_sec.ub_sec_add_key(self._need(), key_id, key)
        return key_id

    def use_key(self, key_id: int) -> None:
        """Key rotation, step 2: sign with key `key_id` (already accepted by every receiver)."""
        ub_sec.ub_sec_set_tx_key(self._need(), key_id)

    def remove_key(self, key_id: int) -> None:
        """Key rotation, step 3: retire key `key_id` (not the one that signs)."""
        ub_sec.ub_sec_remove_key(self._need(), key_id)

    def status(self) -> dict[str, Any] | None:
        """Signing key, accepted keys and the security counters; None without a security section."""
        if self._sec is None:
            return None
        out: dict[str, Any] = {"tx_key": ub_sec.ub_sec_tx_key(self._sec), "keys": ub_sec.ub_sec_key_ids(self._sec)}
        out.update(ub_sec.ub_sec_stats(self._sec))
        out["counter_mark"] = ub_nodecfg.counter_mark(self._counter)
        return out

    __call__ = status  # node.security(): the flat API's spelling

    # ---- origin authentication (docs/security.md, "Origin authentication") ----

    def enable_origin(self, identities: dict[str, bytes], lookup: Callable[[str, int], bytes | None], *,
                      recheck_ms: int = 0, optional: bool = False) -> None:
        """Origin authentication for this node's entities: `identities` maps each local entity's name to its
        X25519 secret key (32 bytes); `lookup(entity_name, now_s)` is the identity store: the peer's X25519
        public key, or None when it is unknown, revoked or expired. From then on every unicast frame a local
        entity sends carries an origin tag for its destination, and every frame reaching a local entity must
        carry one from its source (`optional=True`: frames without one are still taken). A hosted entity without
        an identity here cannot send to remote entities (its frames are refused, counted `no_identity`)."""
        self._need()
        if getattr(self, "_origin", None) is not None:
            raise InvalidArgumentError("origin authentication is already enabled on this node")

        def by_id(raw: bytes, now_s: int) -> bytes | None:
            return lookup(ub_node.entity_name(raw), now_s)

        ctx = ub_origin.OriginContext(by_id, recheck_ms, optional)
        for name, sk in identities.items():
            ctx.add_identity(ub_node.entity_id(name), sk)
        ctx.attach(self.node._c)
        self._origin = ctx

    def enable_origin_table(self, table: bytes | str | Path) -> dict[str, Any]:
        """Origin authentication from a provisioning table (`uavbus keys pairwise`: bytes or its path), as the
        microcontroller firmware runs it: the table's entity tags and checks origins with the pairwise keys
        the authority computed for it, no key agreement and no store (a peer outside the table is refused,
        `no_identity`). Its group key must be this node's too (configured, or added with add_key()). Returns
        the table's entity name and its number of pairs."""
        self._need()
        if getattr(self, "_origin", None) is not None:
            raise InvalidArgumentError("origin authentication is already enabled on this node")
        raw = table if isinstance(table, bytes) else Path(table).read_bytes()
        ctx, info = ub_origin.OriginContext.provisioned(raw)
        ctx.attach(self.node._c)
        self._origin = ctx
        return {"entity": ub_node.entity_name(info["entity"]), "pairs": info["pairs"],
                "group_key_id": info["group_key_id"]}

    def origin_forget(self, entity: str) -> int:
        """Forgets the cached pairwise keys with `entity` at once (e.g. on its revocation)."""
        ctx = getattr(self, "_origin", None)
        return 0 if ctx is None else ctx.forget(ub_node.entity_id(entity))

    def origin_status(self) -> dict[str, int] | None:
        """Origin counters (sealed, opened, bad_origin, no_origin, no_identity, derivations, ...), cached pairs;
        None when origin authentication is off."""
        ctx = getattr(self, "_origin", None)
        if ctx is None:
            return None
        return {**ctx.stats(), "cached": ctx.cached()}


class Inspection:
    """`node.inspect`: the INSPECT requester (ub_inspect.h, docs/inspect.md), one per node, sending from the
    node's first local entity; remote() browses one entity through it (uavbus.remote)."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._c: Any = None  # ub_inspect_t, created on first use

    def _requester(self, **options: int) -> Any:
        node = self.node
        node._check_open()
        if self._c is None:
            self._c = ub_inspect.ub_inspect_new(node._c, node.entity_index(node.local_entities[0]), **options)
        return self._c

    def remote(self, entity: str, timeout: float = 3.0) -> "Remote":
        """The variable browser on entity `entity`, anywhere on the bus: get/set its directories, read
        and change its tables (uavbus.remote)."""
        from uavbus.remote import Remote
        return Remote(self.node, entity, timeout)

    def counters(self) -> dict[str, int]:
        """The requester's counters (requests sent, done, failed...); all zero before the first request."""
        if self._c is None:
            return {k: 0 for k in ub_inspect.COUNTER_FIELDS}
        return ub_inspect.ub_inspect_counters(self._c)

    def _detach(self) -> None:
        if self._c is not None:
            ub_inspect.ub_inspect_detach(self._c)


class MemLink:
    """An in-process link between `link_a` of node `a` and `link_b` of node `b` (the C memlink,
    with seeded faults: loss_ppm, duplicate_ppm, reorder_ppm, corrupt_ppm, delay_ms, jitter_ms).
    Both nodes pump it from their poll()/service()."""

    def __init__(self, a: Node, link_a: str, b: Node, link_b: str, faults: dict[str, int] | None = None,
                 seed: int = 0) -> None:
        self.a, self.b = a, b
        self._c = ub_memlink.ub_memlink_new(faults, seed)
        self._link_a, self._link_b = a.link_id(link_a), b.link_id(link_b)
        ub_memlink.ub_memlink_connect(self._c, a._c, self._link_a, b._c, self._link_b)
        a._memlinks.append(self)
        if b is not a:
            b._memlinks.append(self)

    def disconnect(self) -> None:
        """Takes both ends off their nodes and drops what is queued (counted lost); the link slots can then
        be removed (Node.remove_link()) or connected again by a new MemLink."""
        ub_memlink.ub_memlink_disconnect(self._c)
        for n in (self.a, self.b):
            if self in n._memlinks:
                n._memlinks.remove(self)

    def _ends_at(self, node: Node, link_id: int) -> bool:
        return (self.a is node and self._link_a == link_id) or (self.b is node and self._link_b == link_id)

    def set_faults(self, faults: dict[str, int] | None) -> None:
        """Changes the seeded faults (None: none) for the frames sent from now on."""
        ub_memlink.ub_memlink_set_faults(self._c, faults)

    def pending(self) -> int:
        """Frames queued in the link, not delivered yet."""
        return ub_memlink.ub_memlink_pending(self._c)

    def pump(self, now_ms: int) -> int:
        """Delivers the frames due at `now_ms` (poll() does this; tests call it to interleave steps)."""
        return ub_memlink.ub_memlink_pump(self._c, now_ms)

    def stats(self) -> dict[str, dict[str, int]]:
        """Counters of frames sent from each end: {"a": {...}, "b": {...}}."""
        return {"a": ub_memlink.ub_memlink_stats(self._c, 0), "b": ub_memlink.ub_memlink_stats(self._c, 1)}
