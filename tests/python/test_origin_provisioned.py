"""A microcontroller entity on a fleet with identities (issue 23 item 8): fcs20 holds no X25519 key and no
store, only the table the authority computed for it (`uavbus keys pairwise fcs20`: its directional keys with
each peer and the group key), loaded as the firmware loads it (ub_origin_load_pairs). gcs1 and rmax1ob1 run
ordinary identities and derive their keys with fcs20 from its certificate. Over Table 2's memlinks (gcs1 -
rmax1ob1 - fcs20): imuOut reaches gcs1 origin-verified through the forwarder, gcs1's requests are verified at
fcs20 without a single key agreement there; frames in gcs1's name without gcs1's key are dropped at fcs20; a
reprovisioned table without a revoked peer cuts that peer off; the table's checks refuse a damaged one."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import pytest

from binding_testutil import FakeClock, Generated, run_nodes
from test_node_identity import identity_config
from uavbus import MemLink, Node, keys
from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_node as un
from uavbus._bindings import ub_origin, ub_sec
from uavbus._bindings.ub_error import UbError


def mcu_config(cfg: Path) -> Path:
    """fcs20's configuration: the group key and counters, no identity (the board has none to load)."""
    doc = json.loads(cfg.read_text(encoding="utf-8"))
    for k in ("authority", "identity", "certificates", "revocations"):
        doc["security"].pop(k, None)
    out = cfg.with_name("mcu.json")
    out.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return out


def forged(cat: object, src: str, dest: str, payload: bytes, key_id: int, key: bytes, counter: int,
           tag: bytes | None) -> bytes:
    """A frame in `src`'s name with a right hop tag (the group key) and an origin tag `tag` (None: no block)."""
    from uavbus.sim.attacker import frame_header

    hdr = frame_header(cat, "imuCalibration", src, dest, 0, counter, payload_size=len(payload))
    flags = uf.FLAG_SIGNED | (uf.FLAG_ORIGIN if tag is not None else 0)
    hdr = uf.FrameHeader(**{**hdr.__dict__, "flags": flags, "key_id": key_id, "origin_hop0": 8 if tag else 0,
                            "origin_tag": tag or bytes(8)})
    return ub_sec.ub_sec_protect(ub_sec.ub_sec_new({key_id: key}), hdr, payload)


def test_a_provisioned_entity_speaks_with_derived_ones(flightsw: Generated, tmp_path: Path) -> None:
    cfg = identity_config(tmp_path)
    kdir = tmp_path / "keys"
    group = json.loads(cfg.read_text(encoding="utf-8"))["security"]["keys"][0]
    (kdir / "fleet-1.key").write_bytes((tmp_path / group).read_bytes())
    (kdir / "fleet-1.key").chmod(0o600)
    table_path, peers = keys.pairwise("fcs20", str(kdir))
    assert sorted(peers) == ["gcs1", "rmax1ob1", "rmax1ob2"]
    assert oct(table_path.stat().st_mode & 0o777) == "0o600"
    table = table_path.read_bytes()
    assert len(table) == 56 + 3 * 44 + 4
    # the keys in it are what each peer derives from fcs20's certificate
    from uavbus._bindings import ub_ident

    _c, _s, gcs_sk = ub_ident.identfile_load(kdir / "gcs1.id")
    fcs_cert, _s2, _k = ub_ident.identfile_load(kdir / "fcs20.id")
    g_tx, g_rx = ub_origin.ub_origin_pair_keys(un.entity_id("gcs1"), gcs_sk, un.entity_id("fcs20"), fcs_cert.kx_pk)
    at = table.index(un.entity_id("gcs1"), 56)
    assert table[at + 12:at + 28] == g_rx and table[at + 28:at + 44] == g_tx    # fcs20->gcs1, gcs1->fcs20

    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=cfg, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=cfg, node="primary", clock=clock)
    fcs = Node(flightsw.catalogue, config=mcu_config(cfg), node="backup", clock=clock)
    try:
        assert fcs.identity is None
        info = fcs.security.enable_origin_table(table_path)
        assert info == {"entity": "fcs20", "pairs": 3, "group_key_id": 1}
        MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
        MemLink(air, "onboardPortRelay", fcs, "onboardPortDatalink1", seed=2)
        nodes = [gcs, air, fcs]
        got: list[str] = []
        gcs.on_data(lambda m: got.append(m.source))
        gcs.subscribe("gcs1", "imuOut", source="fcs20", period_ms=50)
        fcs.bind("imuOut")
        fcs.bind("imuCalibration")
        run_nodes(nodes, clock, 2000)
        assert got.count("fcs20") >= 30, got[-5:]
        mine, theirs = gcs.security.origin_status(), fcs.security.origin_status()
        assert mine["opened"] >= 30 and mine["bad_origin"] == mine["no_origin"] == 0, mine
        assert theirs["opened"] >= 1 and theirs["sealed"] >= 30, theirs       # gcs1's request, verified there
        assert theirs["derivations"] == theirs["lookups"] == 0, theirs        # no key agreement on the board

        # frames in gcs1's name without gcs1's pairwise key: a guessed tag, no block -> dropped at fcs20
        gid, gkey = ub_sec.ub_keyfile_load(str(kdir / "fleet-1.key"))
        cal = bytes(flightsw.catalogue.instance("imuCalibration").type.packed_size)
        before = dict(fcs.link_counters()["onboardPortDatalink1"]["drops"])
        c0 = 1 << 40
        bad = [forged(flightsw.catalogue, "gcs1", "fcs20", cal, gid, gkey, c0 + i, bytes([0xA5]) * 8) for i in range(5)]
        bare = [forged(flightsw.catalogue, "gcs1", "fcs20", cal, gid, gkey, c0 + 10 + i, None) for i in range(5)]
        for f in bad + bare:
            un.ub_node_rx_frame(fcs._c, fcs.link_id("onboardPortDatalink1"), f, clock.t)
        after = fcs.link_counters()["onboardPortDatalink1"]["drops"]
        assert after["bad_origin"] - before.get("bad_origin", 0) == 5
        assert after["no_origin"] - before.get("no_origin", 0) == 5

        # the operator revokes rmax1ob2 and reprovisions fcs20: the new table has no pair with it
        keys.revoke("rmax1ob2", None, None, str(kdir), None)
        _t2, peers2 = keys.pairwise("fcs20", str(kdir))
        assert sorted(peers2) == ["gcs1", "rmax1ob1"]
    finally:
        for n in (gcs, air, fcs):
            n.close()


def test_a_damaged_table_is_refused() -> None:
    body = b"UBPR" + bytes([1, 1, 0, 0]) + un.entity_id("fcs20") + bytes([1, 1, 0, 0]) + bytes(32)
    body += un.entity_id("gcs1") + bytes(range(32))
    good = body + struct.pack("<I", uf.ub_crc32c(body))
    ctx, info = ub_origin.OriginContext.provisioned(good)
    assert info["pairs"] == 1 and info["entity"] == un.entity_id("fcs20") and ctx.cached() == 1
    for bad in (good[:-1], good[:-4] + b"\0\0\0\0", b"UBPX" + good[4:], good[:4] + b"\x02" + good[5:],
                body[:56] + un.entity_id("fcs20") + bytes(32)):
        with pytest.raises(UbError, match="provisioning table"):
            ub_origin.OriginContext.provisioned(bad)


def test_keys_fleet_writes_a_boards_table_and_refuses_a_stranger(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from binding_testutil import TABLE2

    out = tmp_path / "fleet"
    assert keys.main(["fleet", str(TABLE2), "--out", str(out), "--mcu", "nobody"]) == 1
    assert "--mcu nobody: not an entity of" in capsys.readouterr().err
    assert not out.exists()                                     # refused before anything was written
    assert keys.main(["fleet", str(TABLE2), "--out", str(out), "--mcu", "fcs20"]) == 0
    table = (out / "fcs20.pairs").read_bytes()
    ctx, info = ub_origin.OriginContext.provisioned(table)
    assert info["entity"] == un.entity_id("fcs20") and info["pairs"] == 3 and info["group_key_id"] == 1
    assert keys.main(["pairwise", "fcs20", "--dir", str(out), "--peers", "gcs1,ghost"]) == 1
    assert "no valid certificate" in capsys.readouterr().err
