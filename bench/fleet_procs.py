#!/usr/bin/env python3
"""Fleet bench, separate processes (bench figure 8, issue 12): N vehicles and 2 ground stations, each a
`uavbus_node` process, linked by UDP on 127.0.0.1, automatic routes, connectivity by the launcher's range
model (uavbus.sim.fleet, the `uavbus sim` launcher).

    fleet_procs.py PROGRAM [N] [--hello-ms 1000] [--out DIR]
        -> one "fleet_procs n=N key=value ..." line on stdout

The layout is fleet_bench.c's: vehicles on a grid 500 m apart flying 20 m orbits, radio range 650 m, gcs1 and
gcs2 350 m west and east of the middle row; every vehicle's gpsOut (10 Hz) to the ground station of its half
(a subscription at the ground station). PROGRAM must be built with room for N + 2 entities
(-DUB_MAX_ENTITIES=64, bench/run.sh does it). After 15 s of warm-up, links next to the ground stations' first
relays (on most paths) are cut one at a time for 4 s, every 6 s. Figures: reconvergence of every flow a cut
interrupted (data plane: silence end minus the cut, from the launcher's per-event report), delivery where a path
existed, routing frames per link end per second in quiet windows, CPU per process from /proc/PID/stat.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from uavbus.sim.fleet import FleetRun
from uavbus.sim.scenario import EventSpec, FlowSpec, LinkSpec, RoutingSpec, Scenario, Station

SPACING, RANGE, GCS_OFFSET = 500.0, 650.0, 350.0
WARMUP_S, FAIL_EVERY_S, FAIL_FOR_S = 15.0, 6.0, 4.0


def scenario(n: int, hello_ms: int, failures: int) -> Scenario:
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    mid = (rows - 1) * SPACING / 2
    stations = [Station("gcs1", "gcs", "process", f"static:n={mid:g},e={-GCS_OFFSET:g}", 0),
                Station("gcs2", "gcs", "process", f"static:n={mid:g},e={(cols - 1) * SPACING + GCS_OFFSET:g}", 0)]
    pos = {"gcs1": (mid, -GCS_OFFSET), "gcs2": (mid, (cols - 1) * SPACING + GCS_OFFSET)}
    home = {}
    for v in range(n):
        r, c = divmod(v, cols)
        name = f"v{v}"
        stations.append(Station(name, "vehicle", "process",
                                f"orbit:r=20,v=5,n={r * SPACING:g},e={c * SPACING:g},phase={(v * 37) % 360}", 0))
        pos[name] = (r * SPACING, c * SPACING)
        home[name] = "gcs1" if c < (cols + 1) // 2 else "gcs2"
    names = [s.name for s in stations]
    links = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if math.dist(pos[a], pos[b]) <= RANGE:
                links.append(LinkSpec(a, b, "udp", "radio", RANGE, 0.0, 0, 0, 0))
    flows = [FlowSpec(f"state_{v}", "gpsOut", v, g, 100, 0) for v, g in home.items()]
    # Cut the links between a ground station's first relays and the vehicles behind them: many flows cross them,
    # and each leaves a detour.
    near = sorted({(l.a, l.b) for l in links if "gcs" not in l.a + l.b and
                   any({l.a, l.b} & {m.a, m.b} for m in links if "gcs" in m.a + m.b)})
    events = []
    t = WARMUP_S
    for k in range(failures):
        a, b = near[(k * 7) % len(near)]
        events.append(EventSpec(t, "fail_link", (a, b), 0))
        events.append(EventSpec(t + FAIL_FOR_S, "restore_link", (a, b), 0))
        t += FAIL_EVERY_S
    return Scenario(f"fleet{n}procs", "<bench>", t + 2.0, 1, RoutingSpec(hello_ms, 0, 2, "all"), tuple(stations),
                    tuple(links), tuple(flows), tuple(events))


def cpu_ticks(pid: int) -> int:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime + stime (fields 14, 15)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("program", type=Path)
    ap.add_argument("n", type=int, nargs="?", default=30)
    ap.add_argument("--hello-ms", type=int, default=1000)
    ap.add_argument("--failures", type=int, default=6)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    sc = scenario(args.n, args.hello_ms, args.failures)
    out = args.out or Path(tempfile.mkdtemp(prefix="fleet_procs_"))
    run = FleetRun(sc, out, program=args.program, log=lambda s: print(s, file=sys.stderr, flush=True))
    cpu: dict[str, list[tuple[float, int]]] = {}

    def sample(r: FleetRun, t: float) -> None:
        for name, m in r.members.items():
            if m.proc is not None and m.proc.running:
                cpu.setdefault(name, []).append((time.monotonic(), cpu_ticks(m.proc.pid)))

    run.call_at(5.0, sample)
    run.call_at(sc.duration_s - 0.5, sample)
    t0 = time.monotonic()
    summary = run.run()
    wall = time.monotonic() - t0
    hz = os.sysconf("SC_CLK_TCK")
    rate = {n: (v[-1][1] - v[0][1]) / hz / (v[-1][0] - v[0][0]) for n, v in cpu.items() if len(v) == 2}
    veh = [x for n, x in rate.items() if not n.startswith("gcs")]
    gcs = [x for n, x in rate.items() if n.startswith("gcs")]
    samples = sorted(1000.0 * s for e in summary["events"] if e["event"] == "fail_link" for s in e["affected"].values())
    unrec = sum(len(e["unrecovered"]) for e in summary["events"] if e["event"] == "fail_link")

    def pct(q: float) -> float:
        return samples[min(len(samples) - 1, max(0, math.ceil(q * len(samples)) - 1))] if samples else -1.0

    ratios = [f["delivery_ratio_connected"] for f in summary["flows"] if f["delivery_ratio_connected"] is not None]
    frames = summary["routing_frames_per_link_s"]
    print(f"fleet_procs n={args.n} gcs=2 transport=udp hello_ms={args.hello_ms} links={len(sc.links)} "
          f"sim_s={sc.duration_s:.0f} wall_s={wall:.1f} failures={args.failures} samples={len(samples)} "
          f"unrecovered={unrec} data_p50_ms={pct(0.5):.0f} data_p99_ms={pct(0.99):.0f} "
          f"delivery_connected_mean={statistics.fmean(ratios):.5f} delivery_connected_min={min(ratios):.5f} "
          f"frames_per_link_end_s={frames['steady_mean']} frames_per_link_end_s_max={frames['steady_max']} "
          f"cpu_ms_per_vehicle_s={1000 * statistics.fmean(veh):.2f} cpu_ms_per_vehicle_s_max={1000 * max(veh):.2f} "
          f"cpu_ms_per_gcs_s={1000 * statistics.fmean(gcs):.2f} processes={len(rate)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
