"""What a fleet run measured (uavbus.sim.fleet): summary.json and timeline.png.

- **delivery per flow**: deliveries / what the period promises while both ends run (`delivery_ratio`) and
  while a path of connected links exists (`delivery_ratio_connected`), from the launcher's own link states; both
  over the run's span [0, duration) (`delivered` counts every delivery, before t = 0 and while the last stats are
  collected too);
- **reconvergence after each event** (kill, restart, add, link failure and repair, out of and back into
  range): for every flow that has a path after the event, the outage of that flow around the event (silence
  longer than the flow's gap, 3 periods, at least 300 ms) ends at its first delivery; the event's
  `reconverged_s` is the latest such end minus the event time (0 when no flow noticed), and flows that never
  delivered again are listed `unrecovered`;
- **routing frames per link per second**, per link end from the routing engines' counters (sampled every
  2 s): over the whole run, and `steady_*` over sampling windows with no event in them or in the 2 s before
  (the start counts as one: routes are being learned);
- **hops** of the last delivery of each flow (from its hop limit), and `radio_share`, what the radio's own
  loss leaves of a flow over that many hops ((1 - loss)^hops, `radio_share()`): the links do not retransmit,
  so a routing check asks for a share of that, not of the whole rate;
- **every outage with its cause** (`outages_explained`): the event that began it (link down, source gone,
  route change), start-up, no path since an event, or no event at all (loss or load);
- **stale flows**: a flow whose source is gone for good is `status: stale`, and so is its administration
  row's `admin_status` whatever the row last heard (`admin_row_status` keeps that).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from uavbus.sim.fleet import FleetRun, FlowTrack

__all__ = ["summarize", "plot_timeline", "flow_gaps", "window_delivery", "explained_outages", "outage_cause",
           "source_gone", "radio_share"]

SETTLE_S = 2.0


def radio_share(run: FleetRun, hops: int | None) -> float:
    """What the radio's own loss leaves of a flow over `hops` hops: (1 - loss)^hops, loss the median of the
    scenario's link losses (a scenario's radio default; a link given its own worse loss is a detour, not the
    path). Telemetry is not retransmitted (docs/pubsub.md), so a 2 % radio gives 0.98^5 = 90.4 % over 5 hops
    however well routes hold: a delivery check of routing compares against this share, not the whole rate."""
    losses = sorted(link.loss for link in run.sc.links)
    loss = losses[len(losses) // 2] if losses else 0.0
    return (1.0 - loss) ** (hops or 1)


def flow_gaps(tr: FlowTrack, end: float) -> list[tuple[float, float, bool]]:
    """Outages of a flow as (from, to, open): `from` is the last delivery before it (0 when it never
    started), `to` the first after it, or the end of the run for an outage that never ended (open)."""
    gap_s = tr.spec.gap_ms / 1000.0
    out: list[tuple[float, float, bool]] = []
    if tr.first is not None and tr.first > gap_s:
        out.append((0.0, tr.first, False))  # silent from the start (a vehicle that joins, a slow start)
    if tr.times:
        for a, b in zip(tr.times, tr.times[1:]):
            if b - a > gap_s:
                out.append((a, b, False))
    else:
        out = [(a, b, False) for a, b in sorted(tr.gaps)]
    if tr.last is None:
        out.append((0.0, end, True))
    elif end - tr.last > gap_s:
        out.append((tr.last, end, True))
    return out


def window_delivery(tr: FlowTrack, t0: float, t1: float) -> float | None:
    """Deliveries of a flow in [t0, t1) (whole 0.5 s bins) over what its period promises there."""
    k0, k1 = int(round(t0 / 0.5)), int(t1 / 0.5)
    if k1 <= k0:
        return None
    got = sum(tr.bins.get(k, 0) for k in range(k0, k1))
    return round(got / ((k1 - k0) * 500.0 / tr.spec.period_ms), 4)


COUNTERS = ("handovers", "leases_expired", "nacks_relayed", "other_admin", "replies_unmatched")


SLACK_S = 0.1  # launcher to process command latency


def outage_cause(run: FleetRun, name: str, a: float) -> dict[str, Any] | None:
    """The event that began an outage whose last delivery before it was at `a`: the data stops at the event,
    so the event comes after the last delivery (give or take the command's latency) and before the silence
    counts as an outage (the flow's gap: 3 periods, at least 300 ms; a frame or two lost to load just before
    the event does not hide the cause). An event that came later did not cause it, whatever happened to the
    flow afterwards. None: nothing the launcher did."""
    gap = run.flows[name].spec.gap_ms / 1000.0
    for ev in run.timeline:
        if a - SLACK_S <= ev["t"] <= a + gap:
            return ev
    return None


def _explain(run: FleetRun, name: str, a: float, b: float, cause: dict[str, Any] | None) -> str:
    """One line: why a flow was silent from a to b."""
    f = run.flows[name].spec
    if a == 0.0 and (run.flows[name].first is None or b <= run.flows[name].first):
        joins = run.sc.joins()
        late = [x for x in (f.source, f.destination) if x in joins]
        return f"start-up: {late[0]} joins at t={joins[late[0]]:g}" if late else "start-up (no delivery yet)"
    if cause is not None:
        kinds = {"kill": "source gone" if f.source in cause["target"] else "member gone",
                 "fail_link": "link down", "out_of_range": "link down (out of range)", "move": "route change",
                 "restart": "route change", "restore_link": "route change", "in_range": "route change",
                 "add": "route change"}
        return f"{kinds.get(cause['event'], cause['event'])}: {cause['text']} at t={cause['t']:g}"
    before = [ev for ev in run.timeline if ev["t"] <= a]
    if before and not before[-1]["connectivity"].get(name, True):
        return f"no path since {before[-1]['text']} at t={before[-1]['t']:g}"
    return "no event: loss or load (a path existed)"


def explained_outages(run: FleetRun, end: float) -> dict[str, list[dict[str, Any]]]:
    """Per flow, every outage (silence longer than the flow's gap) with its cause."""
    out: dict[str, list[dict[str, Any]]] = {}
    for name, tr in run.flows.items():
        rows = []
        for a, b, is_open in flow_gaps(tr, end):
            cause = outage_cause(run, name, a) if a > 0.0 else None
            rows.append({"from": round(a, 3), "to": round(b, 3), "open": is_open, "length_s": round(b - a, 3),
                         "cause": _explain(run, name, a, b, cause),
                         "event": None if cause is None else {"t": cause["t"], "event": cause["event"],
                                                              "target": cause["target"]}})
        out[name] = rows
    return out


def _reconvergence(run: FleetRun, end: float) -> list[dict[str, Any]]:
    """Each outage of a flow is charged to at most one event: the event that began it (`outage_cause`) when
    the flow still had a path after it (the network had to find another way: rerouting), or else the event
    that gave the flow its path back while the outage went on (a restart after the kill, a link restored or
    back in range, the flow's end joining). An outage that began before an event is never charged to an
    event that neither began it nor gave it its path back (a slow start, a loss burst, another link's
    failure)."""
    gaps = {name: flow_gaps(tr, end) for name, tr in run.flows.items()}
    causes = {(name, k): (outage_cause(run, name, a) if a > 0.0 else None)
              for name, gs in gaps.items() for k, (a, _, _) in enumerate(gs)}
    charged: set[tuple[str, int]] = set()
    out = []
    had_path = dict(run.connectivity0)   # at t = 0: who had a path before any event
    for ev in run.timeline:
        t = ev["t"]
        recovered: dict[str, float] = {}
        unrecovered = []
        for name, expected in ev["connectivity"].items():
            restored, had_path[name] = expected and not had_path.get(name, True), expected
            if not expected:
                continue
            for k, (a, b, is_open) in enumerate(gaps[name]):
                if (name, k) in charged or b < t:
                    continue
                if not (causes[(name, k)] is ev or (restored and a <= t + SLACK_S)):
                    continue
                charged.add((name, k))
                if is_open:
                    unrecovered.append(name)
                else:
                    recovered[name] = round(b - t, 3)
                break
        out.append({"t": t, "event": ev["event"], "target": ev["target"], "text": ev["text"],
                    "reconverged_s": (max(recovered.values()) if recovered else 0.0) if not unrecovered else None,
                    "affected": recovered, "unrecovered": unrecovered})
    return out


def _routing_rates(run: FleetRun) -> dict[str, Any]:
    # The start is an event too: every node learns its neighbours and sends triggered updates then. Counted as
    # steady state, the first 2 s window read 1.04-1.11 frames per hello on a busy machine and a first sample
    # 0.7 s late (a shorter window around the same burst) 2.1 (make demo, issue 27's audit).
    marks = [0.0] + [e["t"] for e in run.timeline]
    total: dict[str, float] = {}
    steady: dict[str, list[float]] = {}
    phased: list[float] = []
    for m in run.members.values():
        samples = m.routes_seen
        for link in {name for _, _, frames in samples for name in frames}:
            key = f"{m.name}:{link}"
            series = [(t, r, f[link]) for t, r, f in samples if link in f]
            # Whole run: the longest stretch of one process run.
            best = 0.0
            for run_id in {r for _, r, _ in series}:
                pts = [(t, n) for t, r, n in series if r == run_id]
                if len(pts) >= 2 and pts[-1][0] - pts[0][0] > best:
                    best = pts[-1][0] - pts[0][0]
                    total[key] = (pts[-1][1] - pts[0][1]) / best
            for (t0, r0, n0), (t1, r1, n1) in zip(series, series[1:]):
                if r0 != r1 or t1 - t0 < 0.5 or any(t0 - SETTLE_S <= x <= t1 for x in marks):
                    continue
                steady.setdefault(key, []).append((n1 - n0) / (t1 - t0))
                # Per hello interval, less the window's phase: a window of W s holds W/h hellos or one more,
                # depending on where it starts, so 11 hellos fall in a 1.96 s window (1.12 per hello counted
                # raw, coverage's slow node, hellos only). One frame of every window is that phase.
                phased.append((n1 - n0 - 1) / (t1 - t0))
    flat = [x for xs in steady.values() for x in xs]
    hello_s = run.sc.routing.hello_ms / 1000.0
    return {
        "mean": round(sum(total.values()) / len(total), 3) if total else None,
        "max": round(max(total.values()), 3) if total else None,
        "steady_mean": round(sum(flat) / len(flat), 3) if flat else None,
        "steady_max": round(max(flat), 3) if flat else None,
        "steady_per_link_max": {k: round(max(v), 3) for k, v in sorted(steady.items())},
        "hello_ms": run.sc.routing.hello_ms,
        # the budget's figure: the most frames per hello interval in any steady window, one frame of phase
        # allowed (steady_max is the same window counted raw)
        "steady_per_hello_max": round(max(phased) * hello_s, 3) if phased else None,
        "per_link": {k: round(v, 3) for k, v in sorted(total.items())},
    }


def source_gone(run: FleetRun, f: Any, end: float) -> bool:
    """The flow's source is gone for good: killed and not restarted, or an external member silent at the
    end (the launcher cannot see it; its last outage is still open)."""
    m = run.members[f.source]
    if m.station.external:
        tr = run.flows[f.name]
        return tr.last is None or end - tr.last > f.gap_ms / 1000.0
    return not (m.up or m.starting)


def summarize(run: FleetRun) -> dict[str, Any]:
    end = run.sc.duration_s
    flows = []
    explained = explained_outages(run, end)
    for name, tr in run.flows.items():
        f = tr.spec
        gaps = flow_gaps(tr, end)
        gone = source_gone(run, f, end)
        flows.append({
            "name": name, "content": f.content, "source": f.source, "destination": f.destination,
            "period_ms": f.period_ms, "delivered": tr.count, "expected": round(tr.expected, 1),
            # Deliveries and expectations over the same span, [0, duration): the flows that start while the
            # processes come up deliver before t = 0, and every flow goes on while the run's last stats are
            # collected; counted, those made multi-hop flows look 4-6 points better than they were.
            "delivery_ratio": round(min(1.0, tr.in_run / tr.expected), 4) if tr.expected > 0 else None,
            "delivery_ratio_connected": (round(min(1.0, tr.in_run / tr.expected_connected), 4)
                                         if tr.expected_connected > 0 else None),
            "hops": tr.hops,
            "radio_share": round(radio_share(run, tr.hops), 4),
            "outages": [[round(a, 3), round(b, 3)] + (["open"] if o else []) for a, b, o in gaps],
            "outages_explained": explained[name],
            # stale: the source is gone for good; what the destination holds is its last value, not a live one
            "status": "stale" if gone else ("flowing" if tr.last is not None and end - tr.last <= f.gap_ms / 1000.0
                                            else "silent"),
            "external": [x for x in (f.source, f.destination) if run.members[x].station.external],
        })
        if f.admin is not None:
            admin_member = run.members[f.admin]
            adm, row = run.admin_rows[name]
            if admin_member.node is None:
                st = {"status": "gone", "nack_reason": None, "nack_relayed": None}  # administrator killed for good
            else:
                st = adm.status(row)
            # The row's own status says what its last exchange was (`acknowledged`, `active`...); a source gone
            # for good makes it stale whatever it says (the C table has no such status; the report decides).
            flows[-1].update({"admin": f.admin, "kind": f.kind,
                              "admin_status": "stale" if gone and st["status"] != "gone" else st["status"],
                              "admin_row_status": st["status"],
                              "nack_reason": st["nack_reason"], "nack_relayed": st["nack_relayed"]})
    return {
        "scenario": run.sc.name, "file": run.sc.source, "duration_s": end, "seed": run.sc.seed,
        "routing": {"hello_ms": run.sc.routing.hello_ms, "dead_misses": run.sc.routing.dead_misses,
                    "parallel": run.sc.routing.parallel},
        "vehicles": len(run.sc.vehicles), "ground_stations": len(run.sc.ground_stations),
        "external": {s.name: {"port": s.port, "routing": s.routing} for s in run.sc.stations if s.external},
        "events": _reconvergence(run, end),
        "flows": flows,
        "routing_frames_per_link_s": _routing_rates(run),
        "processes": {m.name: {"starts": m.proc.starts, "running": m.proc.running}
                      for m in run.members.values() if m.proc is not None},
        "announcements": [ms.status(row) for ms, row in run.announcements],
        "signed": run.sc.signed,
        "signed_mode": run.sc.signed_mode if run.sc.signed else None,   # "identity" or "group"
        "counters": {name: {**{k: c.get(k, 0) for k in COUNTERS}, **({"origin": c["origin"]} if "origin" in c else {})}
                     for name, c in sorted(run.counters().items())},
    }


def plot_timeline(run: FleetRun, path: str | Path) -> None:
    """Per flow, deliveries per 0.5 s as a fraction of the flow's rate, against the events."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(run.flows)
    fig, axes = plt.subplots(len(names) or 1, 1, figsize=(10, 1.4 + 1.2 * len(names)), dpi=100, sharex=True,
                             squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        tr = run.flows[name]
        per_bin = 500.0 / tr.spec.period_ms
        ks = range(0, int(run.sc.duration_s / 0.5) + 1)
        ax.step([k * 0.5 for k in ks], [tr.bins.get(k, 0) / per_bin for k in ks], where="post", linewidth=1.0)
        ax.set_ylim(-0.05, 1.3)
        ax.set_ylabel(name, rotation=0, ha="right", va="center", fontsize=8)
        ax.grid(True, alpha=0.3)
        for ev in run.timeline:
            ax.axvline(ev["t"], color="tab:red" if ev["event"] in ("kill", "fail_link", "out_of_range") else
                       "tab:green", linestyle="--", linewidth=0.8, alpha=0.7)
    top = axes[0, 0]
    for k, ev in enumerate(run.timeline):  # two rows of labels, so events close in time stay readable
        top.text(ev["t"], 1.32 + 0.45 * (k % 2), ev["text"].split(" (")[0], rotation=20, fontsize=6, ha="left",
                 va="bottom")
    axes[-1, 0].set_xlabel("t (s)")
    fig.suptitle(f"{run.sc.name}: delivery per flow (fraction of its rate per 0.5 s)", fontsize=9, y=0.995)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
