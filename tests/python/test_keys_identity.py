"""`uavbus keys authority create | issue | revoke | show` on real files, as an operator runs them: files
0600 where secret, refusals in one line that say what to do, re-keying a replacement in one command, and
the node's loader (ub_identfile_load_store, through cffi) taking or refusing what the CLI wrote."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from uavbus._bindings import ub_ident
from uavbus._bindings.ub_error import ConfigError

UAVBUS = [sys.executable, "-m", "uavbus.cli"]


def keys(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*UAVBUS, "keys", *args], capture_output=True, text=True, cwd=cwd)


def one_line(text: str) -> str:
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    return lines[0]


@pytest.fixture()
def fleet(tmp_path: Path) -> Path:
    out = keys("authority", "create", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    return tmp_path


def test_authority_create_writes_secret_0600_and_never_overwrites(fleet: Path) -> None:
    key, pub = fleet / "keys" / "authority.key", fleet / "keys" / "authority.pub"
    assert key.stat().st_mode & 0o777 == 0o600
    assert pub.stat().st_size == 40 and key.stat().st_size == 40
    before = key.read_bytes()
    again = keys("authority", "create", cwd=fleet)
    assert again.returncode == 1
    assert "already exists" in one_line(again.stderr) and str(key.relative_to(fleet)) in again.stderr
    assert key.read_bytes() == before


def test_issue_show_and_load(fleet: Path) -> None:
    out = keys("issue", "rmax1ob1", "--roles", "vehicle,relay", "--days", "30", cwd=fleet)
    assert out.returncode == 0, out.stderr
    ident = fleet / "keys" / "rmax1ob1.id"
    assert ident.stat().st_mode & 0o777 == 0o600
    shown = keys("show", "keys/rmax1ob1.id", cwd=fleet)
    assert shown.returncode == 0, shown.stderr
    text = one_line(shown.stdout)
    assert "identity of rmax1ob1, serial 1, roles vehicle,relay, valid" in text
    assert "authority" in keys("show", "keys/authority.pub", cwd=fleet).stdout
    # the node's loader takes it, with the roles the CLI asked for
    now = int(time.time())
    store = ub_ident.Store.load(fleet / "keys" / "authority.pub", ident, fleet / "state.ubr", now)
    cert = store.self_cert()
    assert cert is not None and cert.entity_name == "rmax1ob1" and cert.serial == 1
    assert store.roles(ub_ident.entity_id("rmax1ob1"), now) == ub_ident.ROLES["vehicle"] | ub_ident.ROLES["relay"]
    # and refuses it 31 days later, saying what to do
    with pytest.raises(ConfigError, match="expired .* uavbus keys issue rmax1ob1"):
        ub_ident.Store.load(fleet / "keys" / "authority.pub", ident, None, now + 31 * 86400)


def test_refusals_are_one_line(fleet: Path) -> None:
    assert keys("issue", "gcs1", "--roles", "admin", cwd=fleet).returncode == 0
    again = keys("issue", "gcs1", "--roles", "admin", cwd=fleet)
    assert again.returncode == 1 and "--force" in one_line(again.stderr)
    bad_role = keys("issue", "gcs2", "--roles", "admin,pilot", cwd=fleet)
    assert bad_role.returncode == 1 and "unknown role 'pilot'" in one_line(bad_role.stderr)
    bad_name = keys("issue", "a-name-that-is-too-long", "--roles", "admin", cwd=fleet)
    assert bad_name.returncode == 1 and "1 to 12 characters" in one_line(bad_name.stderr)
    os.chmod(fleet / "keys" / "gcs1.id", 0o644)
    shown = keys("show", "keys/gcs1.id", cwd=fleet)
    assert shown.returncode == 1 and "chmod 600" in one_line(shown.stderr)
    os.chmod(fleet / "keys" / "authority.key", 0o640)
    issued = keys("issue", "fcs20", "--roles", "vehicle", cwd=fleet)
    assert issued.returncode == 1 and "chmod 600" in one_line(issued.stderr)
    unknown = keys("revoke", "nobody", cwd=fleet)
    assert unknown.returncode == 1 and "--serial" in one_line(unknown.stderr)


def test_revoke_then_rekey_the_replacement(fleet: Path) -> None:
    assert keys("issue", "rmax1ob1", "--roles", "vehicle", cwd=fleet).returncode == 0
    old = (fleet / "keys" / "rmax1ob1.id").read_bytes()
    (fleet / "captured.id").write_bytes(old)
    os.chmod(fleet / "captured.id", 0o600)
    out = keys("revoke", "rmax1ob1", cwd=fleet)
    assert out.returncode == 0, out.stderr
    assert "revoked up to serial 1" in out.stdout
    revs = fleet / "keys" / "revocations.ubr"
    assert "rmax1ob1: serials up to 1 revoked" in keys("show", str(revs), cwd=fleet).stdout
    # idempotent: the same revocation again changes nothing
    assert "(already)" in keys("revoke", "rmax1ob1", cwd=fleet).stdout
    assert revs.stat().st_size == 8 + 104
    # re-keying the replacement is one command; it gets serial 2
    out = keys("issue", "rmax1ob1", "--roles", "vehicle", "--force", cwd=fleet)
    assert out.returncode == 0 and "serial 2" in out.stdout, out.stderr
    now = int(time.time())
    pub = fleet / "keys" / "authority.pub"
    store = ub_ident.Store.load(pub, fleet / "keys" / "rmax1ob1.id", revs, now)
    assert store.self_cert() is not None and store.self_cert().serial == 2
    # the captured (old) identity cannot start a node, nor join as a peer
    with pytest.raises(ConfigError, match="revoked"):
        ub_ident.Store.load(pub, fleet / "captured.id", revs, now)
    peer_store = ub_ident.Store.load(pub, None, revs, now)
    assert peer_store.add_peer(old[8:8 + 176], now) == "revoked"
