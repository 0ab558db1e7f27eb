"""Issue 11 items 3 and 4 on the paper's Table 2 as real processes on 127.0.0.1, keys made at test time:
an eavesdropper on an encrypting datalink sees only ciphertext; keys rotate on the running network with
nothing lost. (Every attack of the issue is test_attacks.py's, with the campaign `make demo` runs.)
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

from uavbus.sim.attacker import UdpTap, insert_udp_tap
from uavbus.sim.build import REPO
from uavbus.sim.hitl import Hitl, HitlOptions
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(150)

TABLE2 = REPO / "examples" / "configs" / "table2.json"
GPS_MS, IMU_MS = 100, 20


def start(opts: HitlOptions) -> tuple[Hitl, dict[str, UdpTap]]:
    h = Hitl(opts)
    taps: dict[str, UdpTap] = {}

    def tap_datalink(topo: Any) -> None:
        if "udp" in taps:          # a retried start (ports taken meanwhile): a new tap for the new ports
            taps.pop("udp").close()
        taps["udp"] = insert_udp_tap(topo, ("gcs", "gcsPortDatalink1"), ("primary", "onboardPortDatalink1"), h.alloc)

    h.on_topology = tap_datalink
    try:
        h.start()
    except BaseException:
        h.close()
        for t in taps.values():
            t.close()
        raise
    return h, taps


def rates(h: Hitl, t0: float, t1: float) -> tuple[float, float, float]:
    return (h.meter("gpsOut", "rmax1ob1").rate_hz(t0, t1), h.meter("imuOut", "fcs20").rate_hz(t0, t1),
            h.meter("navFilterState", "rmax1ob2").rate_hz(t0, t1))


def test_an_encrypting_datalink_shows_the_eavesdropper_only_ciphertext(hitl_opts: HitlOptions,
                                                                       tmp_path: Path) -> None:
    """`encrypt` on both ends of the UDP datalink: everything the tap records there is ENCRYPTED (also the
    imuOut frames rmax1ob1 forwards from fcs20, converted from SIGNED), no delivered payload appears on
    that link in clear, and the streams keep their rates."""
    # rmax1ob1: fcs20 has a link of the same name (Table 2), which must stay as it is
    links = {"gcsPortDatalink1": {"encrypt": True}, "rmax1ob1:onboardPortDatalink1": {"encrypt": True}}
    hitl_opts.config = signed_config(TABLE2, tmp_path, links=links)
    hitl_opts.gcs_links = ("gcsPortDatalink1",)        # the tapped link only: every frame crosses the tap
    h, taps = start(hitl_opts)
    try:
        gps = h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", GPS_MS)
        imu = h.add_row("subscription", "imuOut", "fcs20", "gcs1", IMU_MS)
        h.wait_status(gps, "active", 8.0)
        h.wait_status(imu, "active", 8.0)
        h.wait_data("imuOut", "fcs20", 3, 5.0)
        t0 = time.monotonic()
        h.run_for(1.5)
        gps_hz, imu_hz, _ = rates(h, t0, time.monotonic())
        assert gps_hz == pytest.approx(10, rel=0.10) and imu_hz == pytest.approx(50, rel=0.10), (gps_hz, imu_hz)
        on_air = taps["udp"].frames("b>a") + taps["udp"].frames("a>b")
        assert len(on_air) > 80
        assert {f[3] for f in on_air} == {0x21}, "a frame crossed the encrypting link unencrypted"
        delivered = {raw for *_x, raw in h.messages if len(raw) >= 16}
        assert delivered and not any(raw in f for raw in delivered for f in on_air)
        assert h.gcs.security()["decrypted_in"] >= 80
        backup = h.child_stats("backup")["security"]
        assert backup["encrypted_out"] == 0 and backup["signed_out"] >= 80   # fcs20's own link is signed only
    finally:
        h.close()
        for t in taps.values():
            t.close()


def test_key_rotation_across_running_processes_loses_nothing(hitl_opts: HitlOptions, tmp_path: Path) -> None:
    """Rotation on the live Table 2 network (uavbus_node stdin `key add/use/remove`, Python Node methods):
    every node accepts key 2, every node signs with it, key 1 is retired everywhere; the streams keep
    their rates throughout and no frame is refused for its key."""
    from uavbus.sim.secure import new_key

    hitl_opts.config = signed_config(TABLE2, tmp_path)
    h, taps = start(hitl_opts)
    try:
        gps = h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", GPS_MS)
        imu = h.add_row("subscription", "imuOut", "fcs20", "gcs1", IMU_MS)
        h.wait_status(gps, "active", 8.0)
        h.wait_status(imu, "active", 8.0)
        h.wait_data("imuOut", "fcs20", 3, 5.0)
        key2 = new_key(tmp_path / "keys", 2)

        def everywhere(command: str) -> None:
            for name in ("primary", "secondary", "backup"):
                proc = h.group[name]
                m = proc.mark()
                proc.send(command)
                ev = h.child_event(name, lambda e: e.get("event") in ("key", "error"), 3.0, since=m)
                assert ev["event"] == "key", f"{name}: {command}: {ev}"
            h.run_for(0.3)

        t0 = h.mark("rotation")
        h.gcs.add_key(key2)
        everywhere(f"key add {key2}")
        h.gcs.use_key(2)
        everywhere("key use 2")
        proc = h.group["primary"]
        m = proc.mark()
        proc.send("key remove 2")
        err = h.child_event("primary", lambda e: e.get("event") in ("key", "error"), 3.0, since=m)
        assert err["event"] == "error" and "'key use' another key first" in err["message"]
        h.gcs.remove_key(1)
        everywhere("key remove 1")
        h.run_for(1.0)
        t1 = h.mark("rotated")
        gps_hz, imu_hz, _ = rates(h, t0, t1)
        assert gps_hz == pytest.approx(10, rel=0.10) and imu_hz == pytest.approx(50, rel=0.10), (gps_hz, imu_hz)
        for name in ("primary", "secondary", "backup"):
            st = h.child_stats(name)
            assert st["security"]["keys"] == [2] and st["security"]["tx_key"] == 2, st["security"]
            assert st["node"]["drops"]["unknown_key"] == st["node"]["drops"]["bad_tag"] == 0, name
        assert h.gcs.security()["keys"] == [2]
        assert h.gcs.counters()["drops"]["unknown_key"] == 0
    finally:
        h.close()
        for t in taps.values():
            t.close()
