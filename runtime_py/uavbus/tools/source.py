"""Where the live tools get frames: a log (optionally followed while it grows) or a live node.

    --log FILE [--follow]                           a log, e.g. the GCS's while it records
    --config X --node N --catalogue C [--port NAME=SPEC]... [--subscribe CONTENT@SOURCE/MS]...

A live node is a uavbus.Node (the C router) hosting the config's entities for node N; the tools
see every frame it receives through its frame tap, so nothing is parsed or routed in Python.
`--subscribe` makes the first hosted entity subscribe, so data flows to the tool by itself.
"""

from __future__ import annotations

import argparse
import collections
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from uavbus.logfile import LogReader, follow
from uavbus.tools.common import Contents, Seen, load_catalogue, positive


def add_node_args(p: argparse.ArgumentParser, required: bool = False) -> None:
    p.add_argument("--config", required=required, help="node configuration (entity table), e.g. table2.json")
    p.add_argument("--node", required=required, help="node of the config's \"nodes\" to host")
    p.add_argument("--catalogue", default=os.environ.get("UAVBUS_CATALOGUE"),
                   help="<name>.catalogue.json (default: $UAVBUS_CATALOGUE)")
    p.add_argument("--port", action="append", default=[], metavar="NAME=SPEC",
                   help="bind a link to a transport, e.g. gcsPortDatalink1=udp:bind=127.0.0.1:0,peer=127.0.0.1:5001 "
                        "(docs/config-format.md#ports)")
    p.add_argument("--subscribe", action="append", default=[], metavar="CONTENT@SOURCE/MS",
                   help="subscribe the first hosted entity, e.g. imuOut@fcs20/20")
    p.add_argument("--duration", type=positive(float), default=None, help="stop after this many seconds")


def add_source_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--log", help="read frames from this log")
    p.add_argument("--follow", action="store_true", help="with --log: keep reading as the log grows")
    add_node_args(p)
    p.add_argument("--count", type=positive(int), default=None, help="stop after this many matching messages")


def parse_subscribe(text: str) -> tuple[str, str, int]:
    content, at, rest = text.partition("@")
    source, slash, period = rest.partition("/")
    if not (at and slash and content and source and period.isdigit() and int(period) > 0):
        raise SystemExit(f"--subscribe {text}: expected CONTENT@SOURCE/PERIOD_MS, e.g. imuOut@fcs20/20")
    return content, source, int(period)


@dataclass
class NodeSession:
    """A live tool node and what it has seen (filled by the tap, drained by `frames()`)."""

    node: Any
    config: Any
    contents: Contents
    seen: collections.deque[Seen] = field(default_factory=collections.deque)
    frames_seen: int = 0  # every frame the tap saw (received and sent), for "nothing seen" hints

    def close(self) -> None:
        self.node.close()


def log_unix_ms(header: Any, t_ms: int) -> float | None:
    """Wall-clock time of a log record: the header ties the writer's clock to unix time at the start."""
    start_unix = getattr(header, "start_unix_ms", 0)
    if not start_unix:
        return None
    return float(start_unix + t_ms - getattr(header, "start_t_ms", 0))


def monotonic_ms() -> int:
    return time.monotonic_ns() // 1_000_000


def open_node(args: argparse.Namespace, clock: Callable[[], int] | None = None) -> NodeSession:
    """Starts the tool's node from --config/--node/--catalogue/--port/--subscribe (SystemExit with a
    message saying what to do on a bad argument)."""
    from uavbus import Node
    from uavbus.config import load_config

    if not (args.config and args.node):
        raise SystemExit("a live source needs --config FILE --node NAME (or read a log with --log FILE)")
    if not args.catalogue:
        raise SystemExit("a live source needs --catalogue NAME.catalogue.json (or set UAVBUS_CATALOGUE)")
    config = load_config(args.config, args.node)  # ConfigError: one line, status 3 (uavbus cli)
    cat = load_catalogue(path=args.catalogue)
    node = Node(cat, config=config, node=args.node, clock=clock or monotonic_ms)
    session = NodeSession(node=node, config=config, contents=Contents(cat))
    try:
        node.open_ports_from_config()
        for item in args.port:
            name, eq, spec = item.partition("=")
            if not eq:
                raise SystemExit(f"--port {item}: expected NAME=SPEC, e.g. gcsPortDatalink1=udp:peer=127.0.0.1:5001")
            node.open_port(name, spec)
        install_tap(session)
        for text in args.subscribe:
            content, source, period = parse_subscribe(text)
            node.subscribe(config.hosts[0], content, source=source, period_ms=period)
    except BaseException:
        node.close()
        raise
    return session


def install_tap(session: NodeSession) -> None:
    """Puts every frame the node receives into `session.seen`: the C router's frame tap seen from
    Python (Node.on_frame), so the tools see every verified frame received on any link, forwarded
    ones included."""
    from uavbus._bindings.ub_frame import ub_frame_parse

    # The node clock is CLOCK_MONOTONIC ms (or an injected one): wall-clock time = t_ms + this offset.
    offset = time.time() * 1000.0 - session.node.now()

    def on_frame(link: str, direction: str, frame: bytes, t_ms: int) -> None:
        session.frames_seen += 1
        if direction == "rx":
            session.seen.append(Seen(t_ms=t_ms, link=link, dir=direction, header=ub_frame_parse(frame), frame=frame,
                                     unix_ms=t_ms + offset))

    session.node.on_frame(on_frame)


def run_node_for(session: NodeSession, seconds: float | None) -> None:
    """Drives the node's loop for `seconds` (0 or None: one turn)."""
    deadline = time.monotonic() + (seconds or 0.0)
    while True:
        session.node.poll(timeout=0.02)
        if time.monotonic() >= deadline:
            return


@dataclass
class Source:
    """An iterator of Seen frames plus the catalogue to decode them; `log` is set for a log source."""

    contents: Contents
    frames: Iterator[Seen]
    live: bool  # True for a followed log or a node: the tools print periodic updates
    log: LogReader | None = None
    session: NodeSession | None = None

    def close(self) -> None:
        if self.session is not None:
            self.session.close()


def open_source(args: argparse.Namespace, stop: Callable[[], bool]) -> Source:
    if args.log:
        # --catalogue (or $UAVBUS_CATALOGUE) decodes a log too, in place of its embedded catalogue: the way to
        # read a log whose header is damaged in both copies.
        catalogue = getattr(args, "catalogue", None)
        external = None
        if catalogue:
            try:
                external = open(catalogue, encoding="utf-8").read()  # noqa: SIM115 (read at once)
            except (OSError, UnicodeDecodeError) as exc:
                raise SystemExit(f"{catalogue}: cannot read the catalogue given with --catalogue: {exc}") from None
        if args.follow:
            header_box: list[Contents] = []

            def frames() -> Iterator[Seen]:
                headers: list[Any] = []

                def on_header(h: Any) -> None:
                    headers.append(h)
                    header_box.append(Contents(load_catalogue(h.catalogue_json, f"{args.log}: {h.catalogue_origin}")))

                for rec in follow(args.log, stop=stop, on_header=on_header, catalogue_json=external,
                                  catalogue_origin=f"--catalogue {catalogue}"):
                    yield Seen(t_ms=rec.t_ms, link=rec.link, dir=rec.dir, header=rec.header, frame=rec.frame,
                               unix_ms=log_unix_ms(headers[0], rec.t_ms))

            # The catalogue is in the header, which may not exist yet: read lazily through a proxy.
            return Source(contents=_LazyContents(header_box), frames=frames(), live=True)
        log = LogReader(args.log, catalogue_json=external, catalogue_origin=f"--catalogue {catalogue}")
        seen = (Seen(t_ms=r.t_ms, link=r.link, dir=r.dir, header=r.header, frame=r.frame,
                     unix_ms=log_unix_ms(log.header, r.t_ms)) for r in log.records())
        contents = Contents(load_catalogue(log.header.catalogue_json, f"{args.log}: {log.header.catalogue_origin}"))
        return Source(contents=contents, frames=seen, live=False, log=log)
    session = open_node(args)

    def node_frames() -> Iterator[Seen]:
        while not stop():
            session.node.poll(timeout=0.02)
            while session.seen:
                yield session.seen.popleft()

    return Source(contents=session.contents, frames=node_frames(), live=True, session=session)


class _LazyContents(Contents):
    """Contents whose catalogue arrives with the followed log's header."""

    def __init__(self, box: list[Contents]) -> None:  # noqa: D107 (no super().__init__: delegated)
        self._box = box

    def __getattr__(self, name: str) -> Any:
        if not self._box:
            raise RuntimeError("log header not read yet")
        return getattr(self._box[0], name)

    def name(self, h: Any) -> str:
        return self._box[0].name(h)

    def known(self, name: str) -> bool:
        return self._box[0].known(name) if self._box else True  # checked once frames arrive

    def decode(self, seen: Seen) -> dict[str, Any] | None:
        return self._box[0].decode(seen)
