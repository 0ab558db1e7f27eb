"""Signed frames from Python: `uavbus keys new`, the config's "security" section applied through the C
loader, two Python nodes over a memlink with an injected clock (signed flow after one challenge,
unsigned frames refused, key rotation without loss, keys and counters read back from C), and the
config's security errors with file:line."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from binding_testutil import TABLE2, FakeClock, Generated, run_nodes
from uavbus import MemLink, Node
from uavbus._bindings.ub_error import ConfigError, InvalidArgumentError, UbError
from uavbus.sim.secure import new_key, signed_config

UAVBUS = [sys.executable, "-m", "uavbus.cli"]


run = run_nodes


def test_keys_new_writes_0600_prints_the_id_and_never_overwrites(tmp_path: Path) -> None:
    key = tmp_path / "fleet.key"
    out = subprocess.run([*UAVBUS, "keys", "new", str(key), "--id", "42"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "42"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600
    line = [x for x in key.read_text().splitlines() if not x.startswith("#")][0]
    assert line.startswith("uavbus-key 1 id=42 ") and len(line.split()[3]) == 64
    again = subprocess.run([*UAVBUS, "keys", "new", str(key)], capture_output=True, text=True)
    assert again.returncode == 1 and "already exists" in again.stderr
    assert key.read_text().splitlines()[1] == line            # untouched
    random_id = subprocess.run([*UAVBUS, "keys", "new", str(tmp_path / "r.key")], capture_output=True, text=True)
    assert random_id.returncode == 0 and 1 <= int(random_id.stdout) <= 255
    os.chmod(key, 0o644)
    shown = subprocess.run([*UAVBUS, "keys", "show", str(key)], capture_output=True, text=True)
    assert shown.returncode == 1
    assert shown.stderr.strip() == f"{key}: mode 644 lets group or others access the key; refusing it (chmod 600 {key})"
    bad = subprocess.run([*UAVBUS, "keys", "new", str(tmp_path / "x.key"), "--id", "300"], capture_output=True,
                         text=True)
    assert bad.returncode == 2 and "1..255" in bad.stderr


@pytest.fixture()
def signed_pair(flightsw: Generated, tmp_path: Path):
    clock = FakeClock()
    cfg = signed_config(TABLE2, tmp_path)
    gcs = Node(flightsw.catalogue, config=cfg, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=cfg, node="primary", clock=clock)
    link = MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
    yield gcs, air, link, clock, tmp_path
    gcs.close()
    air.close()


def test_signed_subscription_flows_and_counts_in_c(signed_pair) -> None:
    gcs, air, _link, clock, tmp = signed_pair
    air.bind("gpsOut")
    got = []
    gcs.on_data(got.append)
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    run([gcs, air], clock, 1000)
    assert len(got) >= 15
    sec_gcs, sec_air = gcs.security.status(), air.security.status()
    assert sec_gcs is not None and sec_air is not None
    assert sec_gcs["tx_key"] == 1 and sec_gcs["keys"] == [1]
    assert sec_gcs["verified_in"] >= len(got) and sec_air["signed_out"] >= len(got)
    assert sec_air["challenges_completed"] >= 1 or sec_gcs["challenges_completed"] >= 1
    drops = gcs.counters()["drops"]
    assert drops["bad_tag"] == drops["unknown_key"] == drops["replay"] == drops["unsigned"] == 0
    # the counter files exist, one per hosted entity, holding a mark above every counter used
    for entity in ("gcs1", "rmax1ob1"):
        text = (tmp / "state" / f"{entity}.counter").read_text()
        assert text.startswith("uavbus-counter 1 ")
    assert int((tmp / "state" / "rmax1ob1.counter").read_text().split()[2]) == sec_air["counter_mark"]
    links = gcs.link_counters()
    assert links["gcsPortDatalink1"]["require_signed"] is True
    assert links["gcsPortDatalink1"]["frames_accepted"] >= len(got)


def test_unsigned_node_is_refused_by_a_signed_one(flightsw: Generated, tmp_path: Path) -> None:
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=signed_config(TABLE2, tmp_path), node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)     # no keys
    MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
    air.bind("gpsOut")
    gcs.bind("gpsOut")
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=20)
    got = []
    gcs.on_data(got.append)
    run([gcs, air], clock, 500)
    assert got == []
    assert gcs.counters()["drops"]["unsigned"] >= 20
    assert air.security.status() is None
    with pytest.raises(InvalidArgumentError):
        air.security.use_key(1)
    gcs.close()
    air.close()


def test_key_rotation_through_node_loses_nothing(signed_pair) -> None:
    gcs, air, _link, clock, tmp = signed_pair
    air.bind("gpsOut")
    gcs.bind("gpsOut")
    got = []
    gcs.on_data(got.append)
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=20)
    run([gcs, air], clock, 300)
    n0, sent0 = len(got), air.pubsub_rows("rmax1ob1")[0]["frames"]
    key2 = new_key(tmp / "keys", 2)
    assert gcs.security.add_key(key2) == 2 and air.security.add_key(key2) == 2        # 1. everyone accepts key 2
    run([gcs, air], clock, 100)
    gcs.security.use_key(2)                                                           # 2. everyone signs with it
    air.security.use_key(2)
    run([gcs, air], clock, 100)
    with pytest.raises(UbError):
        air.security.remove_key(2)                                                    # never the signing key
    gcs.security.remove_key(1)                                                        # 3. key 1 retired
    air.security.remove_key(1)
    run([gcs, air], clock, 300)
    sent = air.pubsub_rows("rmax1ob1")[0]["frames"] - sent0
    assert len(got) - n0 == sent and sent >= 24
    assert gcs.security.status()["keys"] == [2] and air.security.status()["tx_key"] == 2
    assert gcs.counters()["drops"]["unknown_key"] == 0


def test_config_security_errors_name_file_and_line(flightsw: Generated, tmp_path: Path) -> None:
    doc = json.loads(TABLE2.read_text())
    doc["security"] = {"keys": ["missing.key"], "counter_file": "state/{entity}.counter"}
    cfg = tmp_path / "bad.json"
    cfg.write_text(json.dumps(doc, indent=1))
    line = next(i for i, x in enumerate(cfg.read_text().splitlines(), 1) if "missing.key" in x)
    with pytest.raises(ConfigError) as e:
        Node(flightsw.catalogue, config=cfg, node="gcs")
    assert f"{cfg}:{line}: field 'security.keys[0]': {tmp_path}/missing.key: cannot open the key file" in str(e.value)
    key = new_key(tmp_path, 5, "open.key")
    os.chmod(key, 0o640)
    doc["security"]["keys"] = ["open.key"]
    cfg.write_text(json.dumps(doc, indent=1))
    with pytest.raises(ConfigError, match=r"chmod 600 .*open\.key"):
        Node(flightsw.catalogue, config=cfg, node="gcs")
