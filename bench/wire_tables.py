"""Bench figure 9 (issue #15, the wire for real radios): bytes on the wire per message and messages per second
through a simulated 57,600-baud radio, uavbus full and compact beside MAVLink 2, unsigned and signed; then the
issue's five speed goals gathered from the other figures. Called by bench/tables.py with the raw directory."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Callable

MSGS = ("ATTITUDE", "GPS_RAW_INT", "HIGHRES_IMU")
FORMS = (("full", "uavbus full"), ("compact", "uavbus compact"), ("mavlink2", "MAVLink 2"),
         ("full_signed", "uavbus full, signed"), ("compact_signed", "uavbus compact, signed"),
         ("mavlink2_signed", "MAVLink 2, signed"))
# (goal row, the figure names in tables.py's goals list that measure it)
SPEED_GOALS = (("frame build <= 1/8 of MAVLink pack", ("frame build",)),
               ("3 hops in process >= 5 M msg/s", ("in-process, 3 hops",)),
               ("Python receive >= 4x pymavlink decode and >= 1x LCM decode", ("Python receive",)),
               ("Python publish >= 1x LCM encode", ("Python publish",)),
               ("loopback UDP, both ends on one core, >= 2 M msg/s", ("loopback UDP (same core)",)))

Goal = tuple[str, str, str, bool, str]


def render(raw: Path, w: Callable[[str], None], goals: list[Goal]) -> None:
    size: dict[tuple[str, str], int] = {}
    if (raw / "wire.txt").exists():
        for line in (raw / "wire.txt").read_text().splitlines():
            p = line.split("\t")
            if p[0] == "bytes":
                size[(p[1], p[2])] = int(p[3])
    rate: dict[tuple[str, str], float] = defaultdict(float)
    if (raw / "radio.txt").exists():
        for line in (raw / "radio.txt").read_text().splitlines():
            p = line.split("\t")
            if p[0] == "radio":
                form, msg = Path(p[1]).name.removesuffix(".frames").split("-", 1)
                rate[(form, msg)] = float(p[2])
    w("## 9. The wire for real radios (issue #15)")
    w("")
    if not size:
        w("TODO: the wire figure did not run.")
        w("")
        return
    w("bench/wire_bench.py: one message of each kind, every field non-zero (figure 4's values), made by the real")
    w("code: uavbus frames by the C runtime through cffi (`ub_frame_finish`, `ub_sec_protect`, `ub_compact_encode`")
    w("+ COBS stuffing + the 0x00 delimiter, i.e. what a compact link sends), MAVLink 2 frames by pymavlink")
    w("(`msg.pack`, signing set up for the signed rows). Compact = a link whose dictionaries agree (LINK_HELLO done):")
    w("content and entities as indices, 16-bit sequence. Both sides cut the same trailing zero bytes of the payload.")
    w("")
    w("**9a. Bytes on the wire per message**")
    w("")
    w("| form | " + " | ".join(MSGS) + " |")
    w("|---|" + "---:|" * len(MSGS))
    for form, label in FORMS:
        w(f"| {label} | " + " | ".join(str(size.get((m, form), "-")) for m in MSGS) + " |")
    w("")
    ok_bytes = True
    cells = []
    for ours, peer in (("compact", "mavlink2"), ("compact_signed", "mavlink2_signed")):
        for m in MSGS:
            a, b = size.get((m, ours)), size.get((m, peer))
            if a is None or b is None:
                ok_bytes = False
                continue
            ok_bytes = ok_bytes and a <= b
            cells.append(f"{a}/{b}")
    goals.append(("wire bytes, compact vs MAVLink 2", "<= MAVLink 2 in every cell (unsigned and signed)",
                  ", ".join(cells) + " bytes", ok_bytes, "figure 9a"))
    if rate:
        w("**9b. Messages per second through a simulated 57,600-baud radio**")
        w("")
        w("bench/src/radio_bench.c: each stream of 256 consecutive frames from wire_bench.py (the compact streams carry")
        w("all 32 sequence bits every 128th frame, as a link does) offered in a loop, as fast as the radio takes them,")
        w("to the runtime's impairment link (`ub_impair`, the ports' bandwidth model) at 5,760 bytes/s (57,600 baud,")
        w("10 UART bits a byte) and a 255-byte packet MTU; 60 simulated seconds after a 1 s warm-up, injected clock.")
        w("Not in the compact streams: one LINK_HELLO round per 5 s each way once agreed (a page is a 40-byte payload")
        w("+ 12 bytes per entity; with this link's 2 entities ~80 bytes on the wire: 16 bytes/s, 0.3 % of the radio).")
        w("")
        w("| form | " + " | ".join(MSGS) + " |")
        w("|---|" + "---:|" * len(MSGS))
        for form, label in FORMS:
            w(f"| {label} | " + " | ".join(f"{rate[(form, m)]:.1f}" if (form, m) in rate else "-" for m in MSGS) + " |")
        w("")
        w("| ratio | " + " | ".join(MSGS) + " | goal |")
        w("|---|" + "---:|" * (len(MSGS) + 1))
        worst = 1e9
        for ours, peer, label in (("compact", "mavlink2", "compact / MAVLink 2"),
                                  ("compact_signed", "mavlink2_signed", "compact signed / MAVLink 2 signed"),
                                  ("full", "mavlink2", "full / MAVLink 2 (the paper's header)")):
            rs = [rate[(ours, m)] / rate[(peer, m)] if rate.get((peer, m)) else 0.0 for m in MSGS]
            if ours != "full":
                worst = min(worst, *rs)
            w(f"| {label} | " + " | ".join(f"{r:.2f}x" for r in rs) + f" | {'>= 1x' if ours != 'full' else '-'} |")
        w("")
        goals.append(("57,600-baud radio, compact vs MAVLink 2", ">= 1x messages/s (unsigned and signed)",
                      f"worst {worst:.2f}x", worst >= 1.0, "figure 9b"))
    w("**9c. The speed goals of issue #15** (measured above in this run; what holds a miss back and the next step:")
    w("'What holds a miss back' below)")
    w("")
    w("| goal | measured (this run) | met |")
    w("|---|---|:---:|")
    by_name = {g[0]: g for g in goals}
    for title, names in SPEED_GOALS:
        found = [by_name[n] for n in names if n in by_name]
        if not found:
            w(f"| {title} | not measured in this run | ✗ |")
            continue
        w(f"| {title} | " + "; ".join(g[2] for g in found) + f" | {'✓' if all(g[3] for g in found) else '✗'} |")
    w("")
