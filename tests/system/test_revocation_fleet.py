"""Issue 23 item 4 on the paper's Table 2 as real processes on 127.0.0.1: every C node runs with its own
identity (uavbus keys authority create / issue, made at test time); the operator hands a revocation to one
node (`revoke FILE` on rmax1ob2's stdin); it reaches rmax1ob1 (1 hop) and fcs20 (2 hops) over the signed
links, each persists it, a restarted node still holds it, and the revoked vehicle cannot start again with
its identity (it is told why, in one line)."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path
from typing import Any

import pytest

from uavbus import keys
from uavbus.sim.build import REPO
from uavbus.sim.hitl import Hitl, HitlOptions
from uavbus.sim.process import NodeError
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(150)

TABLE2 = REPO / "examples" / "configs" / "table2.json"
ROLES = {"gcs1": "admin", "rmax1ob1": "vehicle,relay", "rmax1ob2": "vehicle", "fcs20": "vehicle"}


def identity_config(tmp_path: Path, roles_of: dict[str, str] = ROLES) -> Path:
    kdir = tmp_path / "keys"
    keys.authority_create(str(kdir))
    for entity, roles in roles_of.items():
        keys.issue(entity, roles, 30, None, str(kdir), None, False)
    cfg = signed_config(TABLE2, tmp_path)
    # each node its own copy of the fleet's certificates (a node rewrites its copy when it learns one)
    for entity in roles_of:
        shutil.copyfile(kdir / "fleet.certs", tmp_path / "state" / f"{entity}.certs")
    doc: dict[str, Any] = json.loads(cfg.read_text(encoding="utf-8"))
    doc["security"].update({"authority": str(kdir / "authority.pub"), "identity": str(kdir / "{entity}.id"),
                            "certificates": "state/{entity}.certs",
                            "revocations": "state/{entity}.revocations.ubr"})
    cfg.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return cfg


def identity(h: Hitl, node: str) -> dict[str, Any]:
    ident = h.child_stats(node)["identity"]
    assert ident is not None, f"{node}: no identity in its stats"
    return ident


def test_a_revocation_reaches_the_fleet_persists_and_locks_the_vehicle_out(hitl_opts: HitlOptions,
                                                                            tmp_path: Path) -> None:
    hitl_opts.config = identity_config(tmp_path)
    h = Hitl(hitl_opts)
    h.start()
    try:
        # traffic on every link (a TCP connection is adopted, and freshness proven, by authentic frames)
        nav = h.add_row("subscription", "navFilterState", "rmax1ob2", "gcs1", 100)
        imu = h.add_row("subscription", "imuOut", "fcs20", "gcs1", 20)
        h.wait_status(nav, "active", 8.0)
        h.wait_status(imu, "active", 8.0)
        for node in ("primary", "secondary", "backup"):
            ident = identity(h, node)
            assert ident["serial"] >= 1 and ident["revocations"] == 0
        out = keys.revoke("fcs20", None, None, str(tmp_path / "keys"), None)
        assert "revoked up to serial" in out
        proc = h.group["secondary"]
        m = proc.mark()
        t0 = time.monotonic()
        proc.send(f"revoke {tmp_path / 'keys' / 'revocations.ubr'}")
        ev = h.child_event("secondary", "revoke", 3.0, since=m)
        assert ev["accepted"] == 1 and ev["refused"] == 0 and ev["revocations"] == 1
        # one hop (rmax1ob1) and two hops (fcs20, its own identity): held, and persisted
        h.run_until(lambda: identity(h, "primary")["revocations"] == 1, 5.0, "rmax1ob1 holds the revocation")
        h.run_until(lambda: identity(h, "backup")["revocations"] == 1, 5.0, "fcs20 holds the revocation")
        elapsed = time.monotonic() - t0
        print(f"revocation: submitted at rmax1ob2, held by rmax1ob1 and fcs20 (2 hops) within {elapsed * 1000:.0f} ms")
        assert elapsed < 2.0, f"the revocation took {elapsed:.2f} s to cross two hops"
        for entity in ("rmax1ob1", "fcs20"):
            assert (tmp_path / "state" / f"{entity}.revocations.ubr").stat().st_size == 8 + 104
        # idempotent: the same file again is known everywhere, and nothing new is spread
        m = proc.mark()
        proc.send(f"revoke {tmp_path / 'keys' / 'revocations.ubr'}")
        assert h.child_event("secondary", "revoke", 3.0, since=m)["known"] == 1
        primary = identity(h, "primary")
        assert primary["revocations_accepted"] == 1 and primary["revocations_refused"] == 0
        # a restarted node still holds it (read back from its revocations file)
        h.restart("primary")
        assert identity(h, "primary")["revocations"] == 1
        # the revoked vehicle's restart with the same identity: refused, saying why and what to do
        with pytest.raises(NodeError) as refused:
            h.restart("backup")
        text = str(refused.value)
        assert "revoked" in text and "uavbus keys issue fcs20" in text, text
        # re-keying the replacement is one command; it starts, announces its certificate, and the fleet learns it
        out = keys.issue("fcs20", "vehicle", 30, None, str(tmp_path / "keys"), None, True)
        assert "serial 5" in out, out
        h.restart("backup")
        assert identity(h, "backup")["serial"] == 5
        h.run_until(lambda: identity(h, "primary")["certs_accepted"] >= 1, 5.0, "rmax1ob1 learns the new fcs20")
        h.run_until(lambda: identity(h, "secondary")["certs_accepted"] >= 1, 5.0, "rmax1ob2 learns it, 2 hops")
        # ...and keeps it: its certificates file now holds serial 5 for fcs20
        text = keys.show(str(tmp_path / "state" / "rmax1ob2.certs"))
        assert "fcs20: serial 5" in text, text
    finally:
        h.close()


@pytest.mark.parametrize("gcs_roles", ["admin", "observer"])
def test_who_administers_is_the_certificates_role(hitl_opts: HitlOptions, tmp_path: Path, gcs_roles: str) -> None:
    """gcs1 asks rmax1ob1 to publish gpsOut to rmax1ob2 (data to a third party: administrators only). The
    vehicle's node judges gcs1 on its certificate: served when it says admin, refused NOT_AUTHORIZED when
    it says observer, with the same name, keys and configuration."""
    hitl_opts.config = identity_config(tmp_path, {**ROLES, "gcs1": gcs_roles})
    h = Hitl(hitl_opts)
    h.start()
    try:
        row = h.add_row("publication", "gpsOut", "rmax1ob1", "rmax1ob2", 100)
        if gcs_roles == "admin":
            h.wait_status(row, "active", 8.0)
        else:
            st = h.run_until(lambda: (s := h.admin.status(row)) and s.get("nack_reason") and s, 8.0,
                             "a NACK for the observer's request")
            assert "authorized" in str(st["nack_reason"]).lower(), st
            drops = h.child_stats("primary")["node"]["drops"]
            assert drops["not_authorized"] >= 1, drops
    finally:
        h.close()
