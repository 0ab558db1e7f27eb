"""Two uavbus networks on 127.0.0.1 joined through two Zenoh sessions (eclipse-zenoh from PyPI).

    site A: uavbus_node [rmax1ob1] <-udp-> uavbus bridge zenoh [gwA]
                                                 |  Zenoh session (peer, listens)
                                                 |  tcp/127.0.0.1
                                                 |  Zenoh session (peer, connects)
    site B: Python GCS [gcs2]      <-udp-> uavbus bridge zenoh [gwB]

in both of Zenoh's topologies here: two peers, and a router with a client; the second with every node
signing (trust-design.md, one fleet key): frames cross Zenoh unchanged and the GCS, which requires
signed frames, verifies rmax1ob1's tags end to end.

Checked, each able to fail:
  - gcs2's subscription to rmax1ob1's navFilterState (20 ms) crosses both bridges (the PUB_REQUEST one
    way, the DATA back) and the data arrives at the rate asked, 50 Hz ±10 %, every frame once;
  - the frames travel under the documented key expressions (a plain Zenoh subscriber on the same
    network sees `uavbus/zentest/gcs2/rmax1ob1/navFilterState/data`), as the bytes the router sent;
  - each bridge sees the other site's entities alive (liveliness), and its counters balance: what one
    bridge published, the other received, none rejected;
  - signed: what travels on Zenoh carries the SIGNED flag and its trailer, and gcs2 verified every frame
    it took in (no tag failure, nothing unsigned).
"""

from __future__ import annotations

import json
import sys
import threading
import time
from pathlib import Path

import pytest

from uavbus import Node
from uavbus._bindings.ub_frame import FLAG_SIGNED, ub_frame_parse
from uavbus.bridges.zenoh_bridge import batch_spans
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import ProcessGroup
from uavbus.sim.secure import signed_config

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is in the `test` extras (make setup installs it)")

DIRECTORY = "navFilterState"  # uavbus_node's rmax1ob1 updates it every 20 ms


def write_config(path: Path, ports: PortAllocator) -> None:
    a = {k: ports.port() for k in ("uav", "gwA", "gwB", "gcs")}

    def udp(bind: str, peer: str) -> dict[str, str]:
        return {"transport": "udp", "bind": f"127.0.0.1:{a[bind]}", "peer": f"127.0.0.1:{a[peer]}"}

    cfg = {
        "system": "zentest",
        "entities": [
            {"name": "rmax1ob1", "links": ["toGw"], "linktoentity": {"gwA": [0], "gwB": [0], "gcs2": [0]}},
            {"name": "gwA", "links": ["toSite", "zenoh"],
             "linktoentity": {"rmax1ob1": ["toSite"], "gwB": ["zenoh"], "gcs2": ["zenoh"]}},
            {"name": "gwB", "links": ["toSite", "zenoh"],
             "linktoentity": {"gcs2": ["toSite"], "gwA": ["zenoh"], "rmax1ob1": ["zenoh"]}},
            {"name": "gcs2", "links": ["toGw"], "linktoentity": {"gwB": [0], "gwA": [0], "rmax1ob1": [0]}},
        ],
        "nodes": {"primary": ["rmax1ob1"], "gwA": ["gwA"], "gwB": ["gwB"], "gcs": ["gcs2"]},
        "ports": {
            "rmax1ob1:toGw": udp("uav", "gwA"),
            "gwA:toSite": udp("gwA", "uav"),
            "gwB:toSite": udp("gwB", "gcs"),
            "gcs2:toGw": udp("gcs", "gwB"),
            "gwA:zenoh": {"transport": "mem"},
            "gwB:zenoh": {"transport": "mem"},
        },
    }
    path.write_text(json.dumps(cfg, indent=1))


def bridge_argv(cfg: Path, catalogue: Path, node: str, *zenoh_args: str) -> list[str]:
    return [sys.executable, "-m", "uavbus.cli", "bridge", "zenoh", "--config", str(cfg), "--node", node,
            "--catalogue", str(catalogue), *zenoh_args]


@pytest.mark.parametrize("mode_a,mode_b,signed", [("peer", "peer", False), ("router", "client", True)])
def test_subscription_crosses_two_zenoh_sessions_at_its_rate(tmp_path, uavbus_node, mode_a, mode_b, signed):
    ports = PortAllocator()
    cfg = tmp_path / "zentest.json"
    write_config(cfg, ports)
    if signed:
        cfg = signed_config(cfg, tmp_path / "signed")
    catalogue = catalogue_for(uavbus_node)
    zport = ports.port()
    endpoint = f"tcp/127.0.0.1:{zport}"
    with ProcessGroup() as group:
        group.spawn([str(uavbus_node), "--config", str(cfg), "--node", "primary", "--stats-ms", "0"], "uav")
        gw_a = group.spawn(bridge_argv(cfg, catalogue, "gwA", "--mode", mode_a, "--listen", endpoint), "gwA",
                           ready_timeout=15)
        gw_b = group.spawn(bridge_argv(cfg, catalogue, "gwB", "--mode", mode_b, "--connect", endpoint), "gwB",
                           ready_timeout=15)
        assert gw_a.wait_ready()["remote_site"] == ["gwB", "gcs2"]
        assert gw_b.wait_ready()["flows"] == ["uavbus/zentest/gwB/**", "uavbus/zentest/gcs2/**"]
        # A third, plain Zenoh session on the same network: what travels, under which keys.
        spy_conf = zenoh.Config()
        spy_conf.insert_json5("mode", '"peer"' if mode_a == "peer" else '"client"')
        spy_conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
        spy_conf.insert_json5("scouting/multicast/enabled", "false")
        seen: list[tuple[str, bytes]] = []
        lock = threading.Lock()

        def on_sample(s):
            with lock:
                seen.append((str(s.key_expr), s.payload.to_bytes()))

        spy = zenoh.open(spy_conf)
        group.on_close(spy.close)
        spy_sub = spy.declare_subscriber("uavbus/zentest/**", on_sample)
        group.on_close(spy_sub.undeclare)

        gcs = Node(catalogue, config=cfg, node="gcs")
        group.on_close(gcs.close)
        gcs.open_ports_from_config()
        gcs.subscribe("gcs2", DIRECTORY, source="rmax1ob1", period_ms=20)
        deadline = time.monotonic() + 10
        first = None
        while first is None and time.monotonic() < deadline:
            first = next(iter(gcs.messages(timeout=0.1)), None)
        assert first is not None, f"nothing crossed: gwA {gw_a.request_stats()} gwB {gw_b.request_stats()}"
        got = []
        t0 = time.monotonic()
        for msg in gcs.messages(timeout=1.0):
            got.append(msg)
            if time.monotonic() - t0 >= 3.0:
                break
        span = time.monotonic() - t0
        seqs = [m.seq for m in got if m.name == DIRECTORY and m.source == "rmax1ob1"]
        assert len(seqs) == len(set(seqs)), "a frame arrived twice"
        assert len(seqs) / span == pytest.approx(50.0, rel=0.10), (len(seqs), span)

        with lock:
            keys = {k for k, _ in seen}
            # Each sample is a batch of frames (batch format 1, docs/bridges.md): the frames inside it.
            data = [payload[at:at + n] for k, payload in seen if k == f"uavbus/zentest/gcs2/rmax1ob1/{DIRECTORY}/data"
                    for at, n in batch_spans(payload)]
        assert f"uavbus/zentest/rmax1ob1/gcs2/{DIRECTORY}/pub_request" in keys, sorted(keys)[:10]
        assert data, sorted(keys)[:10]
        h = ub_frame_parse(data[-1])  # the C codec verifies the frame as carried
        assert h.src_id.rstrip(b"\0") == b"rmax1ob1" and h.dest_id.rstrip(b"\0") == b"gcs2"
        assert h.flags == (FLAG_SIGNED if signed else 0)
        if signed:
            sec = gcs.security()
            assert sec["verified_in"] >= len(seqs) and sec["auth_failures"] == 0, sec
            drops = gcs.counters()["drops"]
            assert drops["unsigned"] == 0 and drops["bad_tag"] == 0, drops

        remote = gw_b.wait_event(lambda e: e.get("event") == "remote" and e.get("entity") == "rmax1ob1", 5,
                                 what="rmax1ob1 alive at gwB")
        assert remote["alive"] and remote["known"]
        a, b = gw_a.request_stats(), gw_b.request_stats()
        assert b["zenoh"]["rejected"] == 0 and a["zenoh"]["rejected"] == 0, (a, b)
        assert a["zenoh"]["rx_overflow"] == 0 and b["zenoh"]["rx_overflow"] == 0
        assert "gcs2" in a["zenoh"]["remote_alive"] and "rmax1ob1" in b["zenoh"]["remote_alive"]
        assert b["links"]["zenoh"]["frames_in"] >= len(seqs), b["links"]
