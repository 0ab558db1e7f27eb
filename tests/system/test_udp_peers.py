"""UDP peers a ground station can use (issue 14, item 3), with real processes on 127.0.0.1.

- A vehicle (C `uavbus_node`) whose UDP port has no configured peer learns its peers from the frames
  its node accepted: a Python GCS on an ephemeral port gets its publication, and a second monitor
  (`uavbus spy`, another process on another ephemeral port) sees the same traffic at the same time.
- Garbage from a third address teaches the vehicle nothing (the node's verdict, not the datagram).
- A port with a fixed peer refuses a stranger's frames: counted as `foreign`, reported once (one
  `warning` event naming the stranger and what to do), never delivered.
- `uavbus log play --into udp:peer=...` (no bind: an ephemeral source port) into a node that learns its
  peers delivers every frame; into a fixed-peer port it is refused, counted, and logged once.
- On a signed network (issue 11), forged frames (unsigned, a guessed key, an unknown key id) and copies of
  genuine frames replayed from a new address make no peer: only a frame the node accepted as new does.
"""

from __future__ import annotations

import json
import logging
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest

from uavbus.sim.hitl import catalogue_for
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import ProcessGroup

pytestmark = pytest.mark.timeout(90)

CONFIG = {
    "system": "udp-peers",
    "entities": [
        {"name": "rmax1ob1", "links": ["radio"], "linktoentity": {"gcs1": ["radio"], "mon1": ["radio"]}},
        {"name": "gcs1", "links": ["gcsRadio"], "linktoentity": {"rmax1ob1": ["gcsRadio"]}},
        {"name": "mon1", "links": ["monRadio"], "linktoentity": {"rmax1ob1": ["monRadio"]}},
    ],
    "nodes": {"vehicle": ["rmax1ob1"], "gcs": ["gcs1"], "monitor": ["mon1"]},
}


@pytest.fixture
def config(tmp_path: Path) -> Path:
    path = tmp_path / "peers.json"
    path.write_text(json.dumps(CONFIG, indent=1))
    return path


def start_vehicle(group: ProcessGroup, program: Path, config: Path, spec: str) -> tuple[object, int]:
    proc = group.spawn([program, "--config", config, "--node", "vehicle", "--port", f"radio={spec}",
                        "--stats-ms", "0"], "vehicle", ready_timeout=8.0)
    port = proc.wait_ready()["ports"]["radio"]["local_port"]
    return proc, int(port)


def test_gcs_on_an_ephemeral_port_and_a_second_monitor(program: Path, config: Path) -> None:
    from uavbus import Catalogue, Node

    catalogue = catalogue_for(program)
    with ProcessGroup() as group:
        vehicle, vport = start_vehicle(group, program, config, "udp:bind=127.0.0.1:0")
        gcs = Node(Catalogue.load(catalogue), config=config, node="gcs")
        spy = None
        try:
            gcs.open_port("gcsRadio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}")
            # A third address sends garbage first: the vehicle's node refuses it, so it is not learned.
            junk = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            junk.sendto(b"not a frame at all" * 4, ("127.0.0.1", vport))
            admin = gcs.admin("gcs1")
            row = admin.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=100)
            gcs.bind("gpsOut")
            admin.activate(row)
            got = [m for m, _ in zip(gcs.messages(timeout=5.0), range(5))]
            assert len(got) == 5 and all(m.name == "gpsOut" and m.source == "rmax1ob1" for m in got)
            assert admin.status(row)["status"] == "active"
            # junk's socket never hears back: it was not made a peer.
            junk.settimeout(0.3)
            with pytest.raises(socket.timeout):
                junk.recvfrom(2048)
            junk.close()

            # A second monitor on another ephemeral port: its subscription request makes it a peer too,
            # and from then on it sees the GCS's stream as well as its own.
            spy = subprocess.Popen(
                [sys.executable, "-m", "uavbus.cli", "spy", "--config", str(config), "--node", "monitor",
                 "--catalogue", str(catalogue), "--port", f"monRadio=udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}",
                 "--subscribe", "navFilterState@rmax1ob1/100", "--duration", "2.5", "--interval", "10"],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 20
            while spy.poll() is None and time.monotonic() < deadline:
                gcs.poll(0.02)  # the GCS keeps receiving (and renewing its row) meanwhile
            out, err = spy.communicate(timeout=10)
            assert spy.returncode == 0, err
            lines = out.splitlines()
            assert any(line.split()[:2] == ["gpsOut", "rmax1ob1"] for line in lines), out
            assert any(line.split()[:2] == ["navFilterState", "rmax1ob1"] for line in lines), out
            still = [m for m, _ in zip(gcs.messages(timeout=1.0), range(3))]
            assert len(still) == 3, "the GCS stopped receiving when the monitor joined"
            stats = vehicle.request_stats()["links"]["radio"]["udp"]
            assert stats["peers_learned"] == 2 and stats["foreign"] == 0
            assert stats["no_peer"] >= 0
            assert vehicle.all("warning") == []
        finally:
            if spy is not None and spy.poll() is None:
                spy.kill()
                spy.wait()
            gcs.close()


def test_a_fixed_peer_refuses_strangers_and_says_so_once(program: Path, config: Path) -> None:
    from uavbus import Catalogue, Node

    alloc = PortAllocator()
    gcs_addr = alloc.addr()
    with ProcessGroup() as group:
        vehicle, vport = start_vehicle(group, program, config, f"udp:bind=127.0.0.1:0,peer={gcs_addr}")
        stranger = Node(Catalogue.load(catalogue_for(program)), config=config, node="gcs")
        try:
            stranger.open_port("gcsRadio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}")
            stranger_port = stranger.local_port("gcsRadio")
            stranger.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=100)  # requests every retry
            end = time.monotonic() + 2.0  # the request is retried meanwhile: several refused datagrams
            while time.monotonic() < end:
                stranger.poll(0.02)
            msg = vehicle.wait_event("warning", 5.0)["message"]
            assert f"refused a datagram from 127.0.0.1:{stranger_port}" in msg
            assert f"not this link's peer ({gcs_addr})" in msg and "accept=any" in msg
            udp = vehicle.request_stats()["links"]["radio"]["udp"]
            assert udp["foreign"] >= 2 and udp["datagrams_in"] == 0
            assert len(vehicle.all("warning")) == 1, "reported once, counted always"
            assert stranger.link_counters()["gcsRadio"]["frames_in"] == 0
        finally:
            stranger.close()


@pytest.mark.parametrize("accept", ["any", "learn"])
def test_a_signed_vehicle_learns_no_peer_from_forged_or_replayed_datagrams(program: Path, config: Path,
                                                                           tmp_path: Path, accept: str) -> None:
    from uavbus import Catalogue, Node
    from uavbus.sim.attacker import forge
    from uavbus.sim.secure import signed_config

    signed = signed_config(config, tmp_path)
    cat = Catalogue.load(catalogue_for(program))
    with ProcessGroup() as group:
        vehicle, vport = start_vehicle(group, program, signed, f"udp:bind=127.0.0.1:0,accept={accept}")
        attacker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        attacker.bind(("127.0.0.1", 0))
        gcs = Node(cat, config=signed, node="gcs")
        sent: list[bytes] = []
        gcs.on_frame(lambda _link, direction, frame, _t: sent.append(frame) if direction == "tx" else None)
        try:
            # Before any peer: the subscription request of gcs1, forged in the three forms a forger can make.
            request = struct.pack("<III12s", 77, 100, 0, b"mallory".ljust(12, b"\0"))
            for mode, kw in (("unsigned", {}), ("signed", {}), ("signed", {"key_id": 99})):
                attacker.sendto(forge(cat, "gpsOut", "gcs1", "rmax1ob1", request, admin=1, counter=10**12,
                                      mode=mode, **kw), ("127.0.0.1", vport))
            time.sleep(0.3)
            # The genuine GCS is learned from its signed frames and gets its publication.
            gcs.open_port("gcsRadio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}")
            gcs.bind("gpsOut")
            gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=100)
            got = [m for m, _ in zip(gcs.messages(timeout=5.0), range(5))]
            assert len(got) == 5
            # Copies of genuine frames from the attacker's address: authentic, already seen (duplicates).
            genuine = [f for f in sent if f[3] & 0x10][-4:]
            assert genuine
            for f in genuine:
                attacker.sendto(f, ("127.0.0.1", vport))
            end = time.monotonic() + 0.6
            while time.monotonic() < end:
                gcs.poll(0.02)
            attacker.settimeout(0.3)
            with pytest.raises(socket.timeout):     # never made a peer: the vehicle sends it nothing
                attacker.recvfrom(2048)
            st = vehicle.request_stats()
            assert st["links"]["radio"]["udp"]["peers_learned"] == 1, st["links"]["radio"]["udp"]
            drops = st["links"]["radio"]["drops"]
            assert drops["unsigned"] == 1 and drops["bad_tag"] == 1 and drops["unknown_key"] == 1, drops
            assert drops["duplicate"] + drops["replay"] >= len(genuine), drops
            assert [m for m, _ in zip(gcs.messages(timeout=2.0), range(3))], "the GCS lost its stream"
        finally:
            attacker.close()
            gcs.close()


def record_log(program: Path, config: Path, log: Path) -> int:
    """A short GCS log of gpsOut from the vehicle; returns the number of DATA records."""
    from uavbus import Catalogue, Node
    from uavbus.logfile import LogReader

    with ProcessGroup() as group:
        _, vport = start_vehicle(group, program, config, "udp:bind=127.0.0.1:0")
        gcs = Node(Catalogue.load(catalogue_for(program)), config=config, node="gcs")
        try:
            gcs.open_port("gcsRadio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}")
            gcs.record(log)
            gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
            n = 0
            for _ in gcs.messages(timeout=3.0):
                n += 1
                if n == 12:
                    break
            gcs.stop_recording()
        finally:
            gcs.close()
    return sum(1 for r in LogReader(log) if r.header.admin == 0)


def play(log: Path, into: str) -> dict:
    out = subprocess.run([sys.executable, "-m", "uavbus.cli", "log", "play", str(log), "--into", into, "--fast"],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_log_play_into_a_node_that_learns_its_peers(program: Path, config: Path, tmp_path: Path,
                                                    caplog: pytest.LogCaptureFixture) -> None:
    from uavbus import Catalogue, Node

    log = tmp_path / "gcs.ublog"
    data_records = record_log(program, config, log)
    assert data_records >= 10
    cat = Catalogue.load(catalogue_for(program))
    for spec, delivered_all in (("udp:bind=127.0.0.1:0", True), ("udp:bind=127.0.0.1:0,peer=127.0.0.1:9", False)):
        node = Node(cat, config=config, node="gcs")
        try:
            node.bind("gpsOut")
            node.open_port("gcsRadio", spec)
            port = node.local_port("gcsRadio")
            caplog.clear()
            with caplog.at_level(logging.WARNING, logger="uavbus"):
                report = play(log, f"udp:peer=127.0.0.1:{port}")
                got = [m for m in node.messages(timeout=0.5)]
            assert report["frames"] >= data_records
            udp = node.port_info("gcsRadio")["udp"]
            if delivered_all:
                assert len(got) == data_records and udp["foreign"] == 0
                assert udp["peers_learned"] == 1 and caplog.records == []
            else:
                assert got == [] and udp["foreign"] == report["frames"]
                warnings = [r.getMessage() for r in caplog.records]
                assert len(warnings) == 1 and "refused a datagram from 127.0.0.1:" in warnings[0]
                assert node.notices == [warnings[0].split(": ", 1)[1]]
        finally:
            node.close()
