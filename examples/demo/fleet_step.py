"""`make demo`, fleet step (issue 12): twelve vehicles and two ground stations with automatic routes
(examples/scenarios/fleet12.yaml, run by the scenario launcher `uavbus sim` uses).

What it shows, each as a check:
 - a vehicle leaves the ground station's radio range and stays reachable through relays (its flow goes on,
   one hop longer);
 - a vehicle joins mid-run: its links are made on the running peers, it is announced, its flow starts;
 - two administrators ask for the same flow at 100 ms and 500 ms: the first keeps it at its rate and says
   active, the second is told other_admin (no status is silently wrong);
 - the ground station that set up the vehicle-to-vehicle flows drives out of everyone's range: those flows
   go on at their rate without it (flows outlive the operator), while its own flows have nowhere to go;
 - the operator's console (`uavbus web`'s pages) on gcs1 while the fleet flies: screenshots of its map and its
   administration table in demo-out/ (console_step.py).

Returns the `"fleet"` section of demo-out/summary.json; writes demo-out/fleet/ (the launcher's summary.json,
timeline.png, configs).

    from fleet_step import fleet_part
    fleet = fleet_part(out_dir, program, check, say)
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Callable

from uavbus.sim.fleet import FleetRun
from uavbus.sim.fleet_report import radio_share, window_delivery
from uavbus.sim.scenario import load_scenario

REPO = Path(__file__).resolve().parents[2]
SCENARIO = REPO / "examples" / "scenarios" / "fleet12.yaml"
RECONVERGED_S = 2.5       # bound on any event's reconvergence (measured ~0.2-0.8 s; the machine is shared)
# Where a path exists, a flow delivers at least this share of what the radio leaves of it: fleet12's radio
# loses 2 % on every hop and nothing resends telemetry, so 5 hops carry 0.98^5 = 90.4 % at best and a bound
# of 90 % of the whole rate would test the dice, not the routes (it failed 2 of 3 clean-clone runs; measured
# over [0, duration) gps12 read 0.874-0.929). The bound is on routing: 90 % of (1 - loss)^hops.
DELIVERY = 0.9
SECOND_ADMIN_T = 5.0      # gcs2 asks for gcs1's imu7to3 at another rate
SAMPLE_T = 12.0           # both rows read back


Check = Callable[[str, bool, str], bool]


def fleet_part(out: Path, program: Path | None, check: Check, say: Callable[[str], None], *,
               signed: bool = False, console: bool = True) -> dict[str, Any]:
    sc = load_scenario(SCENARIO)
    if signed:
        sc = dataclasses.replace(sc, signed=True)
    say(f"\n== Fleet: {len(sc.vehicles)} vehicles (C processes) and {len(sc.ground_stations)} ground stations, "
        f"automatic routes, radio range {sc.links[0].range_m:.0f} m{', signed' if signed else ''} ({SCENARIO.name})")
    run = FleetRun(sc, out / "fleet", program=program, log=lambda s: say("  " + s))
    second: dict[str, Any] = {}

    def second_admin(r: FleetRun, t: float) -> None:
        f = r.sc.flows[[x.name for x in r.sc.flows].index("imu7to3")]
        adm = r.members["gcs2"].node.admin("gcs2")
        second["row"] = adm.add(f.content, f.source, f.destination, 500, kind="subscription")
        adm.activate(second["row"])
        second["adm"] = adm
        say(f"  [fleet12] t={t:6.2f}  gcs2 asks for imu7to3 ({f.source} -> {f.destination}) every 500 ms; "
            "gcs1 asked every 100 ms")

    def sample(r: FleetRun, t: float) -> None:
        adm1, row1 = r.admin_rows["imu7to3"]
        second["gcs1"] = adm1.status(row1)
        second["gcs2"] = second["adm"].status(second["row"])

    run.call_at(SECOND_ADMIN_T, second_admin)
    run.call_at(SAMPLE_T, sample)
    shown = None
    if console:  # the operator's console on gcs1, its map and administration table photographed (console_step.py)
        from console_step import attach_console

        shown = attach_console(run, out, say)
    try:
        summary = run.run()
    finally:
        if shown is not None:
            from console_step import finish_console

            console_result = finish_console(shown, check)
    flows = {f["name"]: f for f in summary["flows"]}
    events = summary["events"]
    tracks = run.flows

    for f in summary["flows"]:
        ratio = f["delivery_ratio_connected"]
        check(f"fleet flow {f['name']} delivers where a path exists",
              ratio is not None and ratio >= DELIVERY * f["radio_share"],
              f"{f['source']} -> {f['destination']}: {100 * (ratio or 0):.1f} % of its rate while a path existed, "
              f"{f['hops']} hops (the radio leaves {100 * f['radio_share']:.1f} %, bound "
              f"{100 * DELIVERY * f['radio_share']:.1f} %)")
    for e in events:
        rec = e["reconverged_s"]
        check(f"fleet event reconverges: {e['text'].split(' (')[0]}", rec is not None and rec <= RECONVERGED_S,
              "every flow recovered" + (f" in {rec:.2f} s" if rec is not None else f": not {e['unrecovered']}"))

    # A vehicle leaves the ground station's radio range and stays reachable through relays.
    left = next((e for e in events if e["event"] == "out_of_range" and set(e["target"]) == {"gcs1", "uav11"}), None)
    if left is not None:
        after = window_delivery(tracks["gps11"], left["t"] + 1.0, left["t"] + 6.0)
        check("fleet: uav11 out of gcs1's range, reached through relays",
              flows["gps11"]["hops"] >= 2 and after is not None
              and after >= DELIVERY * radio_share(run, flows["gps11"]["hops"]),
              f"out of range at t={left['t']:.1f} s; {100 * (after or 0):.0f} % delivered in the next 5 s, "
              f"{flows['gps11']['hops']} hops")
    else:
        check("fleet: uav11 out of gcs1's range, reached through relays", False, "uav11 never left gcs1's range")

    # A vehicle joins.
    add = next(e for e in events if e["event"] == "add")
    check("fleet: uav12 joins mid-run and delivers", flows["gps12"]["delivered"] > 0 and add["reconverged_s"] is not None,
          f"joined at t={add['t']:.0f} s, first data {add['reconverged_s']} s later, {flows['gps12']['hops']} hops")

    # Two administrators, one flow.
    g1, g2 = second.get("gcs1", {}), second.get("gcs2", {})
    imu_rate = window_delivery(tracks["imu7to3"], SECOND_ADMIN_T + 1.0, SAMPLE_T)
    check("fleet: two administrators, no wrong status",
          g1.get("status") == "active" and g2.get("status") == "failed" and g2.get("nack_reason") == "other_admin"
          and imu_rate is not None and imu_rate >= DELIVERY * radio_share(run, flows["imu7to3"]["hops"]),
          f"gcs1 (100 ms) {g1.get('status')}, gcs2 (500 ms) {g2.get('status')} ({g2.get('nack_reason')}); "
          f"the flow ran at {100 * (imu_rate or 0):.0f} % of 10 Hz")

    # The ground station drives out of range: vehicle-to-vehicle flows continue.
    gone = [e["t"] for e in events if e["event"] == "out_of_range" and "gcs1" in e["target"]]
    t_gone = max(gone) if gone else None
    if t_gone is not None and t_gone < sc.duration_s - 3.0:
        w0, w1 = t_gone + 1.0, sc.duration_s
        v2v = {n: window_delivery(tracks[n], w0, w1) for n in ("imu7to3", "nav10to6")}
        own = window_delivery(tracks["gps4"], w0, w1)
        kept = summary["counters"]
        check("fleet: gcs1 out of range, vehicle-to-vehicle flows continue",
              all(v is not None and v >= DELIVERY * radio_share(run, flows[n]["hops"]) for n, v in v2v.items())
              and (own or 0.0) < 0.1
              and kept["uav3"]["handovers"] >= 1 and kept["uav10"]["handovers"] >= 1,
              f"gcs1 out of everyone's range from t={t_gone:.1f} s; in the {w1 - w0:.0f} s after: "
              + ", ".join(f"{n} {100 * (v or 0):.0f} %" for n, v in v2v.items())
              + f" (its own gps4: {100 * (own or 0):.0f} %); rows handed over at uav3 and uav10; gcs1's rows now "
              + f"{flows['imu7to3']['admin_status']}")
    else:
        check("fleet: gcs1 out of range, vehicle-to-vehicle flows continue", False, "gcs1 never left everyone's range")

    r = summary["routing_frames_per_link_s"]
    per_hello = r["steady_per_hello_max"]
    check("fleet: at most one routing frame per link per hello interval (steady state)",
          per_hello is not None and per_hello <= 1.1,
          f"{r['steady_mean']} frames per link per second at hello {r['hello_ms']} ms "
          f"(max {per_hello} per hello interval over 2 s windows, one frame of phase allowed)")
    return {
        "vehicles": summary["vehicles"], "ground_stations": summary["ground_stations"], "signed": summary["signed"],
        "events": [{"t": e["t"], "event": e["event"], "target": e["target"], "reconverged_s": e["reconverged_s"]}
                   for e in events],
        "flows": [{k: f.get(k) for k in ("name", "source", "destination", "delivery_ratio", "delivery_ratio_connected",
                                         "hops", "admin", "admin_status")} for f in summary["flows"]],
        "routing_frames_per_link_s": {k: r[k] for k in ("mean", "steady_mean", "steady_max", "hello_ms",
                                                        "steady_per_hello_max")},
        "two_administrators": {"gcs1": g1.get("status"), "gcs2": g2.get("status"),
                               "gcs2_reason": g2.get("nack_reason")},
        "console": console_result if shown is not None else None,
        "gcs_out_of_range_t": t_gone,
        "outputs": str(out / "fleet"),
    }
