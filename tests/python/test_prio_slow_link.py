"""Priorities on slow links from Python (issue 28): the content classes a node is given decide how a burst is
queued on a byte-budget port (an impairment with rate=5760 and prio on). Injected clock: the burst happens at
one instant, so what waits, what is shed and what is pushed back depends only on the classes and the bounds
(UB_PRIO_DEPTH_*), never on the machine's speed."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from binding_testutil import TABLE2, FakeClock, Generated
from uavbus import Node
from uavbus._bindings.ub_error import ConfigError, InvalidArgumentError

pytestmark = pytest.mark.timeout(60)
BURST = 40


def burst(flightsw: Generated, classes: dict[str, str] | None, config: Path = TABLE2) -> tuple[dict, dict]:
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=config, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=config, node="primary", clock=clock)
    try:
        gcs.open_port("gcsPortDatalink1", "udp:bind=127.0.0.1:0")
        pg = gcs.local_port("gcsPortDatalink1")
        air.open_port("onboardPortDatalink1", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{pg}")
        air.set_link_impairment("onboardPortDatalink1", rate=5760, prio=True)
        if classes is not None:
            air.wire.set_priorities(classes)
        for _ in range(BURST):  # one instant: the medium takes the first frame, the rest wait by class
            air.send("rmax1ob1", "gpsOut", "gcs1")
        link = air.link_counters()["onboardPortDatalink1"]
        imp = air.port_info("onboardPortDatalink1")["impair"]
        return link, imp
    finally:
        gcs.close()
        air.close()


def test_telemetry_burst_sheds_oldest_and_counts_it(flightsw: Generated) -> None:
    link, imp = burst(flightsw, None)
    # gpsOut is telemetry by default: 1 on the medium, 12 waiting (UB_PRIO_DEPTH_TELEMETRY), the rest each shed
    # the oldest waiting one; nothing is pushed back.
    assert link["drops"]["shed"] == imp["shed"] == BURST - 1 - 12
    assert link["drops"]["backpressure"] == 0
    assert link["frames_out"] == BURST


def test_control_content_is_pushed_back_not_shed(flightsw: Generated) -> None:
    link, imp = burst(flightsw, {"gpsOut": "control"})
    # Configured control: its queue holds 8 (UB_PRIO_DEPTH_CONTROL); the rest are refused, never shed.
    assert link["drops"]["shed"] == imp["shed"] == 0
    assert link["drops"]["backpressure"] == imp["queue_full"] == BURST - 1 - 8
    assert link["frames_out"] == 1 + 8


def test_config_priorities_section(flightsw: Generated, tmp_path: Path) -> None:
    """The same classes from the config file's "priorities" section (every node of the fleet reads it)."""
    cfg = json.loads(TABLE2.read_text())
    cfg["priorities"] = {"gps*": "control"}
    path = tmp_path / "table2_prio.json"
    path.write_text(json.dumps(cfg))
    link, imp = burst(flightsw, None, path)
    assert link["drops"]["shed"] == imp["shed"] == 0
    assert link["drops"]["backpressure"] == BURST - 1 - 8
    cfg["priorities"] = {"gpsOutTypo": "control"}
    path.write_text(json.dumps(cfg))
    with pytest.raises(ConfigError, match="priorities.gpsOutTypo': matches no content"):
        Node(flightsw.catalogue, config=path, node="primary", clock=FakeClock())


def test_priorities_refuse_unknown_names(flightsw: Generated) -> None:
    node = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=FakeClock())
    try:
        with pytest.raises(InvalidArgumentError, match="urgent"):
            node.wire.set_priorities({"gpsOut": "urgent"})
        with pytest.raises(InvalidArgumentError, match="noSuchContent"):
            node.wire.set_priorities({"noSuchContent": "control"})
        node.wire.set_priorities({"gpsOut": "bulk"})
        node.wire.set_priorities(None)
    finally:
        node.close()


def frames_in(data: bytes) -> list[bytes]:
    """Full uavbus frames in a byte stream (sync A5 5B, msg_size at offset 6), in order."""
    out, i = [], 0
    while True:
        i = data.find(b"\xa5\x5b", i)
        if i < 0 or i + 8 > len(data):
            return out
        size = data[i + 6] | data[i + 7] << 8
        if size < 64 or i + size > len(data):
            i += 1
            continue
        out.append(data[i:i + size])
        i += size


def test_serial_port_with_prio_sends_a_command_ahead_of_a_telemetry_burst(flightsw: Generated) -> None:
    """`prio=1` on a serial port: the bandwidth model at the port's own baud rate (57,600 -> 5,760 B/s) sends by
    class, so the request queued behind a burst of telemetry reaches the wire right after the frame that was
    already on it. The other end of the pty is read after the fact: nothing here depends on the machine's speed."""
    master, slave = os.openpty()
    clock = FakeClock()
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    try:
        os.set_blocking(master, False)
        air.open_port("onboardPortDatalink1", f"serial:device={os.ttyname(slave)},baud=57600,prio=1")
        assert air.port_info("onboardPortDatalink1")["spec"].endswith(",prio=1")
        for _ in range(BURST):
            air.send("rmax1ob1", "gpsOut", "gcs1")
        air.subscribe("rmax1ob1", "imuOut", source="gcs1", period_ms=1000)  # a SUB_REQUEST: class command
        data = b""
        for _ in range(400):  # 2 s of injected time: the burst that was kept drains at 5,760 B/s
            clock.t += 5
            air.poll(0)
            try:
                data += os.read(master, 65536)
            except BlockingIOError:
                pass
        admin = [f[48] for f in frames_in(data)]
        assert admin[0] == 0 and admin[1] == 1, str(admin)  # DATA already on the wire, then the PUB_REQUEST
        # The burst that was kept: the frame on the wire and the 12 the telemetry queue holds (the rest shed);
        # the request's retries go ahead of what is left of it too.
        assert admin.count(0) == 1 + 12, str(admin)
        link = air.link_counters()["onboardPortDatalink1"]
        assert link["drops"]["shed"] == BURST - 1 - 12
    finally:
        air.close()
        os.close(master)
        os.close(slave)


def test_prio_needs_a_byte_rate(flightsw: Generated) -> None:
    node = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=FakeClock())
    try:
        with pytest.raises(Exception, match="prio=1' needs the port's byte rate"):
            node.open_port("onboardPortDatalink1", "udp:bind=127.0.0.1:0,prio=1")
    finally:
        node.close()
