"""`make demo`'s insider step (issue 23): a captured vehicle attacks Table 2 with its own valid keys.

A third Table 2 network starts with the authorization policy (examples/configs/table2_policy.json), the
group key and an identity per entity (`uavbus keys fleet`, made at run time: a fleet authority certifies
each; the configuration names them, so every node, C and Python, checks origin tags keyed by the
certificates and honours revocations). rmax1ob2 is the
captured vehicle: the attacker holds the group key and rmax1ob2's own secret key, sits on the gcs1 <->
rmax1ob1 datalink (the outsider step's tap) and runs uavbus.sim.insider's attacks (the same campaign as
tests/system/test_insider_campaign.py). Each is a check: nothing accepted (except requests in its own name
within its quota, which the threat model allows and the line names), every frame counted under a reason at
the victim. gpsOut and imuOut keep their rates within 10 %. Then the operator revokes rmax1ob2 (handed to
rmax1ob1, spread by the revocation service): the time from the revocation reaching gcs1, rmax1ob1 and fcs20
to their first refusal of rmax1ob2's frames is measured per node (bound 2 s), and rmax1ob2's node restarts
with its revoked identity: it refuses to start, and with its revocations file thrown away it starts but
gets nothing in. Routing does not run in Table 2, so the routes attack runs on a small routed identity network
of the same fleet beside it: rmax1ob2 advertises entities that have no certificate to rmax1ob1 (C, `--route
certified=1`) and gcs1 (Python, `certified=True`), which refuse them (`dest_refused`).

The group-key half of the lockout line runs in the attacker step (attack_step.insider_lockout).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path
from typing import Any, Callable

from uavbus.sim.attacks import start_with_tap
from uavbus.sim.insider import INSIDER_ATTACKS, InsiderCampaign, insider_config, key_dir, insider_options

RATE_TOLERANCE = 0.10
REQUESTED_HZ = {"gpsOut": 10.0, "imuOut": 50.0}
REVOCATION_BOUND_MS = 2000.0
# what each attack must be counted as at the victim (a subset of these reasons, nothing else)
EXPECTED = {
    "replay of frames it relayed": {"replay", "duplicate"},
    "lockout: one frame in each victim's name, counter 2^48-2": {"bad_origin", "no_origin", "counter_jump"},
    "as itself: write rmax1ob1's armed = 1 and a waypoint": {"not_allowed", "not_authorized"},
    # on the small routed network beside Table 2 (uavbus.sim.insider.routed_insider): the certified filter
    "routes for entities it does not own": {"dest_refused"},
}
FORGED = {"bad_origin", "no_origin"}


def judge(r: Any) -> tuple[bool, str]:
    """The check of one insider attack: (held, why)."""
    if r.extra.get("allowed"):       # requests in its own name: the threat model allows them within the quota
        ok = r.extra["rows"] <= 8 and r.extra["fast"] == 0 and r.extra["unleased"] == 0 and r.sent > 0
        return ok, r.line()
    want = EXPECTED.get(r.name, FORGED)
    ok = r.sent > 0 and r.accepted == 0 and sum(r.dropped_as.values()) == r.sent and set(r.dropped_as) <= want
    return ok, r.line()


def insider_part(args: argparse.Namespace, check: Callable[[str, bool, str], bool],
                 say: Callable[[str], None] = print) -> dict[str, Any]:
    out: Path = args.out / "insider"
    shutil.rmtree(out, ignore_errors=True)     # a new authority and new identities every run
    config = insider_config(out)
    say(f"\n== Insider step (issue 23): a captured vehicle (rmax1ob2) with its own valid keys, "
        f"{len(INSIDER_ATTACKS)} attacks (identities made at run time: {key_dir(config)})")
    say("  it holds the group key and rmax1ob2's X25519 secret key; it is in range of the gcs1<->rmax1ob1 "
        "datalink; every node checks origin tags")
    h, tap = start_with_tap(insider_options(args.program, config))
    try:
        campaign = InsiderCampaign(h, tap, config)
        campaign.start_flows()
        results = campaign.run(record_s=1.5 if args.short else 2.5)
        for r in results:
            ok, why = judge(r)
            check(f"insider refused: {r.name}", ok, why)
        rates: dict[str, dict[str, float]] = {}
        for label, t0, t1 in campaign.phases:
            rates[label] = campaign.rates(t0, t1)
            for name, hz in rates[label].items():
                want = REQUESTED_HZ[name]
                check(f"rate kept {label}: {name}", abs(hz - want) <= RATE_TOLERANCE * want,
                      f"{hz:.2f} Hz for {want:g} Hz requested over {t1 - t0:.1f} s")
        rev = campaign.revoke()
        for node, v in rev["nodes"].items():
            if v["delay_ms"] is not None:
                why = (f"refused rmax1ob2's frames {v['delay_ms']:.0f} ms after the revocation reached it "
                       f"(reached {v['reached_ms']:.0f} ms, refused {v['refused_ms']:.0f} ms after the operator "
                       f"handed it to rmax1ob1; every node polled each {rev['poll_ms']:.0f} ms)")
            else:
                why = f"did not refuse rmax1ob2's frames within the step (revocation reached: {v['reached_ms']})"
            if campaign.identities or node == "gcs1":
                check(f"revocation: {node} refuses rmax1ob2 within 2 s", v["delay_ms"] is not None
                      and v["delay_ms"] <= REVOCATION_BOUND_MS, why)
            else:
                say(f"  revocation at {node}: {why} (no identities: its origin lookup is the static peers file)")
        if campaign.identities:
            rs = rev["restart"]
            check("revocation: the revoked vehicle's restart with the same identity gets nothing in",
                  rs["refused_to_start"] and rs["delivered"] == 0 and rs["refused"] > 0, rs["text"])
    finally:
        status = h.close()
        tap.close()
    check("insider step: all C nodes exit cleanly", all(s == 0 for s in status.values()),
          ", ".join(f"{n}: exit {s}" for n, s in status.items()))
    return {"attacker": "rmax1ob2 (group key + its own identity)",
            "attacks": [r.as_json() for r in results], "rates": rates, "revocation": rev}
