"""Issue 11 items 5 and 6 against real processes: the authorized, bounded administration plane.

The paper's Table 2 (three `uavbus_node` processes + the Python GCS, tests/system/test_table2.py) runs with
examples/configs/table2_policy.json, to which this test adds one entity: `mallory`, a ground station with a
radio on the "wireless serial" between gcs1 and rmax1ob1. No policy lists mallory as an administrator; it may
read gpsOut and navFilterState from rmax1ob1 (a guest display), and its limits are tight. It forges
CRC-valid frames with its own entity ID (signing is trust-wire's; this test spoofs no source) and injects them
into the radio in both directions, repeatedly, while the paper's two flows run:

    forged admin requests   PUB_REQUEST of onboardSet (read policy), of gpsOut to gcs1 (exclusive rights),
                            SUB_REQUEST at rmax1ob1 (exclusive rights)
    forged NACKs            to gcs1, with guessed ids 1..16 and with the real ids read off the radio
    forged STOPs            of gcs1's publication and of rmax1ob1's own configured row (at rmax1ob1), of
                            gcs1's subscription (at gcs1)
    table exhaustion        a request for every directory rmax1ob1 hosts, and for 20 other destinations
    1 ms amplification      PUB_REQUEST of gpsOut, 1 ms, lease 0
    forged write            DATA onboardSet with armed = 1 into rmax1ob1

Every attack must fail and be counted under its reason while gpsOut (10 Hz) and imuOut (50 Hz) keep their
rates within 10 %; a request within the limits but "forever" must end with its clamped lease; and the
administrator must still be served afterwards.
"""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path
from typing import Any

import pytest

from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus._bindings.ub_node import entity_id
from uavbus._ub import lib
from uavbus.sim.build import REPO
from uavbus.sim.hitl import Hitl, HitlOptions

pytestmark = pytest.mark.timeout(90)

GPS_MS, IMU_MS = 100, 20
MAX_LEASE_MS = 2000
ATTACK_S, BATCH_EVERY_S = 3.0, 0.25
HOSTED = ("gpsOut", "navFilterState", "imuOutPrimary", "onboardSet")   # what rmax1ob1 binds and produces


def policy_config(tmp: Path) -> Path:
    """table2_policy.json plus mallory (routed from rmax1ob1 over its radio link, index 1) and its grants."""
    cfg = json.loads((REPO / "examples" / "configs" / "table2_policy.json").read_text())
    for e in cfg["entities"]:
        lte = e["linktoentity"]
        if isinstance(lte, dict):
            lte["mallory"] = "0x00000010" if e["name"] == "rmax1ob1" else "0x00000000"
        else:
            lte.append("0x00000000")
    cfg["entities"].append({"name": "mallory"})
    sec = cfg["security"]
    sec["read"]["rmax1ob1"] = [{"from": "mallory", "content": ["gpsOut", "navFilterState"]}]
    sec["write"]["rmax1ob2"].append({"from": "rmax1ob1", "content": "navFilterState"})
    sec["limits"] = {"min_period_ms": 10, "max_rows": 1, "max_bytes_per_s": 4000, "max_lease_ms": MAX_LEASE_MS}
    path = tmp / "table2_mallory.json"
    path.write_text(json.dumps(cfg, indent=1))
    return path


class Rogue:
    """mallory's radio: CRC-valid frames from its own entity, written into the null-modem between the relayed
    bytes (side "b" reaches rmax1ob1, side "a" gcs1)."""

    def __init__(self, h: Hitl) -> None:
        assert h.topo is not None
        self.modem = h.topo.find("gcs", "gcsPortDatalink2").modem
        self.cat = h.gcs.catalogue
        self.seq = 1000
        self.sent = 0

    def _send(self, side: str, code: int, content: str, dest: str, payload: bytes) -> None:
        inst = self.cat.instance(content)
        self.seq += 1
        fingerprint = inst.type.fingerprint if code not in (lib.UB_ADMIN_ACK, lib.UB_ADMIN_NACK) else 0
        h = FrameHeader(dir_id=inst.id, dest_id=entity_id(dest), src_id=entity_id("mallory"), admin=code,
                        payload_size=len(payload), seq=self.seq, fingerprint=fingerprint)
        frame = ub_frame_finish(h, payload)
        assert self.modem.inject(side, frame) == len(frame)
        self.sent += 1

    def request(self, code: int, content: str, peer: str, period_ms: int, lease_ms: int, rid: int) -> None:
        self._send("b", code, content, "rmax1ob1", struct.pack("<III12s", rid, period_ms, lease_ms, entity_id(peer)))

    def stop(self, side: str, code: int, content: str, target: str, peer: str, rid: int) -> None:
        self._send(side, code, content, target, struct.pack("<I12s", rid, entity_id(peer)))

    def nack(self, content: str, rid: int, answered: int) -> None:
        self._send("a", lib.UB_ADMIN_NACK, content, "gcs1", struct.pack("<IBBH", rid, answered,
                                                                         lib.UB_NACK_TABLE_FULL, 0))

    def data(self, content: str, payload: bytes) -> None:
        self._send("b", lib.UB_ADMIN_DATA, content, "rmax1ob1", payload)


def attack_batch(r: Rogue, gps_id: int, imu_id: int, armed: bytes) -> dict[str, int]:
    """One round of every attack; returns how many frames of each kind it sent."""
    pub, sub = lib.UB_ADMIN_PUB_REQUEST, lib.UB_ADMIN_SUB_REQUEST
    r.request(pub, "onboardSet", "mallory", 100, 3000, 1)            # read policy
    r.request(pub, "gpsOut", "gcs1", 1, 0, 2)                       # exclusive rights
    r.request(sub, "imuOutPrimary", "fcs20", 20, 0, 3)              # exclusive rights
    r.request(pub, "gpsOut", "mallory", 1, 0, 4)                    # 1 ms: LIMIT
    for k, content in enumerate(HOSTED):                            # exhaustion: one row at most (max_rows 1)
        r.request(pub, content, "mallory", 1000, 3000, 10 + k)
    for k in range(20):                                             # ... and nothing for anyone else
        r.request(pub, "gpsOut", f"victim{k}", 1000, 3000, 30 + k)
    r.stop("b", lib.UB_ADMIN_PUB_STOP, "gpsOut", "rmax1ob1", "gcs1", gps_id)
    r.stop("b", lib.UB_ADMIN_PUB_STOP, "navFilterState", "rmax1ob1", "rmax1ob2", 0)
    r.stop("a", lib.UB_ADMIN_SUB_STOP, "imuOut", "gcs1", "fcs20", imu_id)
    for rid in [*range(1, 17), gps_id]:
        r.nack("gpsOut", rid, pub)
    for rid in [*range(1, 17), imu_id]:
        r.nack("imuOut", rid, sub)
    r.data("onboardSet", armed)
    return {"refused_at_vehicle": 3 + 20 + 2 + 2, "stops_at_gcs": 1, "nacks": 34, "writes": 1}


def owned_rows(stats: dict[str, Any], entity: str, owner: str) -> list[dict[str, Any]]:
    return [r for r in stats["pubsub"][entity] if r.get("owner") == owner]


def dump(h: Hitl, node: str, content: str) -> str:
    proc = h.group[node]
    m = proc.mark()
    proc.send(f"dump {content}")
    return h.child_event(node, "dump", 3.0, since=m)["packed"]


def test_admin_plane_attacks_fail_and_flows_keep_their_rates(program: Path, tmp_path: Path) -> None:
    opts = HitlOptions(program=program, config=policy_config(tmp_path),
                       node_args={"primary": ["--publish", "rmax1ob1:navFilterState>rmax1ob2/100"]})
    with Hitl(opts) as h:
        gps = h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", GPS_MS)
        imu = h.add_row("subscription", "imuOut", "fcs20", "gcs1", IMU_MS)
        h.wait_status(gps, "active", 5.0)
        h.wait_status(imu, "active", 5.0)
        h.wait_data("imuOut", "fcs20", 5, 3.0)
        onboard_before = dump(h, "primary", "onboardSet")
        rogue = Rogue(h)
        armed = h.gcs.catalogue.encode("onboardSet", {**h.gcs.catalogue.default("onboardSet"), "armed": True})
        gps_id, imu_id = h.admin.status(gps)["request_id"], h.admin.status(imu)["request_id"]
        assert gps_id not in range(0, 17) and imu_id not in range(0, 17), "request ids are not 1, 2, 3, ..."

        # ---- every attack, every 250 ms, while the rates are measured --------------------------------------
        t0 = time.monotonic()
        batches, sent = 0, {}
        while time.monotonic() - t0 < ATTACK_S:
            sent = attack_batch(rogue, gps_id, imu_id, armed)
            batches += 1
            h.run_for(BATCH_EVERY_S)
        t1 = time.monotonic()
        gps_hz = h.meter("gpsOut", "rmax1ob1").rate_hz(t0, t1)
        imu_hz = h.meter("imuOut", "fcs20").rate_hz(t0, t1)
        assert gps_hz == pytest.approx(1000 / GPS_MS, rel=0.10), f"gpsOut at {gps_hz:.1f} Hz under attack"
        assert imu_hz == pytest.approx(1000 / IMU_MS, rel=0.10), f"imuOut at {imu_hz:.1f} Hz under attack"
        for row in (gps, imu):
            s = h.admin.status(row)
            assert s["status"] == "active" and s["nack_reason"] is None, s
        assert sum(rogue.modem.snapshot()["dropped"].values()) == 0, "every forged byte reached its node"

        h.run_for(0.3)   # the last batch is handled everywhere
        primary = h.child_stats("primary")
        node = primary["node"]
        # refused and counted under its reason, at the vehicle ...
        assert node["drops"]["not_authorized"] >= batches * sent["refused_at_vehicle"], node["drops"]
        assert node["drops"]["not_allowed"] >= batches * sent["writes"], node["drops"]
        assert node["requests_limited"] >= batches, node
        assert len(owned_rows(primary, "rmax1ob1", "mallory")) <= 1, primary["pubsub"]
        rows = {(r["content"], r.get("destination"), r.get("owner")) for r in primary["pubsub"]["rmax1ob1"]}
        assert ("gpsOut", "gcs1", "gcs1") in rows, rows                  # the administrator's row survived
        assert ("navFilterState", "rmax1ob2", None) in rows, rows        # and the vehicle's own configured row
        assert dump(h, "primary", "onboardSet") == onboard_before, "a forged write changed onboardSet"
        # ... and at the GCS: forged NACKs ignored, the forged SUB_STOP refused
        gcs = h.gcs.counters()
        assert gcs["replies_unmatched"] >= batches * sent["nacks"], gcs
        assert gcs["drops"]["not_authorized"] >= batches * sent["stops_at_gcs"], gcs["drops"]
        # the policy never dropped a legitimate frame
        assert gcs["drops"]["not_allowed"] == 0
        for other in ("secondary", "backup"):
            assert h.child_stats(other)["node"]["drops"]["not_allowed"] == 0, other

        # ---- within the limits but "forever": the lease is clamped, the traffic ends with it ---------------
        radio = "gcsPortDatalink2"   # DATA for mallory reaches the GCS host over the radio and ends there
        rogue.request(lib.UB_ADMIN_PUB_REQUEST, "gpsOut", "mallory", 100, 0, 99)
        h.run_for(1.0)
        s = h.child_stats("primary")
        mine = owned_rows(s, "rmax1ob1", "mallory")
        assert len(mine) == 1 and mine[0]["content"] == "gpsOut" and mine[0]["period_ms"] == 100, mine
        assert 0 < mine[0]["lease_until_ms"] - s["t_ms"] <= MAX_LEASE_MS, mine
        assert s["node"]["leases_clamped"] >= 1
        flowing = h.gcs.link_counters()[radio]["drops"]["no_route"]
        h.run_for(MAX_LEASE_MS / 1000 + 0.5)
        assert owned_rows(h.child_stats("primary"), "rmax1ob1", "mallory") == []
        ended = h.gcs.link_counters()[radio]["drops"]["no_route"]
        assert ended > flowing, "mallory's data flowed until its lease ran out"
        h.run_for(1.0)
        assert h.gcs.link_counters()[radio]["drops"]["no_route"] == ended, "traffic to mallory after its lease"

        # ---- the administrator is still served, and the paper's flows never stopped ------------------------
        nav = h.add_row("subscription", "navFilterState", "rmax1ob2", "gcs1", 50)
        h.wait_status(nav, "active", 5.0)
        h.wait_data("navFilterState", "rmax1ob2", 5, 3.0)
        t2 = time.monotonic()
        h.run_for(1.5)
        assert h.meter("imuOut", "fcs20").rate_hz(t2, time.monotonic()) == pytest.approx(50, rel=0.10)
