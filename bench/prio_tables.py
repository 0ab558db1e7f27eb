"""Bench figure 11 (issue 28, priorities on slow links): command latency beside a telemetry flood on a
simulated 57,600-baud radio, with and without priorities, and the telemetry delivered beside MAVLink 2 on the
same link. Called by bench/tables.py with the raw directory; raw/prio.txt is written by bench/prio_bench.py."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

Goal = tuple[str, str, str, bool, str]
FIELDS = ("label", "prio", "bulk", "commands", "p50", "p99", "max", "tel_offered", "tel_delivered", "age50",
          "age99", "shed", "refused", "bulk_Bps")


def parse(raw: Path) -> tuple[list[dict], str]:
    rows, sizes = [], ""
    f = raw / "prio.txt"
    if not f.exists():
        return rows, sizes
    for line in f.read_text().splitlines():
        p = line.split("\t")
        if p[0] == "prio" and len(p) == len(FIELDS) + 1:
            r = dict(zip(FIELDS, p[1:]))
            for k in FIELDS[1:]:
                r[k] = float(r[k])
            rows.append(r)
        elif p[0] == "sizes":
            sizes = ", ".join(f"{p[i]} {p[i + 1]} B" for i in range(1, len(p) - 1, 2))
    return rows, sizes


def render(raw: Path, w: Callable[[str], None], goals: list[Goal]) -> None:
    rows, sizes = parse(raw)
    w("## 11. Priorities on a 57,600-baud radio (issue 28)")
    w("")
    if not rows:
        w("TODO: the priorities figure did not run (bench/prio_bench.py).")
        w("")
        return
    w("bench/prio_bench.py + bench/src/prio_bench.c: the impairment's bandwidth model (`ub_impair.h`, 5,760 B/s,")
    w("the code the ports put in front of a radio) on the injected clock, 60 simulated seconds after 1 s of warm-up:")
    w("the figures do not depend on the machine. Telemetry: ATTITUDE 50 Hz, HIGHRES_IMU 100 Hz, GPS_RAW_INT 10 Hz,")
    w("about 1.7 times what the link carries; a command every 250-299 ms (uavbus: a PUB_STOP admin frame, class")
    w("command; MAVLink 2: COMMAND_LONG), retried every ms while the link refuses it; latency = first offer to last")
    w("byte at the far side. `prio` 0 = one 32-frame FIFO (what MAVLink radios and routers have), 1 = per-class")
    w("queues (`prio=1`, ub_prio.h). \"+ fragments\": a 16 KiB directory's FRAGMENT packets (255-byte MTU) offered as")
    w(f"fast as the link takes them. Frame sizes: {sizes}.")
    w("")
    w("| link | priorities | command p50 | command p99 | command max | telemetry offered/s | delivered/s | "
      "telemetry age p50 / p99 | shed/s | refused/s | fragment B/s |")
    w("|---|:---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        name = r["label"] + (" + fragments" if r["bulk"] else "")
        w(f"| {name} | {'yes' if r['prio'] else 'no'} | {r['p50']:.0f} ms | {r['p99']:.0f} ms | {r['max']:.0f} ms | "
          f"{r['tel_offered']:.0f} | {r['tel_delivered']:.1f} | {r['age50']:.0f} / {r['age99']:.0f} ms | "
          f"{r['shed']:.1f} | {r['refused']:.1f} | {r['bulk_Bps']:.0f} |")
    w("")

    def find(label: str, prio: float, bulk: float) -> dict | None:
        return next((r for r in rows if r["label"] == label and r["prio"] == prio and r["bulk"] == bulk), None)

    on, off, mav = find("uavbus compact", 1, 0), find("uavbus compact", 0, 0), find("MAVLink 2", 0, 0)
    frag_on = find("uavbus compact", 1, 1)
    if on is not None:
        worst = max(on["p99"], frag_on["p99"] if frag_on else 0)
        note = f"without priorities p99 {off['p99']:.0f} ms" if off else ""
        if mav:
            note += f"; MAVLink 2 p99 {mav['p99']:.0f} ms"
        goals.append(("11 priorities", "command p99 <= 50 ms on a saturated 57,600-baud link, with priorities",
                      f"{on['p99']:.0f} ms" + (f" ({frag_on['p99']:.0f} ms with fragments)" if frag_on else ""),
                      worst <= 50, note))
    if on is not None and mav is not None:
        ratio = on["tel_delivered"] / mav["tel_delivered"] if mav["tel_delivered"] else 0.0
        w(f"Telemetry delivered: uavbus compact with priorities {on['tel_delivered']:.1f} msg/s against MAVLink 2's "
          f"{mav['tel_delivered']:.1f} on the same link ({ratio:.2f}x), while its commands keep p99 "
          f"{on['p99']:.0f} ms against MAVLink 2's {mav['p99']:.0f} ms.")
        w("")
