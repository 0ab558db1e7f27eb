"""Origin authentication through the Pythonic tier (node.security.enable_origin(); docs/security.md, "Origin
authentication"): two Python nodes of Table 2 over a memlink, each entity with its own X25519 key and a lookup
standing in for the identity store. Frames flow and are origin-checked; a peer the store refuses is dropped
`no_identity` on its next recheck; a lookup that raises refuses the peer (fail closed) and is reported;
bad arguments are clear errors."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from binding_testutil import TABLE2, FakeClock, Generated, run_nodes
from uavbus import MemLink, Node
from uavbus._bindings.ub_error import InvalidArgumentError
from uavbus.keys import x25519_public_key
from uavbus.sim.secure import signed_config


def pair(flightsw: Generated, tmp_path: Path, lookup_gcs=None, lookup_air=None):  # noqa: ANN001, ANN201
    clock = FakeClock()
    config = signed_config(TABLE2, tmp_path)
    gcs = Node(flightsw.catalogue, config=config, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=config, node="primary", clock=clock)
    MemLink(gcs, "gcsPortDatalink1", air, "onboardPortDatalink1", seed=1)
    secret = {"gcs1": os.urandom(32), "rmax1ob1": os.urandom(32)}
    public = {n: x25519_public_key(sk) for n, sk in secret.items()}
    store = {"revoked": set()}

    def lookup(name: str, now_s: int) -> bytes | None:
        return None if name in store["revoked"] else public.get(name)

    gcs.security.enable_origin({"gcs1": secret["gcs1"]}, lookup_gcs or lookup)
    air.security.enable_origin({"rmax1ob1": secret["rmax1ob1"]}, lookup_air or lookup)
    return gcs, air, clock, store


def test_frames_flow_origin_checked_and_a_revoked_peer_is_refused(flightsw: Generated, tmp_path: Path) -> None:
    gcs, air, clock, store = pair(flightsw, tmp_path)
    air.bind("gpsOut")
    got = []
    gcs.on_data(got.append)
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    run_nodes([gcs, air], clock, 1000)
    assert len(got) >= 12
    mine, theirs = gcs.security.origin_status(), air.security.origin_status()
    assert mine is not None and theirs is not None
    assert mine["opened"] >= len(got) and theirs["sealed"] >= len(got)
    assert mine["derivations"] == theirs["derivations"] == 1 and mine["cached"] == 1
    assert gcs.counters()["drops"]["bad_origin"] == gcs.counters()["drops"]["no_identity"] == 0
    # the store revokes rmax1ob1: within the recheck (1 s) gcs1 refuses its frames
    store["revoked"].add("rmax1ob1")
    run_nodes([gcs, air], clock, 1200)
    n = len(got)
    run_nodes([gcs, air], clock, 1000)
    assert len(got) == n
    assert gcs.counters()["drops"]["no_identity"] >= 15
    assert gcs.security.origin_forget("rmax1ob1") == 0      # already forgotten by the refusal
    gcs.close()
    air.close()


def test_a_lookup_that_raises_refuses_the_peer(flightsw: Generated, tmp_path: Path) -> None:
    def broken(name: str, now_s: int) -> bytes | None:
        raise RuntimeError("store offline")

    gcs, air, clock, _ = pair(flightsw, tmp_path, lookup_gcs=broken)
    air.bind("gpsOut")
    got = []
    gcs.on_data(got.append)
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    run_nodes([gcs, air], clock, 600)
    assert got == []
    assert gcs.security.origin_status()["no_identity"] >= 1
    assert isinstance(gcs.security._origin.error, RuntimeError)
    gcs.close()
    air.close()


def test_bad_arguments_are_clear_errors(flightsw: Generated, tmp_path: Path) -> None:
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=signed_config(TABLE2, tmp_path), node="gcs", clock=clock)
    with pytest.raises(InvalidArgumentError, match="32 bytes"):
        gcs.security.enable_origin({"gcs1": b"short"}, lambda n, t: None)
    with pytest.raises(InvalidArgumentError, match="32 bytes"):
        x25519_public_key(b"\0" * 31)
    plain = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    with pytest.raises(InvalidArgumentError, match="without security"):
        plain.security.enable_origin({"gcs1": os.urandom(32)}, lambda n, t: None)
    assert plain.security.origin_status() is None
    gcs.close()
    plain.close()
