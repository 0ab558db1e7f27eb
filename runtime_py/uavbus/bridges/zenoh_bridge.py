"""`uavbus bridge zenoh`: joins uavbus networks (sites) through Zenoh sessions (docs/bridges.md).

    uavbus bridge zenoh --config FILE [--node NAME] --catalogue CAT.json
                        [--link zenoh] [--mode peer|router|client]
                        [--listen ENDPOINT]... [--connect ENDPOINT]...
                        [--prefix KEY] [--flow DEST[/SOURCE[/DIRECTORY]]]... [--express]
                        [--batch-bytes N] [--batch-idle-us US] [--batch-age-us US]
                        [--sample-thread zenoh|python] [--timer-slack-ns NS]
                        [--stats-s S] [--duration-s S]

The bridge is a uavbus node like any other: its entity (the one owning --link) has links to its own
site (ports of the configuration) and one link whose transport is this Zenoh session (a C batch link,
ub_batchlink.h: the C router routes onto it as onto a UDP link). Entities of the other sites are
rows of the entity table whose masks point at the Zenoh link, so they are reachable from every node of
this site like any entity a few hops away; the one router does the work (verification, duplicates,
hop limit, forwarding, counters).

**Frames are carried unchanged, many per sample**: the frames the router sent on the Zenoh link since
the loop's last turn go out as batches (docs/bridges.md "Batches"): consecutive frames of one key
expression share one Zenoh sample, each frame's bytes as they left the router (hop limit already
decremented) behind a 2-byte length, so a signed or encrypted frame's trailer arrives intact and is
verified end to end by its destination. The per-frame work is C's (ub_batchlink.h packs what the router
sends, ub_batch_rx() unpacks into the router; ub_ports_drain() services the site's sockets until their
input goes idle); the loop handles samples. A batch leaves when the site's input goes quiet (nothing
new within --batch-idle-us), when --batch-bytes are pending, --batch-age-us after its first frame, or
when a Zenoh sample waits: no timer holds a lone frame, a burst shares samples. Samples travel in
Zenoh's own transmission batches unless --express. On a signed network the bridges verify like any forwarder (they hold the fleet key, docs/security.md) but never
re-sign: the tag the destination checks is the source's.

**Key expressions**, one chunk per part, so Zenoh tools and ACLs can select flows:

    <prefix>/<destination entity>/<source entity>/<directory>/<kind>

<prefix> defaults to `uavbus/<system>` (the configuration's "system", else `uavbus/uavbus`);
<directory> is the catalogue instance name (`navFilterState`, `gcsMissionRmax1[0]`), or `_` + the hex
content ID for a content the bridge's catalogue does not know; <kind> is `data` or the admin frame's
name (`pub_request`, `ack`, ...), so the requests and replies of a flow travel with its data.
A bridge subscribes, for each entity of its own site (masks not through the Zenoh link, itself
included), to `<prefix>/<entity>/**`, or to the --flow selections only (`gcs2/rmax1ob1/navFilterState`
-> `<prefix>/gcs2/rmax1ob1/navFilterState/*`; `*` for any entity). It announces each of those entities
with a liveliness token `<prefix>/@live/<entity>` and reports the other sites' tokens ("remote" events).

JSON lines on stdout, as uavbus_node: "ready", "remote", "stats", "error"; stdin `stats`, `quit`.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import select
import sys
import threading
import time
from collections import deque
from typing import Any, TextIO

from uavbus._bindings.ub_error import UbError
from uavbus._bindings.ub_frame import ub_frame_parse
from uavbus._bindings import ub_batchlink, ub_link, ub_ports
from uavbus.catalogue import Catalogue
from uavbus.errors import ConfigError
from uavbus.tools.common import admin_name, entity_name

LIVE_CHUNK = "@live"
INBOX_MAX = 65536          # frames from Zenoh waiting for the loop; beyond: counted rx_overflow
PUBLISHERS_MAX = 4096      # declared publishers kept (one per key); beyond: plain put, counted
LOOP_WAIT_MS = 10          # the loop wakes for descriptors and Zenoh samples anyway; this bounds ticks
HOUSEKEEPING_S = 0.1       # the full Python service (notices, deliveries to the bridge entity, hooks) this often

# Batch format 1 (docs/bridges.md "Batches"): one Zenoh sample carries one or more frames of one key.
#   0: 0xA5 (a frame's first sync byte)   1: 0xBA (a frame has 0x5B: a bare frame is told apart)
#   2: version (1)   3-4: frame count, little-endian (1..65535)
#   then per frame: length (2 bytes, little-endian, 1..65535) and the frame's bytes; nothing after.
BATCH_SYNC, BATCH_MARK, BATCH_VERSION, BATCH_HEADER = 0xA5, 0xBA, 1, 5
FRAME_MARK = 0x5B          # byte 1 of a bare frame (wire-format.md): what a bridge before batches sent
BATCH_BYTES = 16384        # default bound of one sample's payload (a frame larger than it goes alone)
BATCH_IDLE_US = 20         # default idle gap: the site's input is quiet when nothing came for this long
BATCH_AGE_US = 1000        # default bound of a drain: a batch waits for company at most this long
TIMER_SLACK_NS = 1000      # the loop thread's timer slack: a 20 us gap sleeps ~36 us, not ~87 (Linux's 50 us default)
BATCH_REFUSALS = ("batch_foreign", "batch_version", "batch_malformed")
KEY_AT, KEY_LEN = 8, 41    # dir_id, dest_id, src_id, admin: everything frame_key() reads from a frame
OUTBOX_BYTES = 1 << 22     # frames from the router waiting for the loop, packed; beyond: backpressure
OUTBOX_BATCHES = 4096


class BridgeError(RuntimeError):
    """A set-up problem, said in one line with what to do."""


def frame_key(prefix: str, frame: bytes, catalogue: Catalogue) -> str:
    """The key expression of one frame (module docstring)."""
    h = ub_frame_parse(frame)
    inst = catalogue.find(bytes(h.dir_id))
    directory = inst.name if inst is not None else "_" + bytes(h.dir_id).hex()
    return f"{prefix}/{entity_name(h.dest_id)}/{entity_name(h.src_id)}/{directory}/{admin_name(h.admin)}"


class BatchError(ValueError):
    """A sample that is not a batch this bridge reads; `reason` is the counter that counts it."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


def encode_batch(frames: list[bytes]) -> bytes:
    """One sample's payload: `frames` (1..65535 of them, each 1..65535 bytes) in batch format 1."""
    n = len(frames)
    if not 1 <= n <= 0xFFFF:
        raise ValueError(f"a batch holds 1..65535 frames, not {n}")
    parts = [bytes((BATCH_SYNC, BATCH_MARK, BATCH_VERSION, n & 0xFF, n >> 8))]
    for f in frames:
        size = len(f)
        if not 1 <= size <= 0xFFFF:
            raise ValueError(f"a batched frame has 1..65535 bytes, not {size}")
        parts.append(bytes((size & 0xFF, size >> 8)))
        parts.append(f)
    return b"".join(parts)


def batch_spans(payload: bytes) -> list[tuple[int, int]]:
    """(offset, length) of each frame of a batch-format-1 payload, in order; BatchError (with the counter
    naming why) for anything else, checked whole before any frame is used: a sample is taken or not."""
    end = len(payload)
    if end < 2 or payload[0] != BATCH_SYNC or payload[1] not in (BATCH_MARK, FRAME_MARK):
        raise BatchError("batch_foreign", "not a uavbus batch (another publisher on the bridges' keys?)")
    if payload[1] == FRAME_MARK:
        raise BatchError("batch_version", "a bare frame: the other bridge predates batch format 1 "
                                          "(run the same uavbus version on both sides)")
    if end < BATCH_HEADER:
        raise BatchError("batch_malformed", f"a batch of {end} bytes has no complete header")
    if payload[2] != BATCH_VERSION:
        raise BatchError("batch_version", f"batch format {payload[2]}, this bridge reads {BATCH_VERSION} "
                                          "(run the same uavbus version on both sides)")
    n = payload[3] | payload[4] << 8
    spans = []
    at = BATCH_HEADER
    for _ in range(n):
        if at + 2 > end:
            raise BatchError("batch_malformed", f"batch cut short: frame {len(spans) + 1} of {n} has no length")
        size = payload[at] | payload[at + 1] << 8
        at += 2
        if size == 0 or at + size > end:
            raise BatchError("batch_malformed", f"frame {len(spans) + 1} of {n}: length {size} does not fit")
        spans.append((at, size))
        at += size
    if n == 0 or at != end:
        raise BatchError("batch_malformed", f"{n} frames but {end - at} bytes after them" if n else "no frames")
    return spans


def flow_keyexpr(prefix: str, flow: str) -> str:
    """`DEST[/SOURCE[/DIRECTORY]]` ('*' = any) as a key expression under `prefix`."""
    parts = flow.strip("/").split("/")
    if not 1 <= len(parts) <= 3 or any(not p for p in parts):
        raise BridgeError(f"--flow {flow!r}: expected DEST[/SOURCE[/DIRECTORY]] with '*' for any, "
                          "e.g. gcs2/rmax1ob1/navFilterState or gcs2/*")
    for p in parts:
        if p != "*" and any(c in p for c in "*$#?"):
            raise BridgeError(f"--flow {flow!r}: '{p}': a part is a name or '*', nothing else")
    tail = "/*" if len(parts) == 3 else "/**"
    return f"{prefix}/{'/'.join(parts)}{tail}"


class ZenohLink:
    """The Zenoh link's transport: a C batch link (ub_batchlink.h) packing the router's frames into
    batches of one flow each in memory owned here; the loop takes whole batches, never single frames."""

    def __init__(self, node: Any, link: str, batch_bytes: int) -> None:
        self.node, self.link_id = node, node.link_id(link)
        self.bl = ub_batchlink.BatchLink(OUTBOX_BYTES, OUTBOX_BATCHES, batch_bytes)
        ub_batchlink.ub_batchlink_attach(self.bl, node._c, self.link_id)
        node._keep_alive(self)  # C points at our memory until the node is closed

    @property
    def pending_bytes(self) -> int:
        return int(self.bl.c.len)

    @property
    def pending(self) -> int:
        return int(self.bl.c.n)

    @property
    def refused(self) -> int:
        return int(self.bl.c.refused)

    def take(self) -> tuple[Any, list[int]]:
        """The pending batches as a view of the link's memory (valid until the node runs again) and their
        end offsets; the link is emptied."""
        return ub_batchlink.ub_batchlink_take(self.bl)

    def detach(self) -> None:
        try:
            ub_link.ub_node_link_detach(self.node._c, self.link_id)
        except UbError:
            pass


class ZenohBridge:
    """One node's Zenoh link: outbound frames -> batched samples, subscribed samples -> the router.

    `batch_bytes` bounds a sample's payload. turn() lets the router take what the site's sockets hold until
    they go idle (nothing readable for `idle_us`; 0: at once), `batch_bytes` are pending or `age_us` have
    passed (ub_ports_drain(), in C), then publishes every pending batch: a lone frame waits one idle gap, a
    burst leaves in full samples."""

    def __init__(self, node: Any, link: str, session: Any, prefix: str, flows: list[str] | None = None,
                 express: bool = False, batch_bytes: int = BATCH_BYTES, idle_us: int = BATCH_IDLE_US,
                 age_us: int = BATCH_AGE_US, in_zenoh_thread: bool = True) -> None:
        import zenoh

        if not BATCH_HEADER + 2 <= batch_bytes <= 1 << 24:
            raise BridgeError(f"--batch-bytes {batch_bytes}: give {BATCH_HEADER + 2}..{1 << 24}")
        for flag, v in (("--batch-idle-us", idle_us), ("--batch-age-us", age_us)):
            if not 0 <= v <= 1_000_000:
                raise BridgeError(f"{flag} {v}: give 0..1000000 (0: no waiting)")
        self.node, self.link, self.session, self.prefix = node, link, session, prefix
        self.express = express
        self.batch_bytes, self.idle_us, self.age_us = batch_bytes, idle_us, age_us
        self.entity, self.local_site, self.remote_site = self._sites()
        self.zlink = ZenohLink(node, link, batch_bytes)
        self._counts = ub_batchlink.new_counts()
        self.flows = [flow_keyexpr(prefix, f) for f in flows] if flows else \
            [f"{prefix}/{e}/**" for e in self.local_site]
        self._inbox: deque[bytes] = deque()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        os.set_blocking(self._wake_w, False)
        # The site's sockets drained in C (ub_ports_drain) while the Zenoh link holds frames; a node without
        # ports (memlinks only) runs its Python service instead.
        self._bl = self.zlink.bl
        self._clock = node._clock  # the node's clock in ms (node.now() without its call)
        self._drain = None if node._ports is None else ub_ports.new_drain(
            self._wake_r, idle_us, age_us, ub_batchlink.pending_bytes_ptr(self._bl), batch_bytes)
        # Site ports with batch=1 (docs/bridges.md): a sample taken on a Zenoh thread is flushed there, so
        # its frames share datagrams and none waits for the loop's next turn.
        self._site_batching = node._batching
        self._lock = threading.Lock()
        # Held by whoever touches the node: the loop during its turn (run()), a Zenoh thread taking a sample
        # in the loop's stead (rx_in_callback). Off by default: a caller driving pump() itself (tests, the
        # bench) keeps every node call on its own thread.
        self.node_lock = threading.Lock()
        self.rx_in_callback = False
        self._closed = False
        self.counters = {"published": 0, "received": 0, "rejected": 0, "rx_overflow": 0, "put_errors": 0,
                         "publishers_full": 0, "samples_out": 0, "samples_in": 0, "loop_turns": 0,
                         **{r: 0 for r in BATCH_REFUSALS}}
        self._keys: dict[bytes, tuple[str, Any]] = {}   # a frame's KEY_BYTES -> (key expression, publisher)
        self.remote_alive: dict[str, bool] = {}
        self.events: deque[dict[str, Any]] = deque()
        self._publishers: dict[str, Any] = {}
        self._cc = zenoh.CongestionControl.BLOCK
        # in_zenoh_thread: the sample callback runs on Zenoh's network thread (zenoh.handlers.Callback
        # indirect=False, marked unstable by zenoh-python) instead of a Python thread Zenoh wakes for each
        # sample: one thread hand-off less per sample (added p50 342-571 us against 725-1,731 in three
        # interleaved bench pairs at load 6). It never blocks there (the node lock is only tried). A
        # zenoh-python without the option gets the plain callable.
        on_sample: Any = self._on_sample
        if in_zenoh_thread:
            try:
                on_sample = zenoh.handlers.Callback(self._on_sample, indirect=False)
            except (TypeError, AttributeError):
                pass
        self._subs = [session.declare_subscriber(k, on_sample, allowed_origin=zenoh.Locality.REMOTE)
                      for k in self.flows]
        live = session.liveliness()
        self._tokens = [live.declare_token(f"{prefix}/{LIVE_CHUNK}/{e}") for e in self.local_site]
        self._live_sub = live.declare_subscriber(f"{prefix}/{LIVE_CHUNK}/*", self._on_live, history=True)

    # -- which entities are where -----------------------------------------------------------------
    def _sites(self) -> tuple[str, list[str], list[str]]:
        cfg = self.node.config
        if cfg is None:
            raise BridgeError("the Zenoh bridge needs a node configuration (--config)")
        owner = next((e for e in cfg.hosts if self.link in cfg.entity(e).links), None)
        if owner is None:
            raise BridgeError(f"{cfg.path}: no entity of this node has a link named '{self.link}' "
                              f"(add it to the bridge entity's \"links\", or give --link)")
        bit = 1 << cfg.entity(owner).links.index(self.link)
        local, remote = [owner], []
        for e in cfg.entities:
            if e.name == owner:
                continue
            mask = cfg.mask(owner, e.name)
            if mask & bit:
                remote.append(e.name)
            elif mask or e.name in cfg.hosts:
                local.append(e.name)
        if not remote:
            raise BridgeError(f"{cfg.path}: entity '{owner}' sends nothing over '{self.link}': give the other "
                              f"sites' entities a mask with that link in its \"linktoentity\"")
        return owner, local, remote

    # -- Zenoh threads: only queue and wake the loop -----------------------------------------------
    def _wake(self) -> None:
        try:
            os.write(self._wake_w, b"\0")
        except BlockingIOError:
            pass  # the loop has wake-ups pending already
        except OSError:
            pass  # closing: a sample that raced close() has no loop left to wake

    def _on_sample(self, sample: Any) -> None:
        payload = sample.payload.to_bytes()
        # In the loop's stead (rx_in_callback, run()): when the loop is asleep (node_lock free) and nothing
        # older waits, the sample goes to the router from this thread at once, a wake-up and a thread
        # hand-off sooner. Never blocking here: a Zenoh thread that waited for the loop, while the loop
        # waits in a put for Zenoh, could stall both sessions.
        if self.rx_in_callback and not self._inbox and self.node_lock.acquire(blocking=False):
            try:
                if not self._inbox and not self._closed:
                    self._take(payload, self.node.now())
                    if self._site_batching:  # the sample's frames leave in shared datagrams, now
                        ub_ports.ub_ports_flush(self.node._ports)
                    if self.zlink.pending:  # the router answered onto Zenoh: the loop publishes
                        self._wake()
                    return
            finally:
                self.node_lock.release()
        if len(self._inbox) >= INBOX_MAX:
            with self._lock:
                self.counters["rx_overflow"] += 1
            return
        self._inbox.append(payload)
        if len(self._inbox) == 1:  # else the loop has a wake-up pending and will drain to empty anyway
            self._wake()

    def _take(self, payload: bytes, now: int) -> int:
        """One received sample into the router (the caller holds node_lock or is the only thread). Frames."""
        st, frames, rejected = ub_batchlink.ub_batch_rx(self.node._c, self.zlink.link_id, payload, now, self._counts)
        if st:
            self._refuse(payload)
            return 0
        counters = self.counters
        counters["samples_in"] += 1
        counters["received"] += frames
        counters["rejected"] += rejected
        return frames

    def _on_live(self, sample: Any) -> None:
        import zenoh

        entity = str(sample.key_expr).rsplit("/", 1)[-1]
        alive = sample.kind == zenoh.SampleKind.PUT
        if entity in self.local_site:
            return
        with self._lock:
            self.remote_alive[entity] = alive
            self.events.append({"event": "remote", "entity": entity, "alive": alive,
                                "known": entity in self.remote_site})
        self._wake()

    # -- the loop's side ------------------------------------------------------------------------
    def fileno(self) -> int:
        return self._wake_r

    def site_fds(self) -> tuple[int, list[tuple[int, int]]]:
        """(generation, [(fd, events)]) of the site's sockets as the last turn saw them; the generation
        changes when they do (a TCP connection up or down), so a loop re-registers only then."""
        how = self._drain
        if how is None:
            return -1, self.node.fds()
        return how.fds_gen, ub_ports.drain_fds(how)

    def turn(self, now_ms: int | None = None, woken: bool = True) -> int:
        """One turn of the loop (the caller holds node_lock, or is the only thread touching the node):
        queued samples into the router, the site's sockets drained until idle or a bound (C), then every
        pending batch published. `woken` (run() passes what poll() saw; a caller without a poll() keeps
        True): the wake pipe may hold bytes, emptied first, as it is whenever samples are queued: a pipe
        left readable would end every drain at once (WOKEN). Returns frames moved."""
        inbox = self._inbox
        if woken or inbox:
            try:
                while os.read(self._wake_r, 4096):
                    pass
            except BlockingIOError:
                pass
        now = int(self._clock()) if now_ms is None else now_ms
        moved = 0
        if inbox:
            while inbox:
                moved += self._take(inbox.popleft(), now)
        if self._drain is not None:
            ub_ports.ub_ports_drain(self.node._ports, self._drain, now)
        else:
            self.node.service(now, dispatch=False)
        if self._bl.c.n:
            moved += self._flush()
        return moved

    def _flush(self) -> int:
        """Every pending batch published, each copied once out of the batch link's memory. Frames."""
        view, ends = self.zlink.take()
        moved, start = 0, 0
        for end in ends:
            moved += self._publish(view, start, end)
            start = end
        return moved

    def flush_counts(self) -> dict[str, int]:
        """Drains ended by reason (ub_drain_end_t) since the start."""
        how = self._drain
        if how is None:
            return {}
        return ub_ports.drain_ends(how)

    def _refuse(self, payload: bytes) -> None:
        """A sample that is no batch of ours: counted by reason, said once per reason (not per sample).
        The C check decides; the Python reader (batch_spans) words the reason."""
        try:
            batch_spans(payload)
            exc = BatchError("batch_malformed", "refused by the C reader, accepted by batch_spans (a bug)")
        except BatchError as e:
            exc = e
        self.counters[exc.reason] += 1
        if self.counters[exc.reason] == 1:
            self.events.append({"event": "refused", "reason": exc.reason, "message": f"zenoh sample refused: {exc}"})

    def _publish(self, raw: Any, start: int, end: int) -> int:
        """One batch (raw[start:end] of the batch link's memory, frames of one flow) as one sample under
        that flow's key. Returns frames."""
        n = raw[start + 3][0] | raw[start + 4][0] << 8
        first = start + BATCH_HEADER + 2
        key_bytes = raw[first + KEY_AT:first + KEY_AT + KEY_LEN]
        payload = raw[start:end]
        try:
            known = self._keys.get(key_bytes)
            if known is None:
                flen = raw[start + BATCH_HEADER][0] | raw[start + BATCH_HEADER + 1][0] << 8
                key = frame_key(self.prefix, raw[first:first + flen], self.node.catalogue)
                pub = None
                if len(self._publishers) < PUBLISHERS_MAX:
                    pub = self._publishers[key] = self.session.declare_publisher(
                        key, congestion_control=self._cc, express=self.express)
                    self._keys[key_bytes] = known = (key, pub)
            else:
                key, pub = known
            if pub is not None:
                pub.put(payload)
            else:
                self.counters["publishers_full"] += 1
                self.session.put(key, payload, congestion_control=self._cc, express=self.express)
            self.counters["published"] += n
            self.counters["samples_out"] += 1
        except Exception:  # noqa: BLE001 (a Zenoh error must not stop the bridge: counted)
            self.counters["put_errors"] += n
        return n

    def stats(self) -> dict[str, Any]:
        with self._lock:
            out = dict(self.counters)
            out["remote_alive"] = sorted(e for e, up in self.remote_alive.items() if up)
        out["outbox_refused"] = self.zlink.refused
        out.update(self.flush_counts())
        return out

    def close(self) -> None:
        self._closed = True
        for thing in [*self._subs, self._live_sub, *self._tokens, *self._publishers.values()]:
            try:
                thing.undeclare()
            except Exception:  # noqa: BLE001 (closing anyway)
                pass
        os.close(self._wake_r)
        os.close(self._wake_w)


def zenoh_config(mode: str, listen: list[str], connect: list[str]) -> Any:
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    if listen:
        conf.insert_json5("listen/endpoints", json.dumps(listen))
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps(connect))
    # Only the endpoints given: no multicast discovery of whatever else is on the network.
    conf.insert_json5("scouting/multicast/enabled", "false")
    return conf


def _emit(out: TextIO, obj: dict[str, Any]) -> None:
    out.write(json.dumps(obj, separators=(",", ":")) + "\n")
    out.flush()


def run(args: argparse.Namespace, out: TextIO = sys.stdout) -> int:
    try:
        import zenoh
    except ImportError:
        raise BridgeError("the Zenoh bridge needs the eclipse-zenoh package: pip install 'uavbus[bridges]'") from None
    from uavbus.node import Node

    zenoh.init_log_from_env_or("error")
    if not 0 <= args.timer_slack_ns <= 1_000_000_000:
        raise BridgeError(f"--timer-slack-ns {args.timer_slack_ns}: give 0..1000000000 (0: the system's)")
    node = Node(args.catalogue, config=args.config, node=args.node)
    session = None
    bridge = None
    try:
        node.open_ports_from_config()
        prefix = args.prefix or f"uavbus/{node.config.system or 'uavbus'}"
        try:
            session = zenoh.open(zenoh_config(args.mode, args.listen, args.connect))
        except zenoh.ZError as exc:
            raise BridgeError(f"zenoh: cannot open a {args.mode} session (listen {args.listen}, connect "
                              f"{args.connect}): {exc}") from None
        bridge = ZenohBridge(node, args.link, session, prefix, args.flow, express=args.express,
                             batch_bytes=args.batch_bytes, idle_us=args.batch_idle_us, age_us=args.batch_age_us,
                             in_zenoh_thread=args.sample_thread == "zenoh")
        ports = {}
        for name, c in node.link_counters().items():
            if c.get("port") is not None:
                try:
                    ports[name] = {"local_port": node.local_port(name)}
                except UbError:
                    ports[name] = {"local_port": None}
        _emit(out, {"event": "ready", "pid": os.getpid(), "node": args.node, "entity": bridge.entity,
                    "link": args.link, "prefix": prefix, "zid": str(session.info.zid()), "mode": args.mode,
                    "listen": args.listen, "connect": args.connect, "flows": bridge.flows,
                    "local_site": bridge.local_site, "remote_site": bridge.remote_site, "ports": ports})
        end = time.monotonic() + args.duration_s if args.duration_s else None
        next_stats = time.monotonic() + args.stats_s if args.stats_s else None
        next_housekeeping = time.monotonic()
        wake_fd, stdin_fd = bridge.fileno(), sys.stdin.fileno()
        stdin_open = True
        poller = select.poll()
        poller.register(wake_fd, select.POLLIN)
        poller.register(stdin_fd, select.POLLIN)
        site: list[tuple[int, int]] = []
        gen = None
        # The loop holds node_lock except while it sleeps in poll(): then a Zenoh thread may hand a sample
        # to the router itself (ZenohBridge._on_sample), without waking the loop.
        # What set-up built (catalogue, tables, sessions) lives as long as the process: out of the cyclic
        # collector's way, whose passes over it were ~10 % of gwA's CPU under a blast (perf: gc_collect_main,
        # visit_decref) while the loop itself makes no cycles.
        gc.collect()
        gc.freeze()
        set_timer_slack(args.timer_slack_ns)
        bridge.node_lock.acquire()
        bridge.rx_in_callback = True
        bridge.turn()
        while True:
            # A turn is a few Python calls whatever the traffic: poll(), turn() (one C call drains the site's
            # sockets until idle, ub_ports_drain), one publish per batch. The poller changes only when the
            # site's descriptors do (site_fds' generation).
            g, fds = bridge.site_fds()
            if g != gen or g < 0:
                if fds != site:
                    for fd, _ in site:
                        if fd not in (wake_fd, stdin_fd):
                            poller.unregister(fd)
                    for fd, events in fds:
                        if fd not in (wake_fd, stdin_fd):
                            poller.register(fd, events)
                    site = fds
                gen = g
            bridge.node_lock.release()
            try:
                ready = poller.poll(LOOP_WAIT_MS)
            finally:
                bridge.node_lock.acquire()
            woken = False
            for fd, _ in ready:
                if fd == wake_fd:
                    woken = True
                elif fd == stdin_fd and stdin_open:
                    line = sys.stdin.readline()
                    if not line:
                        stdin_open = False
                        poller.unregister(stdin_fd)
                    elif line.strip() == "quit":
                        end = 0.0
                    elif line.strip() == "stats":
                        _emit(out, _stats(node, bridge))
            bridge.turn(woken=woken)
            bridge.counters["loop_turns"] += 1
            t = time.monotonic()
            if t >= next_housekeeping:  # notices, deliveries to the bridge entity, service hooks
                node.service()
                next_housekeeping = t + HOUSEKEEPING_S
            while bridge.events:
                _emit(out, bridge.events.popleft())
            if next_stats is not None and t >= next_stats:
                _emit(out, _stats(node, bridge))
                next_stats += args.stats_s
            if end is not None and t >= end:
                break
        _emit(out, {**_stats(node, bridge), "final": True})
        return 0
    finally:
        if bridge is not None:
            bridge.rx_in_callback = False
            bridge.close()
        node.close()
        if session is not None:
            session.close()
        if bridge is not None and bridge.node_lock.locked():
            bridge.node_lock.release()


def set_timer_slack(ns: int) -> bool:
    """The calling thread's timer slack (prctl PR_SET_TIMERSLACK), which the drain's gaps sleep by: with Linux's
    default 50 us a 20 us ppoll() took 87 us at p50 on a loaded 2-core machine (36 us with 1 us), and a lone
    frame waits one gap in gwA. 0 leaves the system's. Only this thread: Zenoh's own threads are not touched.
    Returns whether it was set."""
    if ns <= 0:
        return False
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(29, ctypes.c_ulong(ns), 0, 0, 0) == 0  # PR_SET_TIMERSLACK
    except (OSError, AttributeError):  # not Linux/glibc: the gaps keep the system's slack
        return False


def _stats(node: Any, bridge: ZenohBridge) -> dict[str, Any]:
    c = node.counters()
    return {"event": "stats", "node": {k: c[k] for k in ("originated", "forwarded", "delivered")} | {"drops": c["drops"]},
            "links": {name: {k: v[k] for k in ("frames_in", "frames_out", "drops")}
                      for name, v in node.link_counters().items()},
            "zenoh": bridge.stats()}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="uavbus bridge zenoh",
                                description="carry uavbus frames between sites through Zenoh (docs/bridges.md)")
    p.add_argument("--config", required=True, help="node configuration: entities, ports, security")
    p.add_argument("--node", help="the node of the configuration this bridge runs (default: its \"hosts\")")
    p.add_argument("--catalogue", required=True, help="catalogue JSON (names the directories in the keys)")
    p.add_argument("--link", default="zenoh", help="the bridge entity's link carried by Zenoh (default zenoh)")
    p.add_argument("--mode", choices=("peer", "router", "client"), default="peer", help="Zenoh session mode")
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT", help="e.g. tcp/127.0.0.1:7447")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT", help="e.g. tcp/127.0.0.1:7447")
    p.add_argument("--prefix", help="key prefix (default uavbus/<system>)")
    p.add_argument("--flow", action="append", metavar="DEST[/SOURCE[/DIRECTORY]]",
                   help="receive only these flows ('*' = any); default: everything for this site's entities")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--express", action="store_true",
                     help="Zenoh sends each sample at once, never in its own transmission batches (about ten "
                          "times the CPU per sample, docs/bridges.md)")
    how.add_argument("--batch", action="store_true",
                     help="Zenoh may put several samples in one transmission batch (the default; kept for scripts)")
    p.add_argument("--batch-bytes", type=int, default=BATCH_BYTES, metavar="N",
                   help=f"largest sample payload: consecutive frames of one key share a sample up to N bytes "
                        f"(default {BATCH_BYTES})")
    p.add_argument("--batch-idle-us", type=int, default=BATCH_IDLE_US, metavar="US",
                   help=f"a batch leaves when the site's sockets had nothing new for US microseconds "
                        f"(default {BATCH_IDLE_US}; 0: as soon as they are empty)")
    p.add_argument("--batch-age-us", type=int, default=BATCH_AGE_US, metavar="US",
                   help=f"...or US microseconds after its turn began, however busy the site (default {BATCH_AGE_US})")
    p.add_argument("--sample-thread", choices=("zenoh", "python"), default="zenoh",
                   help="where received samples go to the router: on Zenoh's network thread (the default; "
                        "zenoh-python's unstable indirect=False) or on a Python thread Zenoh wakes for each one")
    p.add_argument("--timer-slack-ns", type=int, default=TIMER_SLACK_NS, metavar="NS",
                   help=f"the loop thread's timer slack, which its idle gaps sleep by (default {TIMER_SLACK_NS}; "
                        "0: the system's, 50000 on Linux)")
    p.add_argument("--stats-s", type=float, default=0.0, help="print stats every S seconds (0: on request)")
    p.add_argument("--duration-s", type=float, default=0.0, help="stop after S seconds (0: run until quit)")
    return p


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: uavbus bridge zenoh ...   (uavbus bridge zenoh --help)\n\n"
              "  zenoh   carry uavbus frames between sites through Zenoh sessions\n\n"
              "The MAVLink bridge is the C program uavbus_mavbridge (docs/bridges.md).")
        return 0 if argv else 2
    if argv[0] != "zenoh":
        print(f"uavbus bridge: unknown bridge '{argv[0]}' (available: zenoh; the MAVLink bridge is the "
              "program uavbus_mavbridge)", file=sys.stderr)
        return 2
    args = build_parser().parse_args(argv[1:])
    try:
        return run(args)
    except (BridgeError, ConfigError, UbError, OSError) as exc:
        msg = f"uavbus bridge zenoh: {exc}"
        print(msg, file=sys.stderr)
        _emit(sys.stdout, {"event": "error", "message": msg})
        return 2
