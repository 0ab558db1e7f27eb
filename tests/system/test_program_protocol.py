"""The programs' JSON-lines protocol as they really speak it (docs/program-protocol.md): every line a real
`uavbus_node` and a real `uavbus_mavbridge` write, driven through every event each of them has, satisfies
schemas/program-events.schema.json -- the file the supervisor (uavbus.sim.protocol) reads its event names
from. tests/unit/test_program_protocol_schema.py checks the same file against the C sources."""

from __future__ import annotations

import json
import os
import socket
from pathlib import Path

import jsonschema
import pytest

from uavbus import keys
from uavbus.sim import protocol
from uavbus.sim.build import REPO
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeProcess, ProcessGroup
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(120)

TABLE2 = REPO / "examples" / "configs" / "table2.json"


def check_lines(proc: NodeProcess, program: str) -> set[str]:
    """Every event the process wrote is one of `program`'s, as the schema describes it; returns their names."""
    validator = jsonschema.Draft202012Validator(protocol.event_schema(program))
    assert proc.bad_lines == 0, [e for e in proc.events if e.get("event") == "text"]
    seen = set()
    for ev in proc.events:
        line = {k: v for k, v in ev.items() if not k.startswith("_")}  # the supervisor's own stamps
        errors = sorted(validator.iter_errors(line), key=str)
        assert not errors, f"{program}: {json.dumps(line)[:300]}: {errors[0].message}"
        seen.add(line["event"])
    return seen


def answer(proc: NodeProcess, line: str, event: str, timeout: float = 5.0) -> dict:
    m = proc.mark()
    proc.send(line)
    return proc.wait_event(lambda e: e.get("event") in (event, protocol.ERROR), timeout, since=m, what=f"{line!r}")


def test_uavbus_node_writes_every_event_of_the_protocol_and_nothing_else(program: Path, tmp_path: Path) -> None:
    alloc = PortAllocator()
    relay = alloc.port()
    config = signed_config(TABLE2, tmp_path)
    # with an identity (issue 23), so that `revoke FILE` has a revocation service to hand its records to
    kdir = tmp_path / "keys"
    keys.authority_create(str(kdir))
    keys.issue("rmax1ob1", "vehicle,relay", 1, None, str(kdir), None, False)
    keys.revoke("fcs20", 7, None, str(kdir), None)
    doc = json.loads(config.read_text())
    doc["security"].update({"authority": str(kdir / "authority.pub"), "identity": str(kdir / "{entity}.id"),
                            "certificates": str(kdir / "fleet.certs"), "revocations": "state/revocations.ubr"})
    config.write_text(json.dumps(doc))
    with ProcessGroup() as group:
        node = group.spawn([str(program), "--config", str(config), "--node", "primary", "--stats-ms", "200",
                            "--port", f"onboardPortRelay=udp:bind=127.0.0.1:{relay},peer=127.0.0.1:{alloc.port()}",
                            "--publish", "rmax1ob1:gpsOut>fcs20/50", "--flows-ms", "200"], "primary")
        assert answer(node, "frob", protocol.ERROR)["message"].startswith("unknown command 'frob'")
        stats = answer(node, "stats", protocol.STATS)
        assert stats["event"] == protocol.STATS and stats["stdin_dropped"] == 0
        tx_key = stats["security"]["tx_key"]
        assert answer(node, f"key use {tx_key}", protocol.KEY)["event"] == protocol.KEY
        assert answer(node, "dump gpsOut", protocol.DUMP)["event"] == protocol.DUMP
        assert answer(node, "entity add stranger", "membership")["event"] == "membership"
        assert answer(node, "link impair onboardPortRelay loss=0.1", "impaired")["event"] == "impaired"
        rebound = answer(node, f"rebind onboardPortRelay udp:bind=127.0.0.1:{alloc.port()},peer=127.0.0.1:{alloc.port()}",
                         protocol.REBOUND)
        assert rebound["event"] == protocol.REBOUND and rebound["local_port"] > 0
        assert answer(node, "routes", protocol.ROUTES)["event"] == protocol.ROUTES
        assert answer(node, "flows", protocol.FLOWS)["event"] == protocol.FLOWS
        assert answer(node, f"revoke {kdir / 'revocations.ubr'}", "revoke")["accepted"] == 1
        assert answer(node, "stats", protocol.STATS)["identity"]["revocations"] == 1
        # A request nobody answers: pending, then failed (no_answer) once its attempts run out.
        m = node.mark()
        node.send("member stranger add_entity fcs20")
        node.wait_event(lambda e: e.get("event") == "member" and e["status"] == "pending", 5.0, since=m)
        # A datagram from a stranger on a port with a configured peer: one warning.
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(b"\x00" * 8, ("127.0.0.1", rebound["local_port"]))
        node.wait_event(protocol.WARNING, 5.0, what="warning for a stranger's datagram")
        m = node.mark()
        node.send("x" * 1500)
        assert "longer than 1023 bytes" in node.wait_event(protocol.ERROR, 3.0, since=m)["message"]
        assert answer(node, "stats", protocol.STATS)["stdin_dropped"] > 0
        assert group.close()["primary"] == 0
    seen = check_lines(node, protocol.NODE)
    final = [e for e in node.all(protocol.STATS) if e.get("final")]
    assert len(final) == 1 and final[0] is node.all(protocol.STATS)[-1]
    assert seen == set(protocol.events(protocol.NODE)), set(protocol.events(protocol.NODE)) - seen


def test_uavbus_mavbridge_lines_satisfy_the_protocol(tmp_path: Path) -> None:
    info_path = Path(os.environ.get("UAVBUS_BUILD_DIR") or REPO / "build") / "mavbridge.json"
    if not info_path.exists():
        pytest.fail(f"{info_path} is missing: build the MAVLink bridge (make test-c) first")
    prog = json.loads(info_path.read_text())["program"]
    alloc = PortAllocator()
    cfg = tmp_path / "bridge.json"
    cfg.write_text(json.dumps({"entities": [
        {"name": "mavbridge", "links": ["toGcs"], "linktoentity": {"gcs1": [0]}},
        {"name": "gcs1", "links": ["toBridge"], "linktoentity": {"mavbridge": [0]}}], "hosts": ["mavbridge"]}))
    with ProcessGroup() as group:
        bridge = group.spawn([prog, "--config", str(cfg), "--stats-ms", "100",
                              "--mavlink", f"udp:bind=127.0.0.1:{alloc.port()},peer=127.0.0.1:{alloc.port()}",
                              "--port", f"toGcs=udp:bind=127.0.0.1:{alloc.port()},peer=127.0.0.1:{alloc.port()}"],
                             "bridge")
        bridge.wait_event(protocol.WARNING, 3.0, what="commands-off warning")
        assert answer(bridge, "frob", protocol.ERROR)["message"] == "unknown command 'frob' (expected: stats, quit)"
        assert answer(bridge, "stats", protocol.STATS)["mavlink"]["connected"] is False
        assert group.close()["bridge"] == 0
    seen = check_lines(bridge, protocol.MAVBRIDGE)
    assert {protocol.READY, protocol.STATS, protocol.ERROR, protocol.WARNING} <= seen
