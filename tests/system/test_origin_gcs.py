"""Origin authentication (issue 23 item 2) between real processes on 127.0.0.1: a Python ground station
(gcs1, uavbus.Node through cffi) and a C vehicle (`uavbus_node`, rmax1ob1) on a signed network, each with its
own X25519 identity (key files made at test time; a peers file and a Python lookup stand in for the identity
store). Every frame between them carries an origin tag the other end checks; frames flow both ways. Then a
third key holder ("mallory": the group key and an identity of its own, a captured vehicle) forges frames in
gcs1's name to rmax1ob1 from its own socket, with its own pairwise key or with no origin block, one of them
with the lockout counter 2^48 - 2: the vehicle drops each under its own reason, and gcs1 keeps
administering it afterwards (its window was not moved).
"""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path

import pytest

from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_node as un
from uavbus._bindings import ub_origin, ub_sec
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.process import ProcessGroup
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(90)

CONFIG = {
    "system": "origin",
    "entities": [
        {"name": "rmax1ob1", "links": ["radio"], "linktoentity": {"gcs1": ["radio"], "mallory": ["radio"]}},
        {"name": "gcs1", "links": ["gcsRadio"], "linktoentity": {"rmax1ob1": ["gcsRadio"]}},
        {"name": "mallory", "links": ["malRadio"], "linktoentity": {"rmax1ob1": ["malRadio"]}},
    ],
    "nodes": {"vehicle": ["rmax1ob1"], "gcs": ["gcs1"], "mallory": ["mallory"]},
}
NAMES = ("rmax1ob1", "gcs1", "mallory")


def identities(tmp: Path) -> tuple[dict[str, bytes], dict[str, bytes]]:
    """A fresh X25519 identity per entity (a key file each, mode 0600), and the peers file of public keys."""
    sks, pks = {}, {}
    for name in NAMES:
        path = tmp / f"{name}.x25519"
        ub_sec.ub_keyfile_new(str(path), 1)
        sks[name] = ub_sec.ub_keyfile_load(str(path))[1]
        pks[name] = ub_origin.ub_origin_public_key(sks[name])
    (tmp / "peers.txt").write_text("# entity  X25519 public key\n"
                                   + "".join(f"{n} {pks[n].hex()}\n" for n in NAMES))
    return sks, pks


def forged(group_key: bytes, pair_key: bytes | None, counter: int, payload: bytes) -> bytes:
    """A SIGNED frame "from gcs1" to rmax1ob1 (an admin ACK: any frame is refused before its meaning) with a
    right hop tag, and an origin tag under `pair_key` (mallory's own towards rmax1ob1) or no origin block."""
    sec = ub_sec.ub_sec_new({1: group_key})
    header = uf.FrameHeader(dir_id=bytes(16), dest_id=un.entity_id("rmax1ob1"), src_id=un.entity_id("gcs1"),
                            admin=5, hop_limit=8, payload_size=len(payload), seq=counter & 0xFFFFFFFF,
                            key_id=1, counter_hi=counter >> 32, flags=uf.FLAG_SIGNED)
    if pair_key is not None:
        header = uf.FrameHeader(**{**header.__dict__, "flags": uf.FLAG_SIGNED | uf.FLAG_ORIGIN, "origin_hop0": 8})
        tag = ub_origin.ub_origin_tag(pair_key, header, payload)
        header = uf.FrameHeader(**{**header.__dict__, "origin_tag": tag})
    return ub_sec.ub_sec_protect(sec, header, payload)


def test_python_gcs_and_c_vehicle_exchange_origin_authenticated_frames(program: Path, tmp_path: Path) -> None:
    from uavbus import Catalogue, Node

    plain = tmp_path / "origin.json"
    plain.write_text(json.dumps(CONFIG, indent=1))
    config = signed_config(plain, tmp_path)
    sks, pks = identities(tmp_path)
    lookups: list[str] = []

    def store(name: str, now_s: int) -> bytes | None:
        lookups.append(name)
        return pks.get(name)

    with ProcessGroup() as group:
        vehicle = group.spawn([program, "--config", config, "--node", "vehicle", "--port", "radio=udp:bind=127.0.0.1:0",
                               "--stats-ms", "0", "--origin-key", tmp_path / "{entity}.x25519",
                               "--origin-peers", tmp_path / "peers.txt"], "vehicle", ready_timeout=8.0)
        vport = int(vehicle.wait_ready()["ports"]["radio"]["local_port"])
        gcs = Node(Catalogue.load(catalogue_for(program)), config=config, node="gcs")
        try:
            gcs.security.enable_origin({"gcs1": sks["gcs1"]}, store)
            gcs.open_port("gcsRadio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}")
            admin = gcs.admin("gcs1")
            row = admin.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=100)
            gcs.bind("gpsOut")
            admin.activate(row)
            got = [m for m, _ in zip(gcs.messages(timeout=8.0), range(5))]
            assert len(got) == 5 and all(m.name == "gpsOut" and m.source == "rmax1ob1" for m in got)
            mine = gcs.security.origin_status()
            assert mine is not None and mine["opened"] >= 5 and mine["sealed"] >= 1
            assert mine["derivations"] == 1 and mine["bad_origin"] == mine["no_origin"] == 0
            assert "rmax1ob1" in lookups
            theirs = vehicle.request_stats()["security"]["origin"]
            assert theirs["opened"] >= 1 and theirs["sealed"] >= 5 and theirs["derivations"] == 1
            assert theirs["bad_origin"] == theirs["no_identity"] == 0

            # mallory, a key holder with an identity of its own, speaks as gcs1 from its own socket
            group_key = ub_sec.ub_keyfile_load(str(tmp_path / "keys" / "fleet-1.key"))[1]
            own_key, _ = ub_origin.ub_origin_pair_keys(un.entity_id("mallory"), sks["mallory"],
                                                       un.entity_id("rmax1ob1"), pks["rmax1ob1"])
            lockout = (1 << 48) - 2
            frames = [forged(group_key, own_key, lockout - i, bytes(8)) for i in range(5)]
            frames += [forged(group_key, None, lockout - 10 - i, bytes(8)) for i in range(3)]
            mal = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            for f in frames:
                mal.sendto(f, ("127.0.0.1", vport))
            mal.close()
            deadline = time.monotonic() + 5.0
            drops: dict[str, int] = {}
            while time.monotonic() < deadline:
                gcs.poll(0.05)
                drops = vehicle.request_stats()["links"]["radio"]["drops"]
                if drops["bad_origin"] + drops["no_origin"] >= 8:
                    break
            assert drops["bad_origin"] == 5 and drops["no_origin"] == 3, drops
            assert drops["replay"] == 0

            # gcs1 still administers the vehicle: a new row is accepted and served
            row2 = admin.add(content="navFilterState", source="rmax1ob1", destination="gcs1", period_ms=100)
            gcs.bind("navFilterState")
            admin.activate(row2)
            got = [m for m, _ in zip((m for m in gcs.messages(timeout=8.0) if m.name == "navFilterState"), range(3))]
            assert len(got) == 3
            assert admin.status(row2)["status"] == "active"
            final = vehicle.request_stats()
            assert final["security"]["origin"]["bad_origin"] == 5
            assert final["links"]["radio"]["drops"]["replay"] == 0
        finally:
            gcs.close()
