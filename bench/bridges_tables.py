"""Figure 7 of bench/results.md: what the bridges add (bench/bridges_bench.py -> raw/bridges.json)."""

from __future__ import annotations

import json
import statistics
from collections.abc import Callable
from pathlib import Path


def _band(xs: list[float], fmt: str) -> str:
    if not xs:
        return "-"
    return f"{fmt.format(statistics.median(xs))} [{fmt.format(min(xs))} - {fmt.format(max(xs))}]"


def bridges_section(raw: Path, w: Callable[[str], None]) -> None:
    path = raw / "bridges.json"
    if not path.exists():
        return
    d = json.loads(path.read_text())
    meta = d["meta"][0]

    def col(key: str, field: str) -> list[float]:
        return [r[field] for r in d[key]]

    def lat_row(name: str, key: str) -> str:
        return f"| {name} | {_band(col(key, 'p50_us'), '{:.0f}')} | {_band(col(key, 'p99_us'), '{:.0f}')} |"

    def rate_row(name: str, key: str) -> str:
        got = [r["received"] / r["sent"] * 100 for r in d[key]]
        return f"| {name} | {_band([r['rate'] / 1000 for r in d[key]], '{:.1f}')} | {_band(got, '{:.1f}')} |"

    w("## 7. Bridges: what they add (latency, throughput)")
    w("")
    w(f"bench/bridges_bench.py, {meta['runs']} runs, processes unpinned (CPUs {meta['affinity']}), all on 127.0.0.1. "
      f"Latency: {meta['lat_n']} messages at {meta['lat_hz']} Hz, receive time minus send time in one process "
      "(p50 and p99 per run; median [min - max] over runs). Each bridged path beside the same path without the bridge.")
    w("")
    if d["mav_direct_lat"]:  # absent from a `--only zenoh` run
        w("| MAVLink: autopilot ATTITUDE -> Python GCS | latency p50 µs | latency p99 µs |")
        w("|---|---:|---:|")
        w(lat_row("direct: UDP -> pymavlink parse", "mav_direct_lat"))
        w(lat_row("bridged: UDP -> uavbus_mavbridge -> uavbus UDP -> uavbus Node (1 ms subscription)", "mav_bridge_lat"))
        w("")
        w(f"| MAVLink ingest: {meta['blast_mavlink']:,} ATTITUDE sent back to back by a Python sender | taken in, kmsg/s | taken in, % |")
        w("|---|---:|---:|")
        w(rate_row("pymavlink parser in a Python process", "mav_direct_ingest"))
        w(rate_row("uavbus_mavbridge (C: parse, directory, on-update publication)", "mav_bridge_ingest"))
        w("")
    w("| uavbus across sites: node A -> node B (gpsOut) | latency p50 µs | latency p99 µs |")
    w("|---|---:|---:|")
    w(lat_row("direct: one UDP link", "ub_direct_lat"))
    w(lat_row("bridged: UDP -> bridge zenoh -> Zenoh tcp -> bridge zenoh -> UDP", "ub_zenoh_lat"))
    if d.get("zenoh_alone_lat"):
        w(lat_row("Zenoh alone: a plain publisher -> subscriber, two Python processes, same rate", "zenoh_alone_lat"))
    w("")
    w(f"| uavbus across sites: {meta['blast_uavbus']:,} frames sent back to back | delivered, kframes/s | delivered, % |")
    w("|---|---:|---:|")
    w(rate_row("direct: one UDP link", "ub_direct_tput"))
    w(rate_row("bridged: two Zenoh bridges (frames batched per sample in C, ub_batchlink.h)", "ub_zenoh_tput"))
    w("")
    if "site_batch" in meta:  # the site links' settings (direct and bridged alike), from the run itself
        w("Site UDP ports in both paths: " + (f"several frames per datagram (`\"batch\": true`) and "
          f"{meta.get('site_rcvbuf', 0) / 2**20:g} MiB receive buffers, A sending {meta.get('send_chunk', '?')} frames "
          "per `send_many()`" if meta["site_batch"] else
          "one datagram per frame, default receive buffers (`--no-site-batch`)") + ".")
        w("")
    ratios = [b["rate"] / a["rate"] for a, b in zip(d["ub_direct_tput"], d["ub_zenoh_tput"]) if a["rate"]]
    if ratios:
        w(f"Bridged / direct delivery rate, per run (same run, same load): {_band(ratios, '{:.2f}')}.")
        w("")
    calls = d.get("zenoh_calls") or []
    if calls:
        w("| the two Zenoh bridges' own work per frame (a burst, both bridges in one process, real sessions) "
          "| Python-level calls | loop CPU µs | frames per sample | calls per turn of both bridges |")
        w("|---|---:|---:|---:|---:|")
        w(f"| calls and C calls (sys.setprofile) around the bridges' turn(); thread CPU time | "
          f"{_band([r['calls_per_frame'] for r in calls], '{:.1f}')} | "
          f"{_band([r.get('loop_cpu_us_per_frame', float('nan')) for r in calls], '{:.1f}')} | "
          f"{_band([r['crossed'] / r['samples'] if r.get('samples') else float('nan') for r in calls], '{:.0f}')} | "
          f"{_band([r['calls'] / r['turns'] if r.get('turns') else float('nan') for r in calls], '{:.1f}')} |")
        w("")
    z = d["ub_zenoh_tput"]
    if z and "gw_cpu_us_per_frame" in z[0]:
        w("| the bridge processes during the burst (every thread, Zenoh's included; /proc schedstat) "
          "| gwA CPU µs/frame | gwB CPU µs/frame | frames per sample |")
        w("|---|---:|---:|---:|")
        w(f"| per frame gwB received | {_band([r['gw_cpu_us_per_frame'][0] for r in z], '{:.1f}')} | "
          f"{_band([r['gw_cpu_us_per_frame'][1] for r in z], '{:.1f}')} | "
          f"{_band([e['published'] / e['samples_out'] if e['samples_out'] else float('nan') for e in (r['gwA_ends'] for r in z)], '{:.0f}')} |")
        w("")
        w("Why gwA's batches left during the burst (ub_drain_end_t, per run): " + "; ".join(
            ", ".join(f"{k.removeprefix('flush_')} {v}" for k, v in r["gwA_ends"].items() if k.startswith("flush_"))
            for r in z) + ".")
        w("")
    if z and "zenoh_published" in z[0]:
        w("Where the bridged frames went (per run): " + "; ".join(
            f"{r['gw_in']} into gwA, {r['zenoh_published']} published, {r['zenoh_received']} received by gwB, "
            f"{r['gw_out']} out of gwB, {r['received']} at B" for r in z)
          + ". Zenoh loses none; the rest overflowed the UDP receive buffers in front of the Python processes "
            "(kernel drops, which no uavbus counter sees).")
        w("")
    w("The direct paths wake no other process (the sender is the receiver, already running); each bridged path "
      "wakes the bridge process(es) and then the receiver, sleeping in poll(). On a shared 2-vCPU VM those wake-ups "
      "are where the bridged p99 goes (busy-polling the receiving side removed three quarters of the MAVLink "
      "samples above 1 ms in a trial), not the bridges' work: compare the p50s.")
    w("")
    for label, a, b in (("MAVLink bridge", "mav_bridge_lat", "mav_direct_lat"),
                        ("Zenoh bridges", "ub_zenoh_lat", "ub_direct_lat")):
        if not d[a] or not d[b]:
            continue
        added = statistics.median(col(a, "p50_us")) - statistics.median(col(b, "p50_us"))
        net = ""
        if a == "ub_zenoh_lat" and d.get("zenoh_alone_lat"):
            alone = statistics.median(col("zenoh_alone_lat", "p50_us"))
            net = f"; Zenoh alone takes {alone:.0f} µs of it, the two bridges' hops {added - alone:.0f} µs"
        w(f"- {label}: adds {added:.0f} µs at p50 (medians of this run){net}.")
    w("")


def mavdoor_section(raw: Path, w: Callable[[str], None]) -> None:
    """The MAVLink front door (bench/mavdoor_bench.py, issue 26) beside direct and MAVProxy as a router."""
    path = raw / "mavdoor.json"
    if not path.exists():
        return
    d = json.loads(path.read_text())
    runs = len(d["direct"])
    w("### 7b. The MAVLink front door: GCS <-> autopilot over 2 uavbus hops, beside MAVProxy as a router")
    w("")
    w(f"bench/mavdoor_bench.py, {runs} runs interleaved, one pymavlink autopilot (system 3) and one pymavlink GCS on "
      "127.0.0.1. Round trip: COMMAND_LONG -> COMMAND_ACK one at a time (median per run; median [min - max] over runs). "
      "Throughput: ATTITUDE asked at 1 kHz with SET_MESSAGE_INTERVAL (the Python autopilot's own pace bounds it on "
      "every path). mavp2p is in no registry reachable here: not compared.")
    w("")
    w("| path | round trip p50 ms | round trip p90 ms | ATTITUDE/s received | delivered % | ratio p50 to direct |")
    w("|---|---:|---:|---:|---:|---:|")
    base = statistics.median([r["rtt_median_ms"] for r in d["direct"]])
    names = {"direct": "direct (GCS -> autopilot)", "mavproxy": "MAVProxy router (mavproxy.py --master --out)",
             "door": "front door: uavbus_mavbridge door -> relay -> mb3"}
    for key in ("direct", "mavproxy", "door"):
        rs = d[key]
        p50 = [r["rtt_median_ms"] for r in rs]
        w(f"| {names[key]} | {_band(p50, '{:.2f}')} | {_band([r['rtt_p90_ms'] for r in rs], '{:.2f}')} | "
          f"{_band([r['attitude_per_s'] for r in rs], '{:.0f}')} | {_band([r['delivered'] * 100 for r in rs], '{:.1f}')} | "
          f"{statistics.median(p50) / base:.2f}x |")
    w("")
