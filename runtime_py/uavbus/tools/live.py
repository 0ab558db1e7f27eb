"""`uavbus spy`, `echo NAME`, `hz NAME`, `bw [NAME]`: live views decoded from the catalogue.

Sources (see uavbus.tools.source): `--log FILE [--follow]` or a live node
`--config X --node N --catalogue C [--port NAME=SPEC]... [--subscribe CONTENT@SOURCE/MS]...`.
Rates use the frames' own times: the log's t_ms, or the node clock when live.

A message is one (source, sequence number). A frame that arrives again with the same pair -- the
copy a 0x11 link mask sends over the second link, or a retransmission -- is a duplicate: counted and
shown apart, never in a rate or a message count.

    spy   every directory seen: name, source, messages, duplicates, rate, last values
    echo  one JSON line per message of NAME (duplicates left out unless --all); --field picks members
    hz    rate of NAME per source over the last --window messages
    bw    bytes per second on the links, per content and source and per link (copies included)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import deque
from collections.abc import Callable
from typing import IO, Any

from uavbus.tools.common import (
    ArgumentParser, Contents, FieldPathError, positive, Seen, Stream, human_duration, iso_time, jsonable, select_field, short_value,
)
from uavbus.tools.source import Source, add_source_args, open_source
from uavbus.tools.tables import render_grid

__all__ = ["Stream", "bw_main", "echo_main", "hz_main", "spy_main"]


class Tool:
    """Shared loop: open the source, feed every DATA frame to `on_frame`, print every interval."""

    def __init__(self, args: argparse.Namespace, out: IO[str], clock: Callable[[], float] = time.monotonic) -> None:
        self.args, self.out, self.clock = args, out, clock
        self.matched = 0
        self.frames = 0       # every frame seen, DATA or not
        self.admin_frames = 0
        self.deadline = clock() + args.duration if args.duration else None
        self.source: Source | None = None

    def stopped(self) -> bool:
        if self.args.count is not None and self.matched >= self.args.count:
            return True
        return self.deadline is not None and self.clock() >= self.deadline

    def run(self) -> int:
        src = self.source = open_source(self.args, self.stopped)
        if self.args.duration:  # --duration counts from when the tool listens, not from before its node opened
            self.deadline = self.clock() + self.args.duration
        self.opened(src)
        name = getattr(self.args, "name", None)
        if name and not src.contents.known(name):
            src.close()
            raise SystemExit(f"{name}: no such content in catalogue '{src.contents.catalogue.name}' "
                             "(give a directory instance name, e.g. gpsOut)")
        next_print = self.clock() + self.args.interval
        try:
            for seen in src.frames:
                self.frames += 1
                if seen.is_data:
                    self.on_frame(src.contents, seen)
                else:
                    self.admin_frames += 1
                if src.live and self.clock() >= next_print:
                    self.report(src.contents, final=False)
                    next_print = self.clock() + self.args.interval
                if self.stopped():
                    break
        except KeyboardInterrupt:
            pass
        try:
            self.report(src.contents, final=True)  # before closing: a hint may describe the open ports
        finally:
            src.close()
        if src.log is not None and src.log.stats.ignored_bytes:
            print(f"{src.log.path}: ignored {src.log.stats.ignored_bytes} bytes: "
                  f"{src.log.stats.ignored_reason}", file=sys.stderr)
        return 0

    def opened(self, src: Source) -> None:
        """Called once the source is open, before the first frame."""

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        raise NotImplementedError

    def report(self, contents: Contents, final: bool) -> None:
        pass

    def nothing_seen_hint(self, what: str) -> str:
        """What to do when no DATA arrived: depends on where the frames come from."""
        src = self.source
        if src is not None and src.log is not None or getattr(self.args, "log", None):
            return (f"{what}: the log holds {self.frames} frames, none of them DATA "
                    f"({self.admin_frames} administration frames); it recorded nothing to show")
        session = src.session if src is not None else None
        lines = [f"{what}: no DATA received yet ({self.frames} frames in all, {self.admin_frames} of them "
                 "administration). A node receives only what is addressed to the entities it hosts:"]
        if not getattr(self.args, "subscribe", None):
            lines.append("  - subscribe to something, e.g. --subscribe gpsOut@rmax1ob1/100 (CONTENT@SOURCE/PERIOD_MS),"
                         " or have a GCS publish to this node")
        if session is not None:
            for link, c in session.node.link_counters().items():
                port = c.get("port")
                if port is None:
                    continue
                udp = port.get("udp") or {}
                note = f"  - port {link} ({port.get('spec')}): {c.get('frames_in', 0)} frames received"
                if udp.get("foreign"):
                    note += (f", {udp['foreign']} datagrams refused from other addresses (not its peer; "
                             "open it with accept=any to take them)")
                if udp and not udp.get("peers"):
                    note += ", no peer known yet: nothing can be sent (a subscription cannot go out)"
                lines.append(note)
            if not any(c.get("port") for c in session.node.link_counters().values()):
                lines.append("  - no port is open: give --port LINK=SPEC (or a \"ports\" section in the config)")
        lines.append("  (docs/python.md, docs/config-format.md#ports)")
        return "\n".join(lines)


def _streams_key(contents: Contents, seen: Seen) -> tuple[str, str]:
    return contents.name(seen.header), seen.source


class Spy(Tool):
    def __init__(self, *a: Any, **kw: Any) -> None:
        super().__init__(*a, **kw)
        self.streams: dict[tuple[str, str], Stream] = {}

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        key = _streams_key(contents, seen)
        st = self.streams.get(key)
        if st is None:
            st = self.streams[key] = Stream(*key)
        new = st.add(seen.t_ms, seen.header.seq, None, len(seen.frame), seen.unix_ms)
        if new:
            value = contents.decode(seen)
            if value is not None:
                st.last = value if self.args.numeric else contents.labelled(seen, value)
        self.matched += 1

    def report(self, contents: Contents, final: bool) -> None:
        rows = []
        for (name, source), st in sorted(self.streams.items()):
            rate = st.rate()
            rows.append([name, source, st.unique, st.duplicates, f"{rate:.2f}" if rate is not None else "-",
                         st.last_seq, short_value(st.last, self.args.width) if st.last is not None else
                         "(not decodable)"])
        print(f"-- {len(rows)} directories seen --", file=self.out)
        if rows:
            print("\n".join(render_grid(["name", "source", "msgs", "dups", "Hz", "seq", "last value"], rows)),
                  file=self.out)
        else:
            print(self.nothing_seen_hint("spy"), file=self.out)
        self.out.flush()


class Echo(Tool):
    def __init__(self, *a: Any, **kw: Any) -> None:
        super().__init__(*a, **kw)
        self.seen_seqs: dict[str, Stream] = {}
        self.duplicates = 0
        self._unit_cache: dict[str, str] | None = None

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        if contents.name(seen.header) != self.args.name:
            return
        if self.args.source and seen.source != self.args.source:
            return
        st = self.seen_seqs.setdefault(seen.source, Stream(self.args.name, seen.source))
        new = st.add(seen.t_ms, seen.header.seq, None)
        if not new:
            self.duplicates += 1
            if not self.args.all:
                return
        value = contents.decode(seen)
        if value is not None and not self.args.numeric:
            value = contents.labelled(seen, value)
        if value is not None and self.args.field:
            try:
                picked = {f: select_field(value, f) for f in self.args.field}
            except FieldPathError as exc:
                raise SystemExit(f"uavbus echo: {exc}") from None
            value = picked[self.args.field[0]] if len(picked) == 1 else picked
        line: dict[str, Any] = {"t_ms": seen.t_ms, "time": iso_time(seen.unix_ms), "name": self.args.name,
                                "source": seen.source, "seq": seen.header.seq, "link": seen.link,
                                "value": jsonable(value) if value is not None else None}
        units = self._units(contents)
        if units:
            line["units"] = units  # from the headers' comments (docs/catalogue.md#units)
        if not new:
            line["duplicate"] = True
        print(json.dumps(line, separators=(",", ":")), file=self.out)
        self.out.flush()
        if new:
            self.matched += 1

    def _units(self, contents: Contents) -> dict[str, str]:
        """{field path: unit} of what is printed: the --field members, or every member that has one."""
        if self._unit_cache is None:
            import re

            from uavbus.units import units_of

            inst = contents.catalogue.find(self.args.name)
            known = {k: v["unit"] for k, v in units_of(contents.catalogue, inst.type).items() if v.get("unit")} \
                if inst is not None else {}
            if self.args.field:
                known = {f: known[re.sub(r"\[\d+\]", "", f)] for f in self.args.field
                         if re.sub(r"\[\d+\]", "", f) in known}
            self._unit_cache = known
        return self._unit_cache

    def report(self, contents: Contents, final: bool) -> None:
        if final and self.matched == 0:
            print(self.nothing_seen_hint(f"echo {self.args.name}") if self.frames == 0 or not self.seen_seqs
                  else f"echo {self.args.name}: no message passed the filters", file=sys.stderr)


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
        if st.add(seen.t_ms, seen.header.seq, None, len(seen.frame)):
            self.matched += 1

    def report(self, contents: Contents, final: bool) -> None:
        if not self.streams:
            print(f"{self.args.name}: no messages seen", file=self.out)
            if final:
                print(self.nothing_seen_hint(f"hz {self.args.name}"), file=self.out)
        for source, st in sorted(self.streams.items()):
            rate, gaps = st.rate(), st.gaps()
            text = f"{rate:.2f} Hz" if rate is not None else "- Hz"
            gap = f", gap min {gaps[0]} ms max {gaps[1]} ms" if gaps else ""
            dups = (f"; {st.duplicates} duplicates (copies of a message, e.g. over redundant links: not in the "
                    "rate)" if st.duplicates else "; no duplicates")
            print(f"{self.args.name} from {source}: {text} over {len(st.times)} messages{gap} "
                  f"({st.unique} messages in all{dups})", file=self.out)
        self.out.flush()


class Bw(Tool):
    """Bytes per second: what the links carry (every frame, copies included), per content and source,
    and per link. Live: over the last --window seconds; a log: over its whole span."""

    def __init__(self, *a: Any, **kw: Any) -> None:
        super().__init__(*a, **kw)
        self.by_content: dict[tuple[str, str], deque[tuple[int, int, bool]]] = {}
        self.by_link: dict[str, deque[tuple[int, int, bool]]] = {}
        self.streams: dict[tuple[str, str], Stream] = {}
        self.first_ms: int | None = None
        self.last_ms = 0
        self.listen_ms: float | None = None  # the node clock when a live node started listening

    def on_frame(self, contents: Contents, seen: Seen) -> None:
        name = contents.name(seen.header)
        if self.args.name and name != self.args.name:
            return
        key = (name, seen.source)
        st = self.streams.setdefault(key, Stream(*key))
        new = st.add(seen.t_ms, seen.header.seq, None, len(seen.frame))
        sample = (seen.t_ms, len(seen.frame), new)
        self.by_content.setdefault(key, deque()).append(sample)
        self.by_link.setdefault(seen.link, deque()).append(sample)
        self.first_ms = seen.t_ms if self.first_ms is None else self.first_ms
        self.last_ms = max(self.last_ms, seen.t_ms)
        self.matched += 1

    def opened(self, src: Source) -> None:
        if src.session is not None:
            self.listen_ms = float(src.session.node.now())

    def _now_ms(self) -> float:
        session = self.source.session if self.source is not None else None
        return float(session.node.now()) if session is not None else float(self.last_ms)

    def _span_ms(self) -> float:
        """The time the rates divide by: what was actually observed. Live, the window once it is full, and
        before that the time since the tool started listening (a 3 s run at 10 msg/s shows 10, not 30
        messages over a 5 s window); a log: its span."""
        if self.source is not None and self.source.live:
            now = self._now_ms()
            start = self.listen_ms if self.listen_ms is not None else float(self.first_ms or now)
            return max(min(self.args.window * 1000.0, now - start), 1.0)
        return float(self.last_ms - (self.first_ms or 0)) or 1.0

    def _trim(self) -> None:
        if self.source is None or not self.source.live:
            return
        horizon = self._now_ms() - self.args.window * 1000.0
        for q in (*self.by_content.values(), *self.by_link.values()):
            while q and q[0][0] < horizon:
                q.popleft()

    def report(self, contents: Contents, final: bool) -> None:
        self._trim()
        span = self._span_ms() / 1000.0
        if not self.by_content:
            print(self.nothing_seen_hint("bw"), file=self.out)
            self.out.flush()
            return

        def row(label: list[Any], q: deque[tuple[int, int, bool]]) -> list[Any]:
            total = sum(size for _, size, _ in q)
            unique = sum(1 for _, _, new in q if new)
            return [*label, f"{unique / span:.1f}", f"{(len(q) - unique) / span:.1f}", _rate_text(total / span),
                    f"{total / len(q):.0f}" if q else "-"]

        print(f"-- bandwidth over {human_duration(span * 1000)} (DATA frames received, copies included) --",
              file=self.out)
        rows = [row([n, s], q) for (n, s), q in sorted(self.by_content.items()) if q]
        print("\n".join(render_grid(["name", "source", "msgs/s", "dups/s", "bytes/s", "mean B"], rows)), file=self.out)
        links = [row([link], q) for link, q in sorted(self.by_link.items()) if q]
        print("\n".join(render_grid(["link", "msgs/s", "dups/s", "bytes/s", "mean B"], links)), file=self.out)
        total = sum(size for q in self.by_link.values() for _, size, _ in q)
        print(f"total: {_rate_text(total / span)}", file=self.out)
        self.out.flush()


def _rate_text(bytes_per_s: float) -> str:
    for unit, scale in (("MB/s", 1e6), ("kB/s", 1e3)):
        if bytes_per_s >= scale:
            return f"{bytes_per_s / scale:.2f} {unit}"
    return f"{bytes_per_s:.0f} B/s"


def _parser(prog: str, doc: str, named: bool | None) -> argparse.ArgumentParser:
    p = ArgumentParser(prog=prog, description=doc)
    if named is True:
        p.add_argument("name", help="content (directory instance) name, e.g. gpsOut")
    elif named is None:
        p.add_argument("name", nargs="?", help="only this content (directory instance), e.g. gpsOut")
    if named:
        p.add_argument("--source", help="only messages from this entity")
    add_source_args(p)
    p.add_argument("--interval", type=positive(float), default=1.0, help="seconds between reports when live (default 1)")
    return p


def _numeric(p: argparse.ArgumentParser) -> None:
    p.add_argument("--numeric", action="store_true",
                   help="enum members as numbers (default: their constants' names, from the catalogue)")


def spy_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus spy", "every directory seen, with name, source, messages, duplicates, rate and last values",
                named=False)
    p.add_argument("--width", type=positive(int), default=100, help="cut last values at this many characters")
    _numeric(p)
    return Spy(p.parse_args(argv), out or sys.stdout).run()


def echo_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus echo", "the decoded values of one directory, one JSON line per message", named=True)
    p.add_argument("--field", action="append", metavar="PATH",
                   help="print only this member, e.g. velocityNed.x or motors[2].rpm (repeat for several)")
    p.add_argument("--all", action="store_true", help="also print duplicates (marked \"duplicate\": true)")
    _numeric(p)
    return Echo(p.parse_args(argv), out or sys.stdout).run()


def hz_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus hz", "the rate of one directory, per source (unique messages; duplicates apart)", named=True)
    p.add_argument("--window", type=positive(int), default=100, help="messages in the rate window (default 100)")
    return Hz(p.parse_args(argv), out or sys.stdout).run()


def bw_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus bw", "bytes per second on the links: per content and source, and per link", named=None)
    p.add_argument("--window", type=positive(float), default=5.0, help="live: seconds the rates are averaged over (default 5)")
    return Bw(p.parse_args(argv), out or sys.stdout).run()
