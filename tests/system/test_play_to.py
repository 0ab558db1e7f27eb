"""Playback that stimulates the component you choose (issue 25, item 4): a recorded imuOut stream (fcs20 ->
gcs1) is played into a *different* entity, a new estimator process (`uavbus_node` hosting est1), with the
recorded timing; on a signed network it works with the player's own key and is refused, with the reason in
one line, without it or with a key that is not the fleet's; an entity that does not know the player gets a one-line reason too.

The estimator records what it receives (its own ub_log): arrivals are measured by the receiving process,
not by the player.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest

from uavbus.logfile import LogReader
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeProcess
from uavbus.sim.secure import new_key, signed_config

pytestmark = pytest.mark.timeout(120)

PERIOD_MS, FRAMES = 20, 60


@pytest.fixture(scope="module")
def recording(program: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """gcs1's log of an imuOut stream from fcs20 every 20 ms (two Python nodes over UDP)."""
    from uavbus import Catalogue, Node

    d = tmp_path_factory.mktemp("rec")
    cat = Catalogue.load(str(catalogue_for(program)))
    a, b = PortAllocator().addr(), PortAllocator().addr()
    src, dst = Node(cat, node="fcs"), Node(cat, node="gcs")
    try:
        for node, me, peer, bind, to in ((src, "fcs20", "gcs1", a, b), (dst, "gcs1", "fcs20", b, a)):
            node.add_entity(me, local=True)
            node.add_entity(peer)
            node.add_link(me, 0, "l")
            node.set_mask(me, peer, 1)
            node.open_port("l", f"udp:bind={bind},peer={to}")
        dst.bind("imuOut")
        dst.record(str(d / "gcs1.ublog"))
        imu = src.bind("imuOut")
        t = time.monotonic()
        for k in range(FRAMES):
            imu.sampleCount = k
            src.send("fcs20", "imuOut", "gcs1")
            t += PERIOD_MS / 1000.0
            while time.monotonic() < t:
                dst.poll(0.002)
                src.service()
        end = time.monotonic() + 0.2
        while time.monotonic() < end:
            dst.poll(0.01)
        dst.stop_recording()
    finally:
        src.close()
        dst.close()
    return d / "gcs1.ublog"


@pytest.fixture(scope="module")
def two_sources(program: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """gcs1's log of imuOut from fcs20 and gpsOut from rmax1ob1 (each its own node and UDP link), 30 of each."""
    from uavbus import Catalogue, Node

    d = tmp_path_factory.mktemp("rec2")
    cat = Catalogue.load(str(catalogue_for(program)))
    alloc = PortAllocator()
    dst = Node(cat, node="gcs")
    srcs = {"fcs20": Node(cat, node="fcs"), "rmax1ob1": Node(cat, node="primary")}
    try:
        dst.add_entity("gcs1", local=True)
        for k, (name, src) in enumerate(srcs.items()):
            here, there = alloc.addr(), alloc.addr()
            src.add_entity(name, local=True)
            src.add_entity("gcs1")
            src.add_link(name, 0, "l")
            src.set_mask(name, "gcs1", 1)
            src.open_port("l", f"udp:bind={here},peer={there}")
            dst.add_entity(name)
            dst.add_link("gcs1", k, f"l{k}")
            dst.set_mask("gcs1", name, 1 << k)
            dst.open_port(f"l{k}", f"udp:bind={there},peer={here}")
        dst.bind("imuOut")
        dst.bind("gpsOut")
        dst.record(str(d / "gcs1.ublog"))
        t = time.monotonic()
        for _ in range(30):
            srcs["fcs20"].send("fcs20", "imuOut", "gcs1")
            srcs["rmax1ob1"].send("rmax1ob1", "gpsOut", "gcs1")
            t += PERIOD_MS / 1000.0
            while time.monotonic() < t:
                dst.poll(0.002)
        end = time.monotonic() + 0.2
        while time.monotonic() < end:
            dst.poll(0.01)
        dst.stop_recording()
    finally:
        for n in (dst, *srcs.values()):
            n.close()
    return d / "gcs1.ublog"


def estimator(program: Path, tmp: Path, *, signed_with: Path | None = None, identities: Path | None = None,
              write: bool = True, knows: tuple[str, ...] = ("fcs20",), port: str = "udp:bind={mine}",
              ) -> tuple[NodeProcess, str, str, Path]:
    """A new estimator process hosting est1; it knows fcs20 (its configuration says so), not gcs1. With
    `identities`, a fleet with an identity per entity made there (`uavbus keys fleet`): origin tags required,
    and (`write`) a write rule that lets est1 store what the known entities send it unasked."""
    alloc = PortAllocator()
    mine, player = alloc.addr(), alloc.addr()
    cfg = tmp / "est.json"
    doc: dict = {"system": "replay", "nodes": {"est": ["est1"]}, "entities": [
        {"name": "est1", "links": ["in"], "linktoentity": {k: "0x00000001" for k in knows}},
        *({"name": k} for k in knows)]}
    if identities is not None:   # the identities' roles turn the policy on: without a rule, unasked DATA is refused
        doc["security"] = {"write": {"est1": [{"from": list(knows), "content": "*"}]} if write else {}}
    cfg.write_text(json.dumps(doc))
    if signed_with is not None:
        cfg = signed_config(cfg, tmp, keys_dir=signed_with)
    if identities is not None:
        from uavbus import keys

        cfg, _roles = keys.fleet(str(cfg), str(identities), days=1)
    log = tmp / "est1.ublog"
    proc = NodeProcess([str(program), "--config", str(cfg), "--node", "est", "--port", "in=" + port.format(mine=mine),
                        "--record", str(log)], "est")
    proc.start()
    proc.wait_ready(8.0)
    return proc, mine, player, log


def play(log: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "uavbus.cli", "log", "play", str(log), *args],
                          capture_output=True, text=True, timeout=60)


def arrivals(log: Path, src: str, dest: str) -> list[int]:
    out = []
    for r in LogReader(str(log)).records():
        h = r.header
        if r.dir == "rx" and h.admin == 0 and h.src_id.rstrip(b"\0") == src.encode() and \
                h.dest_id.rstrip(b"\0") == dest.encode():
            out.append(r.t_ms)
    return out


def p50_gap(times: list[int]) -> float:
    return statistics.median(b - a for a, b in zip(times, times[1:]))


def test_recorded_stream_into_another_entity_with_its_timing(recording: Path, program: Path, tmp_path: Path) -> None:
    recorded = arrivals(recording, "fcs20", "gcs1")
    assert len(recorded) >= FRAMES - 2, len(recorded)
    proc, mine, player, log = estimator(program, tmp_path)
    try:
        r = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--only", "imuOut")
        assert r.returncode == 0, r.stderr
        report = json.loads(r.stdout.strip().splitlines()[-1])
        assert report["to"] == "est1" and report["as"] == "fcs20" and report["frames"] == len(recorded), report
        assert report["stored"] is True, report   # est1's imuOut, read back: the last frame played
        time.sleep(0.3)
    finally:
        proc.stop()
    got = arrivals(log, "fcs20", "est1")
    assert len(got) == len(recorded), (len(got), len(recorded))
    # The recorded timing, as the estimator's own log sees it (1 ms clock steps).
    assert abs(p50_gap(got) - p50_gap(recorded)) <= 1.0, str([b - a for a, b in zip(got, got[1:])]) + " rec " + str([b - a for a, b in zip(recorded, recorded[1:])])


def test_signed_replay_needs_the_players_key_and_says_why(recording: Path, program: Path, tmp_path: Path) -> None:
    keys = tmp_path / "keys"
    proc, mine, player, log = estimator(program, tmp_path, signed_with=keys)
    try:
        refused = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--only", "imuOut")
        assert refused.returncode != 0
        line = refused.stderr.strip().splitlines()[-1]
        assert line.startswith("uavbus log play: no answer from est1") and "key is missing (--key FILE)" in line, line
        # A key that is not the fleet's (same id, other bytes): refused too, and the line says which case it is.
        wrong = new_key(tmp_path / "other", 1)
        refused = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--only", "imuOut",
                       "--key", str(wrong))
        assert refused.returncode != 0
        line = refused.stderr.strip().splitlines()[-1]
        assert line.startswith("uavbus log play: no answer from est1") and f"signed with {wrong}" in line \
            and "the key is not the fleet key" in line, line
        ok = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--only", "imuOut",
                  "--key", str(keys / "fleet-1.key"), "--fast")
        assert ok.returncode == 0, ok.stderr
        report = json.loads(ok.stdout.strip().splitlines()[-1])
        assert report["signed"] and report["frames"] >= FRAMES - 2, report
        time.sleep(0.3)
        stats = proc.request_stats()
    finally:
        proc.stop()
    got = arrivals(log, "fcs20", "est1")
    assert len(got) == report["frames"], (len(got), report)
    # The estimator refused the unsigned attempt's frames (the probe) as unsigned and the wrong key's as bad tags:
    # nothing got in from either.
    drops = stats["node"]["drops"]
    assert drops.get("unsigned", 0) > 0 and drops.get("bad_tag", 0) > 0, drops


def test_identity_fleet_replay_carries_the_players_origin_tags(recording: Path, program: Path, tmp_path: Path) -> None:
    """In a fleet with identities (issue 23) the group key is not enough: est1 refuses frames without an origin
    tag, and the line says that may be why; with the player's identity file (--identity) the replay is
    delivered, and est1's write rule is what lets it store the data."""
    fleet = tmp_path / "fleet"
    proc, mine, player, log = estimator(program, tmp_path, identities=fleet)
    try:
        into = f"udp:bind={player},peer={mine}"
        refused = play(recording, "--to", "est1", "--into", into, "--only", "imuOut", "--key", str(fleet / "fleet-1.key"))
        assert refused.returncode != 0
        line = refused.stderr.strip().splitlines()[-1]
        assert line.startswith("uavbus log play: no answer from est1") and "est1 checks origin tags" in line \
            and "no_origin" in line, line
        ok = play(recording, "--to", "est1", "--into", into, "--only", "imuOut", "--key", str(fleet / "fleet-1.key"),
                  "--identity", str(fleet / "fcs20.id"), "--fast")
        assert ok.returncode == 0, ok.stderr
        report = json.loads(ok.stdout.strip().splitlines()[-1])
        assert report["signed"] and report["identity"] and report["frames"] >= FRAMES - 2, report
        assert report["stored"] is True, report
        time.sleep(0.3)
        drops = proc.request_stats()["node"]["drops"]
    finally:
        proc.stop()
    assert len(arrivals(log, "fcs20", "est1")) == report["frames"], report
    assert drops.get("no_origin", 0) > 0 and drops.get("not_allowed", 0) == 0, drops   # the first try's, not these
    # The same replay into an estimator whose write policy does not take it: delivered, refused there
    # (not_allowed), and the player says so instead of reporting a success.
    (tmp_path / "nowrite").mkdir()
    proc, mine, player, log = estimator(program, tmp_path / "nowrite", identities=tmp_path / "fleet2", write=False)
    try:
        r = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--only", "imuOut",
                 "--key", str(tmp_path / "fleet2" / "fleet-1.key"), "--identity", str(tmp_path / "fleet2" / "fcs20.id"),
                 "--fast")
        time.sleep(0.3)
        drops = proc.request_stats()["node"]["drops"]
    finally:
        proc.stop()
    assert r.returncode != 0, r.stdout
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert report["stored"] is False and drops["not_allowed"] == report["frames"] > 0, (report, drops)
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith(f"uavbus log play: est1 stored none of the {report['frames']} frames played") \
        and "write policy" in line, line
    bad = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--key",
               str(fleet / "fleet-1.key"), "--identity", str(fleet / "nobody.id"))
    assert bad.returncode != 0 and "nobody.id not found" in bad.stderr.strip().splitlines()[-1], bad.stderr
    bad = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}",
               "--identity", str(fleet / "fcs20.id"))
    assert bad.returncode != 0 and "--identity goes with --key FILE" in bad.stderr, bad.stderr


def test_played_over_tcp(recording: Path, program: Path, tmp_path: Path) -> None:
    """Any port a node has: the estimator listens on TCP, the player connects."""
    proc, mine, _player, log = estimator(program, tmp_path, port="tcp:listen={mine}")
    try:
        r = play(recording, "--to", "est1", "--into", f"tcp:connect={mine}", "--only", "imuOut", "--fast")
        assert r.returncode == 0, r.stderr
        report = json.loads(r.stdout.strip().splitlines()[-1])
        time.sleep(0.3)
    finally:
        proc.stop()
    assert report["frames"] >= FRAMES - 2 and report["stored"] is True, report
    assert len(arrivals(log, "fcs20", "est1")) == report["frames"], report


def test_an_entity_that_does_not_know_the_player_gets_a_reason(recording: Path, program: Path, tmp_path: Path) -> None:
    proc, mine, player, _ = estimator(program, tmp_path)
    try:
        r = play(recording, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--as", "stranger")
    finally:
        proc.stop()
    assert r.returncode != 0
    line = r.stderr.strip().splitlines()[-1]
    assert "no answer from est1" in line and "does not know stranger" in line, line


def test_recorded_sources_mapped_to_new_entities(two_sources: Path, program: Path, tmp_path: Path) -> None:
    """Two recorded sources, each played by an entity of its own (--map): the estimator tells them apart."""
    assert len(arrivals(two_sources, "fcs20", "gcs1")) == 30 and len(arrivals(two_sources, "rmax1ob1", "gcs1")) == 30
    proc, mine, player, log = estimator(program, tmp_path, knows=("imusim", "gpssim"))
    try:
        r = play(two_sources, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--fast",
                 "--map", "fcs20=imusim", "--map", "rmax1ob1=gpssim")
        assert r.returncode == 0, r.stderr
        report = json.loads(r.stdout.strip().splitlines()[-1])
        assert report["plays_as"] == {"fcs20": "imusim", "rmax1ob1": "gpssim"} and report["frames"] == 60, report
        time.sleep(0.3)
    finally:
        proc.stop()
    assert len(arrivals(log, "imusim", "est1")) == 30 and len(arrivals(log, "gpssim", "est1")) == 30
    bad = play(two_sources, "--to", "est1", "--into", f"udp:bind={player},peer={mine}", "--map", "uav9=x")
    assert bad.returncode != 0 and "--map uav9: no such source in the selection" in bad.stderr, bad.stderr
