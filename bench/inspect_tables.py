"""Figure 10 of bench/results.md: a one-shot remote read over 1 and 2 hops (issue 16). Called by
bench/tables.py with the raw folder, its writer and its list of goals; reads raw/inspect.txt
(bench/inspect_bench.py lines)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

Goal = tuple[str, str, str, bool, str]
RETRY_MS = 200  # ub_inspect_options_t.retry_ms default: an answer later than this is sent twice


def parse(text: str) -> list[dict[str, str]]:
    rows = []
    for line in text.splitlines():
        kind, _, rest = line.partition(" ")
        row = {"kind": kind}
        row.update(kv.split("=", 1) for kv in rest.split() if "=" in kv)
        rows.append(row)
    return rows


def render(raw: Path, w: Callable[[str], None], goals: list[Goal]) -> None:
    path = raw / "inspect.txt"
    if not path.exists():
        return
    rows = parse(path.read_text())
    reads = [r for r in rows if r["kind"] == "inspect_read"]
    floor = next((r for r in rows if r["kind"] == "udp_echo"), None)
    note = next((r for r in rows if r["kind"] == "inspect_note"), {})
    w("## 10. Remote inspection (issue 16): a one-shot read, round-trip time")
    w("")
    w("Table 2 on 127.0.0.1 (`uavbus.sim.hitl`, unsigned): the Python GCS and three `uavbus_node` processes; gcs1 to")
    w("rmax1ob1 over UDP and a pty serial link (mask 0x00000011), rmax1ob1 to fcs20 over a pty serial link. One sample =")
    size = reads[0]["bytes"] if reads else "?"
    w(f"`node.remote(target).get(\"airData\")` (INSPECT READ -> INSPECT_VALUE, {size}-byte image), timed around the")
    w("call in Python; the targets alternate. Floor: a Python UDP echo on loopback (no router, no second process's tick).")
    w("")
    w("| target | hops | p50 | p99 | min | max | samples | p50 / floor p50 |")
    w("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in reads + ([floor] if floor else []):
        ratio = f"{float(r['p50_ms']) / float(floor['p50_ms']):.0f}x" if floor and r is not floor else "1x"
        w(f"| {r['target']} | {r['hops']} | {r['p50_ms']} ms | {r['p99_ms']} ms | {r['min_ms']} ms | {r['max_ms']} ms | "
          f"{r['n']} | {ratio} |")
    w("")
    w(f"Requests {note.get('requests', '?')}, resent {note.get('retries', '?')}, failed {note.get('failed', '?')}.")
    w("")
    two = next((r for r in reads if r["hops"] == "2"), None)
    if two is not None:
        p99 = float(two["p99_ms"])
        goals.append(("10", f"a one-shot read over 2 hops is answered before the first retry ({RETRY_MS} ms) at p99",
                      f"p99 {p99:.1f} ms, {note.get('retries', '?')} resends", p99 < RETRY_MS,
                      "loopback, Table 2 processes"))
