"""The Cortex-M4 firmware on a fleet with identities (issue 23 item 8): booted in QEMU with the table the
authority computed for fcs20 (`uavbus keys pairwise fcs20`, loaded into its PROVISION flash sector at 0x1F000
as a programmer would write it), it signs with the group key and tags origins with its provisioned pair keys,
with libsodium's own code cross-built for the board and no X25519 on it. The host is gcs1, an ordinary
identity (`uavbus keys fleet`): it derives its keys with fcs20 from fcs20's certificate and refuses every
frame without a right origin tag. Asserted: the board answers a subscription whose frames gcs1 verifies;
the board is inspected and written by gcs1 (its origin-tagged requests verified on the board); frames in
gcs1's name without gcs1's key (a guessed tag, no block) are dropped by the board (its link's drop counter,
read over the bus) and change nothing."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from uavbus import Node, keys
from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_sec
from uavbus.sim.attacker import frame_header
from uavbus.sim.qemu import QemuBoard, qemu_missing

IMU_MS = 20
TURN_R = 0.2 * 0.971343      # flight_model.c: yaw rate of the coordinated turn, body z (rad/s)
PROVISION_ADDR = 0x1F000     # bsp/mps2_an386/mps2_an386.ld: the PROVISION sector


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("mcu-identity")
    cfg = d / "mcu.json"
    cfg.write_text(json.dumps({
        "system": "mcu-identity",
        "entities": [{"name": "gcs1", "links": ["uart"], "linktoentity": {"fcs20": "0x00000001"}},
                     {"name": "fcs20", "links": ["onboardPortDatalink1"]}],
        "nodes": {"gcs": ["gcs1"], "fcs": ["fcs20"]}}) + "\n", encoding="utf-8")
    identity_cfg, _roles = keys.fleet(str(cfg), str(d / "fleet"), days=30)
    keys.pairwise("fcs20", str(d / "fleet"))
    return identity_cfg


@pytest.fixture(scope="module")
def secure_board(firmware: Path, fleet: Path) -> Iterator[QemuBoard]:
    why = qemu_missing()
    if why:
        pytest.skip(why)
    table = fleet.parent / "fcs20.pairs"
    with QemuBoard(firmware, extra_args=["-device", f"loader,file={table},addr={PROVISION_ADDR:#x}"]) as b:
        yield b


@pytest.fixture(scope="module")
def gcs(secure_board: QemuBoard, open_host: Callable[..., Node], fleet: Path) -> Node:
    def has_identity(node: Node) -> None:
        assert node.identity is not None

    return open_host(secure_board.pty, config=fleet, setup=has_identity)


def test_board_answers_a_subscription_with_verified_origin_tags(secure_board: QemuBoard, gcs: Node,
                                                                collect: Callable[..., list[dict]]) -> None:
    gcs.subscribe("gcs1", "imuOut", "fcs20", IMU_MS)
    deadline = time.monotonic() + 30.0   # boot, then each side challenges the other once
    first: list[dict] = []
    while not first and time.monotonic() < deadline:
        first = collect(gcs, "imuOut", 0.5)
    assert first, f"no imuOut from the board in 30 s; {gcs.link_counters()['uart']}; {gcs.security.origin_status()}"
    values = collect(gcs, "imuOut", 3.0)
    assert len(values) >= 30, f"{len(values)} imuOut in 3 s for a {IMU_MS} ms subscription"
    assert all(abs(v["r"] - TURN_R) < 0.02 for v in values)
    st = gcs.security.origin_status()
    assert st is not None and st["opened"] >= len(values) and st["bad_origin"] == st["no_origin"] == 0, st
    drops = gcs.link_counters()["uart"]["drops"]
    assert drops["bad_origin"] == drops["no_origin"] == drops["bad_tag"] == 0, drops


def test_board_refuses_frames_in_gcs1s_name_without_its_key(secure_board: QemuBoard, gcs: Node, fleet: Path,
                                                          pump: Callable[..., None],
                                                          collect: Callable[..., list[dict]]) -> None:
    fcs = gcs.remote("fcs20", timeout=10.0)
    cal = fcs.get("imuCalibration")           # an origin-tagged request, verified on the board, answered
    assert cal["gyro"]["scale"] == [1.0, 1.0, 1.0], cal
    (uart,) = fcs.table("links")
    drops0, accepted0 = uart["drops"], uart["accepted"]
    gid, gkey = ub_sec.ub_keyfile_load(str(fleet.parent / "fleet-1.key"))
    zero = bytes(gcs.catalogue.instance("imuCalibration").type.packed_size)   # gyro scale 0: r would read 0
    frames = []
    for i in range(10):
        hdr = frame_header(gcs.catalogue, "imuCalibration", "gcs1", "fcs20", 0, (1 << 40) + i,
                           payload_size=len(zero))
        guess = i % 2 == 0
        hdr = uf.FrameHeader(**{**hdr.__dict__, "key_id": gid, "origin_hop0": 8 if guess else 0,
                                "flags": uf.FLAG_SIGNED | (uf.FLAG_ORIGIN if guess else 0),
                                "origin_tag": bytes([0x5A]) * 8 if guess else bytes(8)})
        frames.append(ub_sec.ub_sec_protect(ub_sec.ub_sec_new({gid: gkey}), hdr, zero))
    fd = os.open(secure_board.pty, os.O_WRONLY | os.O_NOCTTY)
    try:
        for f in frames:
            os.write(fd, f)
            pump(gcs, 0.05)
    finally:
        os.close(fd)
    pump(gcs, 0.5)
    (uart,) = fcs.table("links")
    assert uart["drops"] - drops0 >= len(frames), (uart, drops0)
    assert fcs.get("imuCalibration")["gyro"]["scale"] == [1.0, 1.0, 1.0]
    after = collect(gcs, "imuOut", 1.0)
    assert after and all(abs(v["r"] - TURN_R) < 0.02 for v in after), [v["r"] for v in after[:5]]
    # a write that is gcs1's (its node tags it) is taken: the board is not just refusing everything
    assert fcs.set("imuCalibration.gyro.bias", [0.5, 0.0, 0.0])
    pump(gcs, 0.3)
    assert all(abs(v["p"] - 0.5) < 0.01 for v in collect(gcs, "imuOut", 1.0)[2:])
    assert fcs.set("imuCalibration.gyro.bias", [0.0, 0.0, 0.0])
    (uart,) = fcs.table("links")
    assert uart["accepted"] > accepted0
