"""`make demo`'s attacker step (issue 11, item 9): issue 11's attacks against the signed Table 2.

A second Table 2 network starts with the same run-time keys as the demo's HITL part, and an attacker who
holds no key sits on the gcs1 <-> rmax1ob1 UDP datalink (records every datagram, injects with the source
address each end expects) and at rmax1ob2's TCP port, while gcs1 runs the paper's two tests. The attacks
and their accounting are uavbus.sim.attacks' (the same campaign as tests/system/test_attacks.py): each is
printed as a check, which holds only when nothing of it was accepted and the victim counted every frame
under a reason; the step also checks that gpsOut (10 Hz) and imuOut (50 Hz) kept their rates within
10 % under attack and after both ends of the datalink restarted.

Then an insider who holds the group key (issue 23's lockout, in the group-key mode): one imuOut frame in
fcs20's name with counter 2^48-2, toward the forwarder rmax1ob1 and toward gcs1. Checked: nothing accepted,
both copies counted `counter_jump`, and imuOut still reaching gcs1 at 50 Hz within 10 %.

Then the same in gcs1's name to rmax1ob1 and in rmax1ob1's name to gcs1 (uavbus.sim.insider.group_key_lockout):
each counted `counter_jump`, gcs1 still administers rmax1ob1 and gpsOut keeps its 10 Hz.

Returns summary.json's "security" object: {"keys": ..., "attacks": [{"name", "sent", "accepted",
"dropped_as", "counted_at", "effect"}, ...], "insider": [the same for the group-key lockout],
"rates": {phase: {"gpsOut": Hz, "imuOut": Hz}}}.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Callable

from uavbus.sim.attacks import ATTACKS, SHORT_ATTACKS, AttackResult, Campaign, attack_options, start_with_tap
from uavbus.sim.insider import group_key_lockout
from uavbus.sim.secure import signed_config

TABLE2 = Path(__file__).resolve().parents[2] / "examples" / "configs" / "table2.json"
RATE_TOLERANCE = 0.10
REQUESTED_HZ = {"gpsOut": 10.0, "imuOut": 50.0}


def signed_table2(out: Path, fresh: bool = False) -> Path:
    """Table 2 with a "security" section; its key is made under out/keys (mode 0600, never in the
    repository; `fresh`: a new key, the one of an earlier run removed) and shared by every process of the
    demo: the fleet's key for this run. The counter files (out/state) persist: counters never go back."""
    if fresh:
        for old in (out / "keys").glob("*.key"):
            old.unlink()
    return signed_config(TABLE2, out)


def attacker_part(args: argparse.Namespace, check: Callable[[str, bool, str], bool],
                  say: Callable[[str], None] = print) -> dict[str, Any]:
    names = SHORT_ATTACKS if args.short else ATTACKS
    config = args.config
    say(f"\n== Attacker step (issue 11): {len(names)} attacks on the signed Table 2 "
        f"(keys made at run time: {config.parent / 'keys'})")
    say("  the attacker holds no key; it taps the gcs1<->rmax1ob1 UDP datalink (gcs1 listens there only, so "
        "every frame it gets crosses the tap) and connects to rmax1ob2's TCP port")
    h, tap = start_with_tap(attack_options(args.program, config))
    try:
        campaign = Campaign(h, tap, say=lambda _line: None)
        campaign.start_flows()
        say("  gpsOut rmax1ob1 -> gcs1 (10 Hz), imuOut fcs20 -> gcs1 (50 Hz), navFilterState rmax1ob2 -> gcs1 "
            "flowing; the attacker records, then attacks")
        results = campaign.run(names, record_s=2.5 if args.short else 4.5)
        for r in results:
            check(f"attack refused: {r.name}", r.accepted == 0 and sum(r.dropped_as.values()) == r.sent > 0,
                  r.line())
        rates: dict[str, dict[str, float]] = {}
        for label, t0, t1 in campaign.phases:
            rates[label] = campaign.rates(t0, t1)
            for name, hz in rates[label].items():
                want = REQUESTED_HZ[name]
                check(f"rate kept {label}: {name}", abs(hz - want) <= RATE_TOLERANCE * want,
                      f"{hz:.2f} Hz for {want:g} Hz requested over {t1 - t0:.1f} s")
        insider = [insider_lockout(campaign, config, check, say)]
        say("  ... and one frame each in gcs1's name to rmax1ob1 and in rmax1ob1's name to gcs1 (issue 23: every "
            "victim)")
        r = group_key_lockout(campaign, config.parent / "keys" / "fleet-1.key")
        check(f"lockout refused: {r.name}", r.accepted == 0 and r.dropped_as == {"counter_jump": r.sent}, r.line())
        insider.append(r)
    finally:
        status = h.close()
        tap.close()
    check("attacker step: all C nodes exit cleanly", all(s == 0 for s in status.values()),
          ", ".join(f"{n}: exit {s}" for n, s in status.items()))
    return {"keys": "generated at run time (uavbus keys new), never committed", "signed": True,
            "attacks": [r.as_json() for r in results], "insider": [r.as_json() for r in insider], "rates": rates}


def insider_lockout(campaign: Campaign, config: Path, check: Callable[[str, bool, str], bool],
                    say: Callable[[str], None]) -> AttackResult:
    """Issue 23's lockout frame in the group-key mode, by a holder of this run's fleet key."""
    say("  an insider holding the group key (a captured vehicle) sends one frame in fcs20's name with "
        "counter 2^48-2")
    r = campaign.insider_lockout(config.parent / "keys" / "fleet-1.key")
    check(f"lockout refused: {r.name}", r.accepted == 0 and r.dropped_as == {"counter_jump": r.sent}, r.line())
    hz, want = r.extra["imu_hz"], REQUESTED_HZ["imuOut"]
    check("rate kept after the lockout frame: imuOut", abs(hz - want) <= RATE_TOLERANCE * want,
          f"{hz:.2f} Hz for {want:g} Hz requested")
    return r
