"""Issue 23 item 5 acceptance (the group-key half of the demo's lockout line): an insider who holds the fleet
key sends ONE imuOut frame in fcs20's name with counter 2^48-2, into the Table 2 processes on 127.0.0.1, toward
the forwarder rmax1ob1 (on fcs20's 2-hop path to gcs1) and toward gcs1. Before the jump bound this silenced fcs20
for good at both. Now each copy is dropped and counted `counter_jump` where it arrived, nothing is forwarded, and
fcs20's imuOut keeps reaching gcs1 at its 50 Hz (within 10 %), the GCS row staying active.

The campaign machinery is uavbus.sim.attacks' (Campaign.insider_lockout), as make demo's attacker step.
The rate is that of the frames fcs20 stamped in the watch window that reached gcs1 (`sent_rate_hz`): a CI run
of 2026-11-27 read 55.5 Hz by receive instants when this test's process (it polls gcs1; the UDP tap and the serial
null-modem relay are its threads) stalled ~320 ms across the window's start; the second test makes that stall.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

from uavbus.sim.attacks import LOCKOUT, Campaign, attack_options, start_with_tap
from uavbus.sim.build import REPO
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(120)

TABLE2 = REPO / "examples" / "configs" / "table2.json"


def test_one_lockout_frame_with_the_group_key_silences_nobody(program: Path, tmp_path: Path) -> None:
    config = signed_config(TABLE2, tmp_path)
    h, tap = start_with_tap(attack_options(program, config))
    try:
        campaign = Campaign(h, tap, say=print)
        campaign.start_flows()
        h.run_for(1.0)                                 # the tap records fcs20's genuine frames
        primary0 = h.child_stats("primary")
        r = campaign.insider_lockout(tmp_path / "keys" / "fleet-1.key")
        print(f"{LOCKOUT}: {r.line()}")
        # one copy at the forwarder, one at the GCS: each counted under the new reason, nothing else
        assert r.sent == 2
        assert r.dropped_as == {"counter_jump": 2}, r.line()
        assert r.accepted == 0, r.line()
        assert r.extra["imu_hz"] == pytest.approx(50, rel=0.10), r.line()
        assert r.extra["row_status"] == "active", r.line()
        # the forwarder dropped its copy and challenged fcs20 again (at most once a second)
        primary = h.child_stats("primary")
        link = primary["links"]["onboardPortDatalink1"]["drops"]
        assert link["counter_jump"] == 1
        assert primary["security"]["rechallenges"] - primary0["security"].get("rechallenges", 0) == 1
        gcs_link = h.gcs.link_counters()["gcsPortDatalink1"]["drops"]
        assert gcs_link["counter_jump"] == 1
        # gpsOut, which the frame did not name, kept its rate too
        assert r.extra["gps_hz"] == pytest.approx(10, rel=0.10), r.line()
    finally:
        h.close()
        tap.close()


def _hold_the_gil(seconds: float) -> None:
    """Stalls this process's Python threads as a long garbage collection does: the GCS is not polled, and
    the tap and the null-modem relay (threads here) move nothing, while the C nodes go on sending."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(10.0)                     # no other thread gets the GIL meanwhile
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            pass
    finally:
        sys.setswitchinterval(interval)


def test_a_harness_stall_across_the_window_start_adds_no_rate(program: Path, tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """The stall of a CI run of 2026-11-27, made on purpose: 0.4 s at the end of the settle, so that what fcs20 sent
    meanwhile reaches gcs1 in one burst just after the watch window opened."""
    config = signed_config(TABLE2, tmp_path)
    h, tap = start_with_tap(attack_options(program, config))
    try:
        campaign = Campaign(h, tap, say=print)
        campaign.start_flows()
        h.run_for(1.0)
        settle = campaign._settle

        def settle_then_stall(seconds: float = 0.3) -> None:
            settle(seconds)
            _hold_the_gil(0.4)

        monkeypatch.setattr(campaign, "_settle", settle_then_stall)
        r = campaign.insider_lockout(tmp_path / "keys" / "fleet-1.key")
        print(f"{LOCKOUT} (harness stalled 0.4 s before the window): {r.line()}")
        t0, t1 = r.extra["window"]
        imu = h.meter("imuOut", "fcs20")
        # the stall happened: fcs20's frames of those 0.4 s arrived inside the window, each 0.1 s old or more,
        # and by receive instants the stream reads fast (what failed in CI)
        late = [age for age in imu.latencies(t0, t1) if age > 100.0]
        assert len(late) >= 10 and r.extra["imu_late"] == len(late), (len(late), imu.rate_hz(t0, t1))
        assert f"{len(late)} arrived > 100 ms after fcs20 stamped them" in r.line()
        assert imu.rate_hz(t0, t1) > 52.0
        # placed where fcs20 sent them, they are neither extra nor missing
        assert r.extra["imu_hz"] == pytest.approx(50, rel=0.10), r.line()
        assert r.extra["gps_hz"] == pytest.approx(10, rel=0.10), r.line()
        assert r.dropped_as == {"counter_jump": 2}, r.line()
    finally:
        h.close()
        tap.close()
