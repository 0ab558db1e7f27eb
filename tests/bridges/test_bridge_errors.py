"""The bridges' names and their refusals: MAVLink directory names unique under the paper's ID rule for
real dialects (computed here independently of the generator), and set-up mistakes answered with one
line that says what to do, never a traceback or a silent start."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from uavbus.bridges import mavlink_dirs
from uavbus.bridges.zenoh_bridge import BridgeError, flow_keyexpr


def paper_id(name: str) -> bytes:
    raw = name.encode()
    head = raw[:8].ljust(8, b"\0")
    tail = raw[-8:] if len(raw) >= 8 else raw.ljust(8, b"\0")
    return head + tail


@pytest.mark.parametrize("dialect", ["common", "ardupilotmega", "all"])
def test_directory_names_are_unique_under_the_paper_rule(dialect):
    messages, files = mavlink_dirs.read_dialect(mavlink_dirs.dialect_xml(dialect))
    names = [m.directory for m in messages]
    assert len(names) > 200 and files[0].name == f"{dialect}.xml"
    assert len({paper_id(n) for n in names}) == len(names)
    # ... which message names alone are not (the reason for the suffix).
    plain = [m.name for m in messages]
    assert len({paper_id(n) for n in plain}) < len(plain)
    assert mavlink_dirs.parse_directory_name("GLOBAL_POSITION_INT_33") == ("GLOBAL_POSITION_INT", 33)
    assert mavlink_dirs.find_directory(names, "ATTITUDE") == "ATTITUDE_30"
    with pytest.raises(ValueError, match="10\\^7"):
        mavlink_dirs.directory_name("HUGE", 10**7)


def test_flow_selections():
    assert flow_keyexpr("uavbus/s", "gcs2") == "uavbus/s/gcs2/**"
    assert flow_keyexpr("uavbus/s", "gcs2/*/navFilterState") == "uavbus/s/gcs2/*/navFilterState/*"
    for bad in ("", "a/b/c/d", "gcs*/x", "a//b"):
        with pytest.raises(BridgeError, match="--flow"):
            flow_keyexpr("uavbus/s", bad)


def run(argv: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, capture_output=True, text=True, timeout=30)


def test_mavbridge_refuses_bad_set_up_in_one_line(tmp_path, mavbridge):
    cfg = tmp_path / "one.json"
    cfg.write_text(json.dumps({"entities": [{"name": "mavbridge"}], "hosts": ["mavbridge"]}))
    prog = mavbridge["program"]
    cases = [
        ([prog, "--config", str(cfg)], "--mavlink SPEC is required"),
        ([prog, "--config", str(cfg), "--mavlink", "tcp:listen=127.0.0.1:5760"],
         "udp:bind=HOST:PORT,peer=HOST:PORT, tcp:connect=HOST:PORT or serial"),
        ([prog, "--config", str(cfg), "--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", "--gcs",
          "udp:bind=127.0.0.1:0,peer=127.0.0.1:9"], "ground stations are learned: no peer"),
        ([prog, "--config", str(cfg), "--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", "--fleet", "nobody"],
         "--fleet: every entity must be in the entity table"),
        ([prog, "--config", str(cfg), "--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", "--target", "1"],
         "expected SYSID/COMPID"),
        ([prog, "--config", str(cfg), "--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", "--entity", "nobody"],
         "is not an entity this node hosts"),
    ]
    key = tmp_path / "k.key"
    key.write_text("00" * 32 + "\n")
    key.chmod(0o644)
    cases.append(([prog, "--config", str(cfg), "--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9",
                   "--mavlink-key", str(key)], f"{key}:1: the MAVLink key file is accessible by group or others"))
    short = tmp_path / "short.key"
    short.write_text("# a comment\nabcd\n")
    short.chmod(0o600)
    cases.append(([prog, "--config", str(cfg), "--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9",
                   "--mavlink-key", str(short)], f"{short}:2: expected one line of 64 hex digits"))
    mav = ["--mavlink", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9"]
    cases.append(([prog, "--config", str(cfg), *mav, "--gcs-key", str(short)], "--gcs-key needs --gcs"))
    cases.append(([prog, "--config", str(cfg), *mav, "--gcs", "udp:bind=127.0.0.1:0", "--gcs-key", str(key)],
                  f"{key}:1: the MAVLink key file is accessible by group or others"))
    cases.append(([prog, "--config", str(cfg), *mav, "--gcs", "serial:device=/dev/no-such-tty-uavbus,baud=57600"],
                  "--gcs serial:device=/dev/no-such-tty-uavbus,baud=57600: /dev/no-such-tty-uavbus: No such file"))
    for argv, expected in cases:
        r = run(argv)
        assert r.returncode == 2, (argv, r.stdout, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and expected in lines[0], (argv, r.stderr)
        assert json.loads(r.stdout.strip().splitlines()[-1])["event"] == "error"


def test_zenoh_bridge_refuses_a_link_it_does_not_have(tmp_path, uavbus_node):
    from uavbus.sim.hitl import catalogue_for

    cfg = tmp_path / "gw.json"
    cfg.write_text(json.dumps({"system": "t", "entities": [
        {"name": "gw", "links": ["site", "zenoh"], "linktoentity": {"far": ["zenoh"]}}, {"name": "far"}],
        "hosts": ["gw"]}))
    base = [sys.executable, "-m", "uavbus.cli", "bridge", "zenoh", "--config", str(cfg),
            "--catalogue", str(catalogue_for(uavbus_node))]
    r = run(base + ["--link", "radio"])
    assert r.returncode == 2 and "no entity of this node has a link named 'radio'" in r.stderr, r.stderr
    r = run(base + ["--link", "site"])
    assert r.returncode == 2 and "sends nothing over 'site'" in r.stderr, r.stderr
    r = run([sys.executable, "-m", "uavbus.cli", "bridge", "mqtt"])
    assert r.returncode == 2 and "unknown bridge 'mqtt'" in r.stderr
