"""`uavbus sim SCENARIO`: run a fleet scenario file (docs/scenarios.md) and report what happened.

    uavbus sim examples/scenarios/fleet6.yaml [--out DIR] [--program PATH] [--check]

--check only validates the file (every error as file:line: message). The run writes DIR/summary.json,
DIR/timeline.png and DIR/configs/ (default DIR: sim-out/<scenario name>) and prints the events with their
reconvergence times and the delivery of every flow.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

__all__ = ["main", "render", "describe_external"]

OUTAGE_LIST_S = 0.5   # outages at least this long are listed under their flow, with their cause


def describe_external(sc: Any) -> list[str]:
    """One line per external member: what the launcher will and will not do with it."""
    from uavbus.sim.scenario import peer_port

    out = []
    for st in sc.stations:
        if st.external:
            out.append(f"  {st.name}: external on {st.port} (the launcher opens {peer_port(st.port)}), "
                       f"{'automatic routes' if st.routing else 'no routing: its neighbour pins a mask to it'}; "
                       "not started, killed or restarted by the launcher")
    return out


def render(summary: dict[str, Any]) -> str:
    lines = [f"scenario {summary['scenario']}: {summary['vehicles']} vehicles, {summary['ground_stations']} ground "
             f"stations, {summary['duration_s']:g} s, hello {summary['routing']['hello_ms']} ms"]
    for name, ext in sorted(summary.get("external", {}).items()):
        lines.append(f"  {name}: external on {ext['port']}{'' if ext['routing'] else ' (no routing)'}")
    lines += ["", "events:"]
    for e in summary["events"]:
        rec = "did not recover: " + ", ".join(e["unrecovered"]) if e["reconverged_s"] is None else (
            f"reconverged in {e['reconverged_s']:.2f} s" + (f" ({', '.join(sorted(e['affected']))})"
                                                            if e["affected"] else " (no flow noticed)"))
        lines.append(f"  t={e['t']:6.2f}  {e['text']:<40} {rec}")
    lines += ["", "flows:"]
    for f in summary["flows"]:
        ratio = "-" if f["delivery_ratio_connected"] is None else f"{100 * f['delivery_ratio_connected']:.1f} %"
        status = f.get("status", "")
        if f.get("admin_status"):
            status += f", admin row {f['admin_status']}"
        lines.append(f"  {f['name']:<12} {f['content']:<15} {f['source']:>8} -> {f['destination']:<8} "
                     f"hops {f['hops'] if f['hops'] is not None else '-'}  delivered {f['delivered']:5d}  "
                     f"where a path exists {ratio}  {status}".rstrip())
        for o in f.get("outages_explained", []):
            if o["length_s"] >= OUTAGE_LIST_S:
                to = "end (open)" if o["open"] else f"{o['to']:.2f}"
                lines.append(f"      outage {o['from']:.2f} -> {to} ({o['length_s']:.2f} s): {o['cause']}")
    r = summary["routing_frames_per_link_s"]
    lines += ["", f"routing frames per link per second: mean {r['mean']}, max {r['max']}; steady state max "
                  f"{r['steady_max']} ({r['steady_per_hello_max']} per hello interval)"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uavbus sim", description="Run a fleet scenario file (docs/scenarios.md).")
    ap.add_argument("scenario", help="scenario file (YAML)")
    ap.add_argument("--out", help="output folder (default sim-out/<scenario name>)")
    ap.add_argument("--program", help="uavbus_node to run (default: $UAVBUS_NODE or the build directory's)")
    ap.add_argument("--check", action="store_true", help="only validate the file")
    ap.add_argument("--signed", nargs="?", const="identity", choices=("identity", "group", "off"),
                    help="sign every frame whatever the file says: each station its own identity (the default, "
                         "and what --signed alone means), `group` the fleet key alone (bench mode), `off` unsigned")
    args = ap.parse_args(argv)

    from uavbus.sim.scenario import ScenarioError, load_scenario

    try:
        sc = load_scenario(args.scenario)
    except ScenarioError as e:
        print(e, file=sys.stderr)
        return 2
    if args.signed is not None:
        import dataclasses

        sc = dataclasses.replace(sc, signed=args.signed != "off",
                                 signed_mode=args.signed if args.signed != "off" else sc.signed_mode)
    if args.check:
        print(f"{args.scenario}: ok ({len(sc.vehicles)} vehicles, {len(sc.ground_stations)} ground stations, "
              f"{len(sc.links)} links, {len(sc.flows)} flows, {len(sc.events)} events)")
        for line in describe_external(sc):
            print(line)
        return 0
    from uavbus.sim.fleet import FleetRun

    out = Path(args.out) if args.out else Path("sim-out") / sc.name
    summary = FleetRun(sc, out, program=args.program).run()
    print(render(summary))
    print(f"\nwrote {out / 'summary.json'} and {out / 'timeline.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
