"""Rates, latencies and the demo's summary table (demo-out/summary.json).

A `StreamMeter` collects, for one data stream (content, source -> destination), the receive time and the
**data age** of every DATA that arrived: `now - stamp` on one clock, where the C node writes
CLOCK_MONOTONIC into the directory's timeTag `time` when it updates the value, and the receiver compares
with `time.monotonic()` -- the same clock on one machine (Linux: both are CLOCK_MONOTONIC). Data age is
transport latency plus how stale the value already was when it was sent (up to one update period).
**Transport latency** -- from the source node's send of that very frame to its arrival -- comes from
matching (source, sequence) between the source's transmit log and the receiver (`transport_latencies`).

Drops are split in two: **duplicates** on the links of a redundant pair (a 0x11 mask sends every frame on
both links, so every second copy is dropped as `duplicate`: expected) and everything else (losses).

The achieved rate and the latency percentiles are measured over a window in which the stream is expected to flow (e.g. after the
subscription became active and before a planned outage), as (messages - 1) / (last - first): it does
not depend on when the window was opened.

`rate_hz` places each message at its **receive** instant: the harness's, taken when its poll loop handed the
message over. A harness that stalled (its process descheduled, a garbage-collection pause: the tap and the
null-modem relays are threads of the same process, so the frames wait in socket and pty buffers meanwhile)
delivers a backlog in one burst; a stall across the start of a window puts frames sent before it inside
(a 320 ms stall read a 50 Hz stream as 55.5 Hz). `sent_rate_hz` places each message at its **source's**
instant instead -- the timeTag the source stamped, on the same clock -- so it counts what the source sent in
the window and reached the receiver, late or not: a late frame is neither extra nor missing, while a
message delivered twice still counts twice and a silenced source still reads 0.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["StreamMeter", "SummaryRow", "percentile", "render_table", "write_summary", "largest_gap",
           "split_duplicates", "transport_latencies"]


def percentile(values: Iterable[float], q: float) -> float | None:
    """The q-th percentile (0..100) by linear interpolation between closest ranks; None when empty."""
    xs = sorted(values)
    if not xs:
        return None
    if len(xs) == 1:
        return xs[0]
    pos = (len(xs) - 1) * q / 100.0
    lo, hi = math.floor(pos), math.ceil(pos)
    return xs[lo] + (xs[hi] - xs[lo]) * (pos - lo)


def largest_gap(times: list[float]) -> tuple[float, float]:
    """(start, length) of the longest interval between consecutive times (seconds); (0, 0) if < 2."""
    best = (0.0, 0.0)
    for a, b in zip(times, times[1:]):
        if b - a > best[1]:
            best = (a, b - a)
    return best


@dataclass
class StreamMeter:
    name: str
    source: str
    destination: str
    times: list[float] = field(default_factory=list)       # receive time, seconds (monotonic)
    latencies_ms: list[float] = field(default_factory=list)
    latency_times: list[float] = field(default_factory=list)  # receive time of each latency sample
    values: list[dict[str, Any]] = field(default_factory=list)  # optional: decoded values for plots
    stamps: list[float] = field(default_factory=list)        # the source's timeTag of each stamped message, s
    unstamped: int = 0                                        # messages that carried no timeTag

    def add(self, t: float, latency_ms: float | None = None, value: dict[str, Any] | None = None,
            stamp: float | None = None) -> None:
        """One message received at `t`; `stamp`: when its source stamped it (its timeTag, same clock)."""
        self.times.append(t)
        if latency_ms is not None:
            self.latencies_ms.append(latency_ms)
            self.latency_times.append(t)
        if value is not None:
            self.values.append(value)
        if stamp is None:
            self.unstamped += 1
        else:
            self.stamps.append(stamp)

    def window(self, t0: float | None = None, t1: float | None = None) -> list[float]:
        return [t for t in self.times if (t0 is None or t >= t0) and (t1 is None or t <= t1)]

    def rate_hz(self, t0: float | None = None, t1: float | None = None) -> float:
        ts = self.window(t0, t1)
        if len(ts) < 2 or ts[-1] <= ts[0]:
            return 0.0
        return (len(ts) - 1) / (ts[-1] - ts[0])

    def count(self, t0: float | None = None, t1: float | None = None) -> int:
        return len(self.window(t0, t1))

    def sent_rate_hz(self, t0: float, t1: float) -> float:
        """The rate of the messages the source stamped in [t0, t1] that arrived (whenever: read it once they
        had time to), as (messages - 1) / (last stamp - first stamp). Every arrival counts, so a message
        delivered twice counts twice. Raises ValueError for a stream whose messages carry no timeTag (the
        source's instant is unknown: `rate_hz` is all there is)."""
        if self.unstamped and not self.stamps:
            raise ValueError(f"{self.name} from {self.source}: no timeTag in its {self.unstamped} messages; "
                             "the source's send times are unknown (use rate_hz)")
        ts = sorted(s for s in self.stamps if t0 <= s <= t1)
        if len(ts) < 2 or ts[-1] <= ts[0]:
            return 0.0
        return (len(ts) - 1) / (ts[-1] - ts[0])

    def latencies(self, t0: float | None = None, t1: float | None = None) -> list[float]:
        return [lat for t, lat in zip(self.latency_times, self.latencies_ms)
                if (t0 is None or t >= t0) and (t1 is None or t <= t1)]


def transport_latencies(received: Iterable[tuple[str, int, float]], sent: dict[tuple[str, int], float],
                        ) -> list[float]:
    """Transport latency (ms) of each received (source, seq, receive time in ms) whose send time the
    source's transmit log holds (`sent`: (source, seq) -> first transmit time in ms)."""
    out = []
    for source, seq, t_rx in received:
        t_tx = sent.get((source, seq))
        if t_tx is not None:
            out.append(t_rx - t_tx)
    return out


def split_duplicates(dropped: dict[str, dict[str, int]], redundant: Iterable[str],
                     ) -> tuple[dict[str, int], dict[str, dict[str, int]]]:
    """(expected duplicates per link of a redundant pair, every other drop per link and reason)."""
    pair = set(redundant)
    dups: dict[str, int] = {}
    rest: dict[str, dict[str, int]] = {}
    for link, reasons in dropped.items():
        for reason, n in reasons.items():
            if reason == "duplicate" and link in pair:
                dups[link] = dups.get(link, 0) + n
            elif n:
                rest.setdefault(link, {})[reason] = n
    return dups, rest


@dataclass
class SummaryRow:
    name: str
    source: str
    destination: str
    hops: int
    requested_hz: float
    achieved_hz: float
    transport_p50_ms: float | None   # send -> receive of the same frame
    transport_p99_ms: float | None
    age_p50_ms: float | None         # receive - the value's timeTag: transport + staleness
    age_p99_ms: float | None
    delivered: int
    duplicates: dict[str, int]           # link of a redundant pair -> copies dropped there (expected)
    dropped: dict[str, dict[str, int]]   # link -> reason -> frames (losses: everything but those copies)

    @classmethod
    def from_meter(cls, m: StreamMeter, *, hops: int, requested_hz: float, t0: float | None = None,
                   t1: float | None = None, dropped: dict[str, dict[str, int]] | None = None,
                   transport_ms: list[float] | None = None, redundant: Iterable[str] = ()) -> SummaryRow:
        age = m.latencies(t0, t1)
        tr = transport_ms or []
        dups, rest = split_duplicates(dropped or {}, redundant)
        return cls(m.name, m.source, m.destination, hops, requested_hz, round(m.rate_hz(t0, t1), 2),
                   _r(percentile(tr, 50)), _r(percentile(tr, 99)), _r(percentile(age, 50)), _r(percentile(age, 99)),
                   len(m.times), dups, rest)

    def rate_ok(self, tolerance: float = 0.10) -> bool:
        return abs(self.achieved_hz - self.requested_hz) <= tolerance * self.requested_hz

    def as_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def _r(x: float | None) -> float | None:
    return None if x is None else round(x, 3)


def _fmt_drops(d: dict[str, dict[str, int]]) -> str:
    parts = [f"{link}:{reason}={n}" for link, reasons in sorted(d.items())
             for reason, n in sorted(reasons.items()) if n]
    return ", ".join(parts) if parts else "none"


def _ms(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f}"


def render_table(rows: list[SummaryRow]) -> str:
    """The summary as aligned text, one line per row: transport latency and data age apart, expected
    duplicates (redundant links) apart from losses."""
    head = ["content", "source -> destination", "hops", "req Hz", "got Hz", "transport p50/p99 ms",
            "data age p50/p99 ms", "delivered", "dups (redundant links)", "lost/dropped (link:reason=frames)"]
    body = [[r.name, f"{r.source} -> {r.destination}", str(r.hops), f"{r.requested_hz:g}", f"{r.achieved_hz:.1f}",
             f"{_ms(r.transport_p50_ms)} / {_ms(r.transport_p99_ms)}", f"{_ms(r.age_p50_ms)} / {_ms(r.age_p99_ms)}",
             str(r.delivered), str(sum(r.duplicates.values())), _fmt_drops(r.dropped)] for r in rows]
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(line, widths)).rstrip() for line in [head, *body]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def write_summary(path: str | Path, rows: list[SummaryRow], extra: dict[str, Any] | None = None) -> None:
    doc: dict[str, Any] = {"rows": [r.as_dict() for r in rows]}
    if extra:
        doc.update(extra)
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(doc, indent=2) + "\n")
