"""The MAVLink bridge against an autopilot nobody here wrote (pymavlink's mavutil, mav_autopilot.py).

    autopilot (pymavlink, udp) <-MAVLink-> uavbus_mavbridge [mavbridge] <-udp-> uavbus_node [relay1]
                                                  ^                                  |
                                           udp    |                                  | udp
                                        rogue (Python Node)                gcs1 (Python GCS, 2 hops)

Checked, each able to fail:
  - ATTITUDE reaches the GCS two hops away at the autopilot's 50 Hz (±10 %), counted as *distinct*
    samples (time_boot_ms), so a bridge that resent stale values or dropped some would miss;
  - GLOBAL_POSITION_INT asked at 40 ms makes the bridge send SET_MESSAGE_INTERVAL 40000 µs: the
    autopilot's 10 Hz becomes 25 Hz at the GCS; when the GCS stops, the interval is reset (0);
  - a COMMAND_LONG the GCS writes reaches the autopilot with its parameters, and the autopilot's
    COMMAND_ACK comes back to the GCS as a COMMAND_ACK_77 delivery;
  - the same write from `rogue`, which the bridge's write policy does not name, is refused and
    counted (not_allowed) and never reaches the autopilot;
  - with a key on both ends, everything flows signed (pymavlink verifies the bridge's signatures),
    and an unsigned or wrongly signed ATTITUDE injected by the autopilot side is refused, counted
    by cause, and never reaches the GCS; a lost autopilot link is seen and counted. In that test the
    uavbus side is signed too (the configuration's "security" section, one fleet key): the bridge signs
    what it publishes and the GCS, which requires signed frames, verifies it two hops away.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from uavbus import Node
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import ProcessGroup
from uavbus.sim.secure import signed_config

from bridge_testutil import autopilot_argv

ATTITUDE, GPOS, CMD, ACK = "ATTITUDE_30", "GLOBAL_POSITION_INT_33", "COMMAND_LONG_76", "COMMAND_ACK_77"
MAV_CMD_COMPONENT_ARM_DISARM = 400
RATE_TOLERANCE = 0.10


def write_config(path: Path, ports: PortAllocator) -> dict[str, int]:
    a = {k: ports.port() for k in ("bridge_relay", "bridge_rogue", "relay_bridge", "relay_gcs", "gcs", "rogue")}

    def udp(bind: str, peer: str) -> dict[str, str]:
        return {"transport": "udp", "bind": f"127.0.0.1:{a[bind]}", "peer": f"127.0.0.1:{a[peer]}"}

    cfg = {
        "system": "mavtest",
        "entities": [
            {"name": "mavbridge", "links": ["toRelay", "toRogue"],
             "linktoentity": {"relay1": ["toRelay"], "gcs1": ["toRelay"], "rogue": ["toRogue"]}},
            {"name": "relay1", "links": ["toBridge", "toGcs"],
             "linktoentity": {"mavbridge": ["toBridge"], "gcs1": ["toGcs"]}},
            {"name": "gcs1", "links": ["toRelay"], "linktoentity": {"mavbridge": ["toRelay"], "relay1": ["toRelay"]}},
            {"name": "rogue", "links": ["toBridge"], "linktoentity": {"mavbridge": ["toBridge"]}},
        ],
        "nodes": {"bridge": ["mavbridge"], "relay": ["relay1"], "gcs": ["gcs1"], "rogue": ["rogue"]},
        "ports": {
            "mavbridge:toRelay": udp("bridge_relay", "relay_bridge"),
            "mavbridge:toRogue": udp("bridge_rogue", "rogue"),
            "relay1:toBridge": udp("relay_bridge", "bridge_relay"),
            "relay1:toGcs": udp("relay_gcs", "gcs"),
            "gcs1:toRelay": udp("gcs", "relay_gcs"),
            "rogue:toBridge": udp("rogue", "bridge_rogue"),
        },
        # Only gcs1 may command the autopilot; gcs1 stores the ACKs the bridge sends straight back.
        "security": {
            "write": {
                "mavbridge": [{"from": "gcs1", "content": [CMD, "SET_MODE_11"]}],
                "gcs1": [{"from": "mavbridge", "content": ACK}],
            },
        },
    }
    path.write_text(json.dumps(cfg, indent=1))
    return a


class World:
    """Autopilot + bridge + relay as processes; the GCS and the rogue as Python nodes here."""

    def __init__(self, tmp: Path, group: ProcessGroup, mavbridge: dict[str, str], uavbus_node: Path,
                 key: Path | None = None, uavbus_signed: bool = False) -> None:
        ports = PortAllocator()
        self.cfg = tmp / "mavtest.json"
        write_config(self.cfg, ports)
        if uavbus_signed:
            self.cfg = signed_config(self.cfg, tmp / "signed")
        ap_port, mav_port = ports.port(), ports.port()
        self.autopilot = group.spawn(autopilot_argv(ap_port, key), "autopilot", ready_timeout=10)
        argv = [mavbridge["program"], "--config", str(self.cfg), "--node", "bridge", "--stats-ms", "0",
                "--mavlink", f"udp:bind=127.0.0.1:{mav_port},peer=127.0.0.1:{ap_port}"]
        if key is not None:
            argv += ["--mavlink-key", str(key)]
        self.bridge = group.spawn(argv, "bridge", ready_timeout=10)
        self.relay = group.spawn([str(uavbus_node), "--config", str(self.cfg), "--node", "relay", "--stats-ms", "0"],
                                 "relay", ready_timeout=10)
        self.gcs = Node(mavbridge["catalogue"], config=self.cfg, node="gcs")
        self.gcs.open_ports_from_config()
        self.rogue = Node(mavbridge["catalogue"], config=self.cfg, node="rogue")
        self.rogue.open_ports_from_config()
        group.on_close(self.gcs.close)
        group.on_close(self.rogue.close)
        self.bridge.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "connected", 10,
                               what="autopilot connected")

    def run(self, seconds: float, on_msg=None) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.gcs.poll(0.002)
            self.rogue.poll(0)
            for msg in list(self.gcs._inbox) if on_msg else ():
                on_msg(msg)
            if on_msg:
                self.gcs._inbox.clear()

    def samples(self, name: str, seconds: float, warmup_s: float = 8.0) -> list[tuple[float, int]]:
        """(arrival s, time_boot_ms) of `name` at the GCS for `seconds`, once data flows."""
        got: list[tuple[float, int]] = []
        deadline = time.monotonic() + warmup_s
        while not got and time.monotonic() < deadline:
            self.run(0.05, lambda m: got.append((time.monotonic(), m.value["time_boot_ms"])) if m.name == name else None)
        assert got, f"no {name} reached the GCS within {warmup_s} s; bridge: {self.bridge.request_stats()}"
        got.clear()
        self.run(seconds, lambda m: got.append((time.monotonic(), m.value["time_boot_ms"])) if m.name == name else None)
        return got


def distinct_rate(samples: list[tuple[float, int]], seconds: float) -> float:
    return len({boot for _, boot in samples}) / seconds


def test_telemetry_rates_and_commands_through_two_hops(tmp_path, group, mavbridge, uavbus_node):
    w = World(tmp_path, group, mavbridge, uavbus_node)
    w.gcs.subscribe("gcs1", ATTITUDE, source="mavbridge", period_ms=20)
    w.gcs.subscribe("gcs1", GPOS, source="mavbridge", period_ms=40)
    att = w.samples(ATTITUDE, 3.0)
    # Distinct samples, not frames: a bridge resending old values would not reach 50 Hz of new ones.
    assert distinct_rate(att, 3.0) == pytest.approx(50.0, rel=RATE_TOLERANCE), att[:5]
    assert len(att) == len({b for _, b in att}), "a sample reached the GCS twice"
    # 25 Hz of GLOBAL_POSITION_INT exists only if the autopilot honoured the bridge's SET_MESSAGE_INTERVAL.
    gpos = w.samples(GPOS, 3.0)
    assert distinct_rate(gpos, 3.0) == pytest.approx(25.0, rel=RATE_TOLERANCE)
    intervals = w.autopilot.all("interval")
    assert {(e["msgid"], e["requested_us"]) for e in intervals} >= {(33, 40000)}, intervals

    # A command from gcs1 (allowed) and the same from rogue (not allowed). The GCS keeps storage for
    # the ACK the bridge sends straight back.
    w.gcs.bind(ACK)
    cmd = w.gcs.bind(CMD)
    cmd.update(target_system=1, target_component=1, command=MAV_CMD_COMPONENT_ARM_DISARM, confirmation=0,
               param1=1.0, param2=0.0, param3=0.0, param4=0.0, param5=0.0, param6=0.0, param7=0.0)
    bad = w.rogue.bind(CMD)
    bad.update(target_system=1, target_component=1, command=MAV_CMD_COMPONENT_ARM_DISARM, confirmation=0,
               param1=0.0, param2=21196.0, param3=0.0, param4=0.0, param5=0.0, param6=0.0, param7=0.0)
    w.rogue.send("rogue", CMD, to="mavbridge")
    w.gcs.send("gcs1", CMD, to="mavbridge")
    acks = []
    deadline = time.monotonic() + 5
    while not acks and time.monotonic() < deadline:
        w.run(0.05, lambda m: acks.append(m.value) if m.name == ACK else None)
    assert acks, f"no COMMAND_ACK back at the GCS: {w.gcs.counters()}; bridge: {w.bridge.request_stats()}"
    assert acks[0]["command"] == MAV_CMD_COMPONENT_ARM_DISARM and acks[0]["result"] == 0, acks
    got = [e for e in w.autopilot.all("command") if e["command"] == MAV_CMD_COMPONENT_ARM_DISARM]
    assert len(got) == 1 and got[0]["params"][0] == 1.0, f"the autopilot saw {got}"
    assert got[0]["from"] == [255, 190], got  # the bridge's MAVLink ids

    # Unsubscribing resets the intervals the bridge had changed.
    for row in w.gcs.pubsub_rows("gcs1"):
        w.gcs.stop("gcs1", row["row"])
    mark_deadline = time.monotonic() + 5
    while time.monotonic() < mark_deadline and (33, 0) not in {(e["msgid"], e["requested_us"])
                                                                for e in w.autopilot.all("interval")}:
        w.run(0.1)
    assert (33, 0) in {(e["msgid"], e["requested_us"]) for e in w.autopilot.all("interval")}, \
        w.autopilot.all("interval")

    stats = w.bridge.request_stats()
    assert stats["links"]["toRogue"]["drops"]["not_allowed"] >= 1, stats["links"]
    assert stats["mavlink"]["commands_forwarded"] == 1, stats["mavlink"]
    assert stats["mavlink"]["acks_routed"] == 1, stats["mavlink"]
    assert stats["mavlink"]["intervals_granted"] >= 2, stats["mavlink"]
    assert stats["mavlink"]["bad_crc"] == 0 and stats["mavlink"]["other_source"] == 0, stats["mavlink"]


def test_signed_link_refuses_unsigned_and_forged(tmp_path, group, mavbridge, uavbus_node):
    key = tmp_path / "mav.key"
    key.write_text("# MAVLink signing key of the test vehicle\n" + os.urandom(32).hex() + "\n")
    key.chmod(0o600)
    w = World(tmp_path, group, mavbridge, uavbus_node, key=key, uavbus_signed=True)
    assert w.bridge.wait_ready()["uavbus_signed"] and w.bridge.wait_ready()["signing"]
    w.gcs.subscribe("gcs1", ATTITUDE, source="mavbridge", period_ms=20)
    att = w.samples(ATTITUDE, 2.0)
    assert distinct_rate(att, 2.0) == pytest.approx(50.0, rel=RATE_TOLERANCE)
    # An attacker on the autopilot's side without the key: unsigned, then signed with a wrong key.
    w.autopilot.send("send_unsigned 2.5")
    w.autopilot.send("send_badsig 2.75")
    rolls: list[float] = []
    w.run(1.0, lambda m: rolls.append(m.value["roll"]) if m.name == ATTITUDE else None)
    assert rolls and all(abs(r) < 1.0 for r in rolls), "a forged ATTITUDE reached the GCS"
    stats = w.bridge.request_stats()["mavlink"]
    assert stats["unsigned_refused"] == 1 and stats["bad_signature"] == 1, stats
    ap = w.autopilot
    mark = ap.mark()
    ap.send("stats")
    sig = ap.wait_event("stats", 3, since=mark)["signing"]
    assert sig["goodsig"] > 0 and sig["badsig"] == 0, sig  # pymavlink verified every bridge message
    # The autopilot goes silent for longer than the link timeout: lost, then back.
    ap.send("pause 4.5")
    w.bridge.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "lost", 8, what="link lost")
    w.bridge.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "connected"
                        and e is not w.bridge.all("autopilot")[0], 8, what="link back")
    stats = w.bridge.request_stats()
    assert stats["mavlink"]["link_lost"] == 1
    assert stats["security"]["signed_out"] > 0 and stats["security"]["auth_failures"] == 0, stats["security"]
    gsec = w.gcs.security()
    assert gsec["verified_in"] >= len(att) and gsec["auth_failures"] == 0, gsec
