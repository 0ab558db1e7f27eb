"""Identity per entity from Python: a Node whose config names an authority loads its identity through the C
loader (ub_nodecfg_apply_identity), runs the revocation service, and decides administrators on certified
roles, and takes origin authentication from the same store. Three nodes of Table 2 on memlinks: a revocation
submitted at the GCS reaches rmax1ob1 (1 hop) and fcs20 (2 hops), is persisted, ends the GCS's pairwise key
with fcs20 at once and its frames are refused; a refused identity file stops the Node with the config line and
the fix."""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

import pytest

from binding_testutil import TABLE2, FakeClock, Generated, run_nodes
from uavbus import MemLink, Node, keys
from uavbus._bindings import ub_ident
from uavbus._bindings.ub_error import ConfigError
from uavbus.sim.secure import signed_config

ROLES = {"gcs1": "admin", "rmax1ob1": "vehicle,relay", "rmax1ob2": "vehicle", "fcs20": "vehicle"}


def identity_config(tmp_path: Path) -> Path:
    kdir = tmp_path / "keys"
    keys.authority_create(str(kdir))
    for entity, roles in ROLES.items():
        keys.issue(entity, roles, 30, None, str(kdir), None, False)
    cfg = signed_config(TABLE2, tmp_path)
    for entity in ROLES:   # each node its own copy of the fleet's certificates (it rewrites it when it learns one)
        shutil.copyfile(kdir / "fleet.certs", tmp_path / "state" / f"{entity}.certs")
    doc: dict[str, Any] = json.loads(cfg.read_text(encoding="utf-8"))
    doc["security"].update({"authority": "keys/authority.pub", "identity": "keys/{entity}.id",
                            "certificates": "state/{entity}.certs", "revocations": "state/{entity}.ubr"})
    cfg.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return cfg


def test_a_revocation_spreads_between_python_nodes(flightsw: Generated, tmp_path: Path) -> None:
    cfg = identity_config(tmp_path)
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=cfg, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=cfg, node="primary", clock=clock)
    fcs = Node(flightsw.catalogue, config=cfg, node="backup", clock=clock)
    try:
        MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
        MemLink(air, "onboardPortRelay", fcs, "onboardPortDatalink1", seed=2)
        nodes = [gcs, air, fcs]
        assert all(n.identity is not None for n in nodes)
        # traffic on both links first (each node proves its freshness to its neighbours)
        gcs.subscribe("gcs1", "imuOut", source="fcs20", period_ms=50)
        fcs.bind("imuOut")
        run_nodes(nodes, clock, 1500)
        now = int(time.time())
        fcs20 = ub_ident.entity_id("fcs20")
        assert air.identity.store.status(fcs20, now) == "valid"
        keys.revoke("fcs20", None, None, str(tmp_path / "keys"), None)
        record = (tmp_path / "keys" / "revocations.ubr").read_bytes()[8:]
        # origin authentication came with the identities (all in C): imuOut reached gcs1 origin-tagged by fcs20
        mine = gcs.security.origin_status()
        assert mine is not None and mine["opened"] > 0 and mine["bad_origin"] == mine["no_origin"] == 0, mine
        assert fcs.security.origin_status()["sealed"] > 0
        cached = mine["cached"]
        assert gcs.identity.submit(record, clock.t) == "accepted"
        # the revocation service's hook forgot fcs20's pairwise key at once, not at the next recheck
        assert gcs.security.origin_status()["cached"] == cached - 1
        refused = sum(c["drops"]["no_identity"] for c in gcs.link_counters().values())
        run_nodes(nodes, clock, 500)   # fcs20 has no freshness state for rmax1ob1 yet: a repeat gets in
        assert sum(c["drops"]["no_identity"] for c in gcs.link_counters().values()) > refused   # fcs20 refused
        assert air.identity.store.status(fcs20, now) == "revoked"
        assert fcs.identity.store.status(fcs20, now) == "revoked"          # two hops away: its own identity
        for entity in ("gcs1", "rmax1ob1", "fcs20"):
            assert (tmp_path / "state" / f"{entity}.ubr").stat().st_size == 8 + 104
        assert air.identity.stats()["accepted"] == 1 and air.identity.stats()["refused"] == 0
        assert gcs.identity.submit(record, clock.t) == "known"
        run_nodes(nodes, clock, 3000)
        sent = [n.identity.stats()["sent"] for n in nodes]
        run_nodes(nodes, clock, 3000)
        assert [n.identity.stats()["sent"] for n in nodes] == sent          # copies died out
    finally:
        for n in (gcs, air, fcs):
            n.close()


def test_a_refused_identity_stops_the_node_with_the_line(flightsw: Generated, tmp_path: Path) -> None:
    cfg = identity_config(tmp_path)
    os.chmod(tmp_path / "keys" / "rmax1ob1.id", 0o644)
    with pytest.raises(ConfigError) as refused:
        Node(flightsw.catalogue, config=cfg, node="primary", clock=FakeClock())
    text = str(refused.value)
    line = next(i for i, t in enumerate(cfg.read_text().splitlines(), 1) if '"identity"' in t)
    assert f":{line}: field 'security.identity':" in text and "chmod 600" in text, text
    assert "\n" not in text


def test_identities_without_the_group_key_are_refused(flightsw: Generated, tmp_path: Path) -> None:
    """Origin tags ride on signed frames: a config naming identities but no group key says so, in one line."""
    cfg = identity_config(tmp_path)
    doc = json.loads(cfg.read_text(encoding="utf-8"))
    for key in ("keys", "tx_key", "require_signed", "counter_file"):
        doc["security"].pop(key, None)
    cfg.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    with pytest.raises(ConfigError) as refused:
        Node(flightsw.catalogue, config=cfg, node="primary", clock=FakeClock())
    text = str(refused.value)
    assert "security.keys" in text and "\n" not in text, text
