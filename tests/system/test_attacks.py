"""Issue 11 acceptance: every attack of the issue against the paper's Table 2 as real processes on 127.0.0.1,
with signing on. None succeeds, each is counted under its reason at the node it reached, and the
legitimate 10 Hz and 50 Hz streams keep their rates (+-10 %) throughout, also after both ends of the
datalink restarted. The campaign (uavbus.sim.attacks) is the one `make demo` runs in its attacker step.

The same campaign with signing off (the paper's closed lab) shows the attacks getting in: the accounting
that reports 0 accepted above can report the opposite (docs/security.md lists what then succeeds).
The authorization layer against a key holder who is not an administrator is test_admin_security.py's.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from uavbus.sim.attacks import ATTACKS, Campaign, attack_options, start_with_tap
from uavbus.sim.build import REPO
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(150)

TABLE2 = REPO / "examples" / "configs" / "table2.json"
FORGED = ("unsigned", "bad_tag", "unknown_key")      # the three forms a forger without the key can make
REPLAYED = ("replay", "duplicate", "unverified")


def no_message_twice(h: object) -> None:
    seen: set[tuple[str, str, int]] = set()
    for _t, name, source, seq, _raw in h.messages:   # type: ignore[attr-defined]
        assert (name, source, seq) not in seen, f"{name} from {source} seq {seq} delivered twice: a replay got in"
        seen.add((name, source, seq))


def test_every_attack_fails_is_counted_and_the_streams_keep_their_rates(program: Path, tmp_path: Path) -> None:
    h, tap = start_with_tap(attack_options(program, signed_config(TABLE2, tmp_path)))
    try:
        campaign = Campaign(h, tap, say=print)
        campaign.start_flows()
        results = {r.name: r for r in campaign.run()}
        assert list(results) == list(ATTACKS)
        for r in results.values():
            assert r.accepted == 0, f"{r.name}: {r.line()}"
            assert r.sent > 0 and r.dropped_as, f"{r.name}: {r.line()}"
            # every frame sent is counted once, under its reason, at the node it reached
            assert sum(r.dropped_as.values()) == r.sent, f"{r.name}: {r.line()}"
        for name in ATTACKS:
            r = results[name]
            if name.startswith(("forged", "pre-sent", "table", "1 ms")):
                # one frame in three of each form: no tag, a guessed key, an unknown key id
                assert r.dropped_as == {reason: r.sent // 3 for reason in FORGED}, f"{name}: {r.line()}"
        assert set(results["datagrams from an unknown UDP source"].dropped_as) == {"foreign"}
        for name in ("replay of recorded frames", "replay after a restart of both ends"):
            r = results[name]
            assert set(r.dropped_as) <= set(REPLAYED) and r.dropped_as.get("replay", 0) > 0, f"{name}: {r.line()}"
        tcp = results["TCP takeover"]
        assert set(tcp.dropped_as) <= {*FORGED, *REPLAYED} and {"unsigned", "bad_tag", "replay"} <= set(tcp.dropped_as)
        assert "taken over: 0" in tcp.effect and "established link up" in tcp.effect, tcp.effect
        amp = results["1 ms amplification (30 requests)"]
        assert amp.extra["bytes_per_s_after"] <= 1.3 * amp.extra["bytes_per_s_before"], amp.effect
        assert "active" in results["table exhaustion (40 requests)"].effect

        # the legitimate streams, under attack and after both ends restarted
        assert [p[0] for p in campaign.phases] == ["under attack", "after the restarts"]
        for label, t0, t1 in campaign.phases:
            rates = campaign.rates(t0, t1)
            assert rates["gpsOut"] == pytest.approx(10, rel=0.10), f"gpsOut {label}: {rates}"
            assert rates["imuOut"] == pytest.approx(50, rel=0.10), f"imuOut {label}: {rates}"
        no_message_twice(h)
        primary = h.child_stats("primary")
        assert primary["security"]["tx_refused"] == 0
    finally:
        h.close()
        tap.close()


CONTROL = ("forged admin request (spoofed UDP source)", "forged write: armed = 1", "forged write: waypoint",
           "forged gpsOut to the GCS", "forged NACK", "forged STOP", "pre-sent sequence numbers")


def test_with_signing_off_the_same_attacks_get_in(program: Path) -> None:
    """Signing off (no "security" section): the forgeries are accepted and do what the issue says (a vehicle
    streams onboardSet, armed = 1 and a waypoint land, a false position shows, rows fail and vanish,
    genuine frames are dropped by a forwarder) -- the instrument that reports 0 above can see them."""
    h, tap = start_with_tap(attack_options(program, TABLE2))
    try:
        campaign = Campaign(h, tap, say=print)
        campaign.start_flows()
        results = {r.name: r for r in campaign.run(CONTROL, record_s=2.0)}
        for name in CONTROL:
            r = results[name]
            # the unsigned third got in (a node without keys refuses the flagged forms: unknown_key); what else
            # shows in the drops is the attacks' doing (e.g. the onboardSet stream gcs1 never asked for: unbound)
            assert r.accepted >= r.sent // 3 > 0, f"{name}: {r.line()}"
            assert r.dropped_as.get("unknown_key") == 2 * r.sent // 3, f"{name}: {r.line()}"
            assert not {"unsigned", "bad_tag"} & set(r.dropped_as), f"{name}: {r.line()}"
        assert "written: rmax1ob1.onboardSet, fcs20.fcsSet" in results["forged write: armed = 1"].effect
        assert "false positions delivered to gcs1: 5" in results["forged gpsOut to the GCS"].effect
        assert "GCS rows failed: gps" in results["forged NACK"].effect
        assert "rows streaming onboardSet at rmax1ob1: 1" in results[CONTROL[0]].effect
        assert "rows removed at rmax1ob1" in results["forged STOP"].effect
    finally:
        h.close()
        tap.close()
