"""`uavbus spy`, `uavbus echo NAME`, `uavbus hz NAME`: live views decoded from the catalogue.

Sources (see uavbus.tools.source): `--log FILE [--follow]` or a live node
`--config X --node N --catalogue C [--port NAME=SPEC]... [--subscribe CONTENT@SOURCE/MS]...`.
Rates use the frames' own times: the log's t_ms, or the node clock when live.

    spy   every directory seen: name, source, count, rate, last values (table, every --interval s)
    echo  one JSON line per DATA frame of NAME: t_ms, source, seq, link, value
    hz    rate of NAME per source over the last --window frames (every --interval s, and at the end)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO, Any

from uavbus.tools.common import Contents, Seen, jsonable, short_value
from uavbus.tools.source import add_source_args, open_source
from uavbus.tools.tables import render_grid


@dataclass
class Stream:
    """What spy/hz keep per (content, source)."""

    name: str
    source: str
    count: int = 0
    times: deque[int] = field(default_factory=lambda: deque(maxlen=100))
    last: dict[str, Any] | None = None
    last_seq: int = 0

    def add(self, t_ms: int, seq: int, value: dict[str, Any] | None) -> None:
        self.count += 1
        self.times.append(t_ms)
        self.last_seq = seq
        if value is not None:
            self.last = value

    def rate(self) -> float | None:
        """Frames per second over the kept window (None with fewer than 2 frames or no time span)."""
        if len(self.times) < 2 or self.times[-1] == self.times[0]:
            return None
        return (len(self.times) - 1) * 1000.0 / (self.times[-1] - self.times[0])

    def gaps(self) -> tuple[int, int] | None:
        if len(self.times) < 2:
            return None
        d = [b - a for a, b in zip(self.times, list(self.times)[1:])]
        return min(d), max(d)


class Tool:
    """Shared loop: open the source, feed every DATA frame to `on_frame`, print every interval."""

    def __init__(self, args: argparse.Namespace, out: IO[str], clock: Callable[[], float] = time.monotonic) -> None:
        self.args, self.out, self.clock = args, out, clock
        self.matched = 0
        self.deadline = clock() + args.duration if args.duration else None

    def stopped(self) -> bool:
        if self.args.count is not None and self.matched >= self.args.count:
            return True
        return self.deadline is not None and self.clock() >= self.deadline

    def run(self) -> int:
        src = open_source(self.args, self.stopped)
        name = getattr(self.args, "name", None)
        if name and not src.contents.known(name):
            src.close()
            raise SystemExit(f"{name}: no such content in catalogue '{src.contents.catalogue.name}' "
                             "(give a directory instance name, e.g. gpsOut)")
        next_print = self.clock() + self.args.interval
        try:
            for seen in src.frames:
                if seen.is_data:
                    self.on_frame(src.contents, seen)
                if src.live and self.clock() >= next_print:
                    self.report(src.contents, final=False)
                    next_print = self.clock() + self.args.interval
                if self.stopped():
                    break
        except KeyboardInterrupt:
            pass
        finally:
            src.close()
        self.report(src.contents, final=True)
        if src.log is not None and src.log.stats.ignored_bytes:
            print(f"{src.log.path}: ignored the last {src.log.stats.ignored_bytes} bytes: "
                  f"{src.log.stats.ignored_reason}", file=sys.stderr)
        return 0

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        raise NotImplementedError

    def report(self, contents: Contents, final: bool) -> None:
        pass


class Spy(Tool):
    def __init__(self, *a: Any, **kw: Any) -> None:
        super().__init__(*a, **kw)
        self.streams: dict[tuple[str, str], Stream] = {}

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        name = contents.name(seen.header)
        key = (name, seen.source)
        st = self.streams.get(key)
        if st is None:
            st = self.streams[key] = Stream(name, seen.source)
        st.add(seen.t_ms, seen.header.seq, contents.decode(seen))
        self.matched += 1

    def report(self, contents: Contents, final: bool) -> None:
        rows = []
        for (name, source), st in sorted(self.streams.items()):
            rate = st.rate()
            rows.append([name, source, st.count, f"{rate:.2f}" if rate is not None else "-", st.last_seq,
                         short_value(st.last, self.args.width) if st.last is not None else "(not decodable)"])
        print(f"-- {len(rows)} directories seen --", file=self.out)
        print("\n".join(render_grid(["name", "source", "count", "Hz", "seq", "last value"], rows)), file=self.out)
        self.out.flush()


class Echo(Tool):
    def on_frame(self, contents: Contents, seen: Seen) -> None:
        if contents.name(seen.header) != self.args.name:
            return
        if self.args.source and seen.source != self.args.source:
            return
        value = contents.decode(seen)
        line = {"t_ms": seen.t_ms, "name": self.args.name, "source": seen.source, "seq": seen.header.seq,
                "link": seen.link, "value": jsonable(value) if value is not None else None}
        print(json.dumps(line, separators=(",", ":")), file=self.out)
        self.out.flush()
        self.matched += 1


class Hz(Tool):
    def __init__(self, *a: Any, **kw: Any) -> None:
        super().__init__(*a, **kw)
        self.streams: dict[str, Stream] = {}

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        if contents.name(seen.header) != self.args.name:
            return
        st = self.streams.get(seen.source)
        if st is None:
            st = self.streams[seen.source] = Stream(self.args.name, seen.source,
                                                    times=deque(maxlen=self.args.window))
        st.add(seen.t_ms, seen.header.seq, None)
        self.matched += 1

    def report(self, contents: Contents, final: bool) -> None:
        if not self.streams:
            print(f"{self.args.name}: no frames seen", file=self.out)
        for source, st in sorted(self.streams.items()):
            rate, gaps = st.rate(), st.gaps()
            text = f"{rate:.2f} Hz" if rate is not None else "- Hz"
            gap = f", gap min {gaps[0]} ms max {gaps[1]} ms" if gaps else ""
            print(f"{self.args.name} from {source}: {text} over {len(st.times)} frames{gap} "
                  f"({st.count} in all)", file=self.out)
        self.out.flush()


def _parser(prog: str, doc: str, named: bool) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=prog, description=doc)
    if named:
        p.add_argument("name", help="content (directory instance) name, e.g. gpsOut")
        p.add_argument("--source", help="only frames from this entity")
    add_source_args(p)
    p.add_argument("--interval", type=float, default=1.0, help="seconds between reports when live (default 1)")
    return p


def spy_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus spy", "every directory seen, with name, source, rate and last values", named=False)
    p.add_argument("--width", type=int, default=100, help="cut last values at this many characters")
    return Spy(p.parse_args(argv), out or sys.stdout).run()


def echo_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus echo", "the decoded values of one directory, one JSON line per frame", named=True)
    return Echo(p.parse_args(argv), out or sys.stdout).run()


def hz_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus hz", "the rate of one directory, per source", named=True)
    p.add_argument("--window", type=int, default=100, help="frames in the rate window (default 100)")
    return Hz(p.parse_args(argv), out or sys.stdout).run()
