"""Figure 8 of bench/results.md: fleets (issue 12). Called by bench/tables.py with the raw folder, its writer
and its list of goals; reads raw/fleet.txt (bench/src/fleet_bench.c and bench/fleet_procs.py lines)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

Goal = tuple[str, str, str, bool, str]


def parse(text: str) -> list[dict[str, str]]:
    rows = []
    for line in text.splitlines():
        kind, _, rest = line.partition(" ")
        if kind not in ("fleet_inproc", "fleet_procs"):
            continue
        row = {"kind": kind}
        row.update(kv.split("=", 1) for kv in rest.split() if "=" in kv)
        rows.append(row)
    return rows


def render(raw: Path, w: Callable[[str], None], goals: list[Goal]) -> None:
    path = raw / "fleet.txt"
    if not path.exists():
        return
    rows = parse(path.read_text())
    # A run without cuts (FLEET_BENCH_END_S: the 1000-vehicle scale check) measures speed only.
    scale = [r for r in rows if r["kind"] == "fleet_inproc" and int(r.get("failures", "0")) == 0]
    inproc = [r for r in rows if r["kind"] == "fleet_inproc" and r not in scale]
    procs = [r for r in rows if r["kind"] == "fleet_procs"]
    w("## 8. Fleets (issue 12): automatic routes, range model, 10 Hz state from every vehicle")
    w("")
    w("N vehicles on a grid 500 m apart flying 20 m orbits, radio range 650 m (grid neighbours in range, diagonals")
    w("not), gcs1 and gcs2 350 m west and east of the middle row; every vehicle publishes its state (`benchGpsRawInt`,")
    w("10 Hz) to the ground station of its half. Each node is told only itself and its ground station: routes and the")
    w("other entities are learned (ub_route, hello 1 s, 2 missed hellos take a link down). One on-path link at a time")
    w("is cut for 4 s (every 6 s); reconvergence is measured for every vehicle whose path crossed it and that kept a")
    w("detour: **route** = until the masks, followed hop by hop, reach its ground station again; **data** = until the")
    w("ground station receives its data again (includes waiting for the next 100 ms sample). **detect** = until the")
    w("node before the cut stops using it (the hello timers; meanwhile a link in doubt -- a gap in its neighbour's")
    w("frames -- already shares the data with every feasible successor, docs/routing.md \"Transport evidence\"); the")
    w("rest is the protocol. In process: one node per entity over memlinks on a simulated clock in 1 ms steps, a node")
    w("ticking when its next due time comes or frames reach it (as `uavbus_node` sleeps until then); runtime compiled with")
    w("`-DUB_MAX_ENTITIES=128 -DUB_DEDUP_SOURCES=128 -DUB_MAX_LOCAL_ENTITIES=1`; CPU is the nodes' and memlinks' own")
    w("(the harness apart). Processes: `uavbus_node` per entity (`-DUB_MAX_ENTITIES=64`), UDP on 127.0.0.1, the")
    w("`uavbus sim` launcher's range model; reconvergence from its per-event report; CPU from /proc/PID/stat.")
    w("")
    w("| fleet | links | reconvergence route p50 / p99 | data p50 / p99 | detect p50 / p99 | samples | delivery where a path exists: quiet / with cuts | routing frames per link end per s | CPU per vehicle (ms per s) |")
    w("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in inproc:
        w(f"| {r['n']} + 2, in process | {r['links']} | {int(r['route_p50_ms']) / 1000:.2f} / "
          f"{int(r['route_p99_ms']) / 1000:.2f} s | {int(r['data_p50_ms']) / 1000:.2f} / {int(r['data_p99_ms']) / 1000:.2f} s | "
          f"{int(r['detect_p50_ms']) / 1000:.2f} / {int(r['detect_p99_ms']) / 1000:.2f} s | {r['samples']} | "
          f"{100 * float(r['delivery_quiet']):.2f} % / {100 * float(r['delivery_failures']):.2f} % | "
          f"{float(r['frames_per_link_end_s']):.3f} | {float(r['cpu_ms_per_vehicle_s']):.2f} "
          f"(real-time factor {float(r['realtime_factor']):.1f} on one core, wall {float(r['wall_s']):.0f} s) |")
    for r in procs:
        data = (f"{int(r['data_p50_ms']) / 1000:.2f} / {int(r['data_p99_ms']) / 1000:.2f} s"
                if int(r["samples"]) > 0 else "-")  # no cut with a detour in this run: nothing was timed
        w(f"| {r['n']} + 2, processes, UDP | {r['links']} | - | {data} | - | {r['samples']} | mean {100 * float(r['delivery_connected_mean']):.2f} %, "
          f"min {100 * float(r['delivery_connected_min']):.2f} % (cuts included) | {r['frames_per_link_end_s']} (max "
          f"{r['frames_per_link_end_s_max']} over 2 s windows) | {r['cpu_ms_per_vehicle_s']} (ground station "
          f"{r['cpu_ms_per_gcs_s']}) |")
    for r in scale:
        w(f"| {r['n']} + 2, in process, {float(r['sim_s']):.0f} s without cuts | {r['links']} | - | - | - | - | "
          f"{100 * float(r['delivery_quiet']):.2f} % (counted by arrival over the short window after warm-up: frames in flight at its edges land on either side) / - | "
          f"{float(r['frames_per_link_end_s']):.3f} | "
          f"{float(r['cpu_ms_per_vehicle_s']):.3f} (real-time factor {float(r['realtime_factor']):.2f} on one core, "
          f"wall {float(r['wall_s']):.0f} s) |")
    w("")
    for r in inproc:
        drops = {k: r.get(k, "0") for k in ("no_route", "hop_limit", "backpressure", "duplicate", "learn_full")}
        w(f"- {r['n']} vehicles: {r['failures']} cuts, {r['unrecovered']} flows unrecovered; drops over the run "
          + ", ".join(f"{k} {v}" for k, v in drops.items()) + f"; {int(r['node_bytes']):,} bytes per node (node + route "
          "engine + state)")
    w("")
    big = max(inproc, key=lambda r: int(r["n"]), default=None)
    hello_s = 1.0
    if big is not None:
        n = int(big["n"])
        r99 = max(int(r["route_p99_ms"]) for r in inproc) / 1000
        d99 = max(int(r["data_p99_ms"]) for r in inproc) / 1000
        goals.append(("8 fleet", "reconvergence after a link loss within 3 hello intervals (p99)",
                      f"route p99 {r99:.2f} s, data p99 {d99:.2f} s = {d99 / hello_s:.1f} hello intervals (hello 1 s); "
                      f"detection alone p99 {max(int(r['detect_p99_ms']) for r in inproc) / 1000:.2f} s",
                      d99 <= 3 * hello_s, "10, 30, 100 vehicles"))
        q = min(float(r["delivery_quiet"]) for r in inproc)
        c = min(float(r["delivery_failures"]) for r in inproc)
        goals.append(("8 fleet", "delivery >= 99 % where a path exists (steady state)",
                      f"{100 * q:.2f} % (every fleet; no random link loss, the range model only)", q >= 0.99, ""))
        goals.append(("8 fleet", "delivery >= 99.5 % where a path exists, with one on-path link cut every 6 s (issue 28)",
                      f"{100 * c:.2f} % to {100 * max(float(r['delivery_failures']) for r in inproc):.2f} %: what is lost "
                      "is the time each cut takes to show as a gap (fast hellos), or the hello timeout where the node "
                      "before the cut has no feasible successor", c >= 0.995, "10, 30, 100 vehicles"))
        f = max(float(r["frames_per_link_end_s"]) - float(r.get("fast_hellos_per_link_end_s", "0")) for r in inproc)
        fast = max(float(r.get("fast_hellos_per_link_end_s", "0")) for r in inproc)
        goals.append(("8 fleet", "<= 1 routing frame per link per second in steady state (hellos and updates)",
                      f"{f:.3f} per link end per second (in process, hello 1 s), plus {fast:.3f} fast hellos (liveness on "
                      "links carrying traffic: the price of noticing a cut in ~0.2 s)" +
                      (f"; processes {procs[0]['frames_per_link_end_s']}" if procs else ""), f <= 1.0 + 1e-3, ""))
        for r in scale:
            goals.append(("8 fleet", f"{r['n']} vehicles + 2 ground stations in process on one core at real-time factor >= 1",
                          f"real-time factor {float(r['realtime_factor']):.2f} ({float(r['sim_s']):.0f} s simulated, "
                          f"{float(r['cpu_ms_per_vehicle_s']):.3f} ms CPU per vehicle per s)",
                          float(r["realtime_factor"]) >= 1.0, "issue 28 item 5"))
        cpu_cores = float(big["cpu_ms_per_vehicle_s"]) * (n + 2) / 1000
        goals.append(("8 fleet", f"{n} vehicles + 2 ground stations run on this 2-core machine",
                      f"{cpu_cores:.2f} core for the nodes ({float(big['cpu_ms_per_vehicle_s']):.2f} ms CPU per vehicle "
                      f"per second)" + (f"; 30 processes: {float(procs[0]['cpu_ms_per_vehicle_s']) * 32 / 1000:.2f} core"
                                        if procs else ""), cpu_cores < 2.0, "in process, one thread"))
        for r in procs:
            cpu = float(r["cpu_ms_per_vehicle_s"])
            goals.append(("8 fleet", "<= 2 ms CPU per vehicle per second as processes (uavbus_node sleeps until its next due time)",
                          f"{cpu:.2f} ms ({r['n']} vehicles, UDP)", cpu <= 2.0, "issue 28 item 5"))
