"""Issue 23 acceptance, "the insider advertises routes for entities it does not own", on real processes: the
routed identity network of the demo's insider step (uavbus.sim.insider.routed_insider). The captured vehicle
rmax1ob2, with its own valid identity and a real routing engine, advertises three entities that have no
certificate (and fcs20, certified but not its own) at metric 0 to rmax1ob1 (the C program, `--route
certified=1`) and gcs1 (a Python node, `routing.enable(certified=True)`). Every uncertified entry that crossed
the taps is refused `dest_refused` and none is routed; fcs20's claim is the threat model's open case (named,
asserted as it is)."""

from __future__ import annotations

from pathlib import Path

import pytest

from uavbus import Catalogue, Node
from uavbus import keys as keytool
from uavbus.errors import InvalidArgumentError
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.insider import CLAIMED, GHOSTS, TABLE2_POLICY, routed_insider
from uavbus.sim.portalloc import PortAllocator

pytestmark = pytest.mark.timeout(60)


def test_uncertified_routes_are_refused_by_c_and_python(program: Path, tmp_path: Path) -> None:
    keytool.fleet(str(TABLE2_POLICY), str(tmp_path / "fleet"), days=30)
    cat = Catalogue.load(catalogue_for(program))
    r = routed_insider(tmp_path / "fleet", program, cat, PortAllocator())
    print(r.line())
    for victim in ("rmax1ob1", "gcs1"):
        assert r.extra["sent"][victim] >= len(GHOSTS) * 3, r.line()     # several updates each way
        assert r.extra["refused"][victim] == r.extra["sent"][victim], r.line()
        assert r.extra["learned"][victim] == [], r.line()
        # the open case: a certified entity's metric-0 claim is taken (attraction, not forgery)
        assert r.extra["claimed"][victim] == "rmax1ob2", r.line()
    assert r.accepted == 0 and r.dropped_as == {"dest_refused": r.sent}, r.line()
    assert CLAIMED in r.effect


def test_certified_routing_needs_identities(program: Path) -> None:
    node = Node(Catalogue.load(catalogue_for(program)), config=TABLE2_POLICY, node="gcs")
    try:
        with pytest.raises(InvalidArgumentError, match="certified=True needs identities"):
            node.routing.enable(certified=True)
        assert not node.routing.enabled
    finally:
        node.close()
