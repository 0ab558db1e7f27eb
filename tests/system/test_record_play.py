"""Record on gcs1, play back into a fresh node (issue 4: "Record and play").

The live GCS records every frame it receives (runtime_c ub_log via the Python binding); `uavbus log play`
sends the recorded frames, as they are, over UDP into a fresh node hosting gcs1. That node must deliver
the same directory values in the same order; `--only` filters; a log cut at a random byte plays up to
the cut.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
import time
from pathlib import Path

import pytest

from uavbus.sim.hitl import Hitl, HitlOptions
from uavbus.sim.portalloc import PortAllocator

pytestmark = pytest.mark.timeout(60)

Msg = tuple[str, str, int, bytes]


def play_into_fresh_node(h_opts: HitlOptions, catalogue: Path, log: Path, *extra: str) -> tuple[list[Msg], dict]:
    """Starts a fresh gcs1 on UDP, plays `log` into it, returns what it delivered and the player's report."""
    from uavbus import Catalogue, Node

    alloc = PortAllocator()
    node_addr, player_addr = alloc.addr(), alloc.addr()
    node = Node(Catalogue.load(str(catalogue)), config=str(h_opts.config), node="gcs")
    got: list[Msg] = []
    try:
        node.bind("gpsOut")
        node.bind("imuOut")
        node.on_data(lambda m: got.append((m.name, m.source, int(m.seq), bytes(m.raw))))
        node.open_port("gcsPortDatalink1", f"udp:bind={node_addr},peer={player_addr}")
        player = subprocess.Popen([sys.executable, "-m", "uavbus.cli", "log", "play", str(log), "--into",
                                   f"udp:peer={node_addr},bind={player_addr}", "--speed", "4", *extra],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 20
        while player.poll() is None and time.monotonic() < deadline:
            node.poll(timeout=0.01)
        end = time.monotonic() + 0.3
        while time.monotonic() < end:
            node.poll(timeout=0.01)
        out, err = player.communicate(timeout=5)
        assert player.returncode == 0, err
        report = json.loads(out.strip().splitlines()[-1])
    finally:
        node.close()
    return got, report


def test_record_and_play_back_same_values_same_order(hitl_opts: HitlOptions, tmp_path: Path) -> None:
    log = tmp_path / "gcs1.ublog"
    hitl_opts.record = log
    with Hitl(hitl_opts) as h:
        catalogue = h.catalogue_path
        h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", 100)
        h.add_row("subscription", "imuOut", "fcs20", "gcs1", 50)
        h.wait_data("gpsOut", "rmax1ob1", 5, 5.0)
        h.wait_data("imuOut", "fcs20", 10, 5.0)
        h.run_for(0.5)
        live: list[Msg] = [(n, s, q, r) for _, n, s, q, r in h.messages]
    assert log.read_bytes()[:8] == b"UBLOG3\r\n"

    replayed, report = play_into_fresh_node(hitl_opts, catalogue, log)
    assert report["frames"] > len(live)                 # both datalinks recorded: duplicates included
    assert replayed == live, "the fresh node delivered other values or another order than the live GCS"

    only, _ = play_into_fresh_node(hitl_opts, catalogue, log, "--only", "gpsOut")
    assert only == [m for m in live if m[0] == "gpsOut"] and only

    from uavbus.logfile import LogReader

    data = log.read_bytes()
    header = LogReader(log).header.size  # the header embeds the catalogue: its size follows the catalogue's
    records = len(data) - header
    # Inside the middle third of the records: a cut near the end may drop only copies the second datalink
    # recorded of values already delivered, and then nothing the fresh node delivers is missing.
    cut_at = random.Random(20261121).randrange(header + records // 3, header + 2 * records // 3)
    cut = tmp_path / "cut.ublog"
    cut.write_bytes(data[:cut_at])
    part, report = play_into_fresh_node(hitl_opts, catalogue, cut)
    assert 0 < len(part) < len(live) and part == live[:len(part)], f"cut at byte {cut_at}"
    assert report["ignored_bytes"] >= 0
