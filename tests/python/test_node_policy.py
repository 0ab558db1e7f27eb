"""A configuration's "security" section reaches Python nodes through the C loader, and the Admin API
reports the target's refusals by name (issue 11, items 5 and 6; docs/pubsub.md "Authorization and
limits"). rmax1ob2 runs an administration table although table2_policy.json gives it no exclusive
rights: what it may still do, it gets; the rest comes back as "not_authorized" or "limit"."""

from __future__ import annotations

from binding_testutil import TABLE2, FakeClock, Generated
from binding_testutil import run_nodes as run
from uavbus import MemLink, Node

TABLE2_POLICY = TABLE2.with_name("table2_policy.json")


def test_policy_from_config_and_nack_reasons_by_name(flightsw: Generated) -> None:
    clock = FakeClock()
    air = Node(flightsw.catalogue, config=TABLE2_POLICY, node="primary", clock=clock)
    sec = Node(flightsw.catalogue, config=TABLE2_POLICY, node="secondary", clock=clock)
    try:
        MemLink(air, "onboardPortIPC", sec, "onboard2PortIPC", seed=3)
        for content in ("gpsOut", "onboardSet"):
            air.bind(content)
            sec.bind(content)
        adm = sec.admin("rmax1ob2")
        foreign = adm.add("gpsOut", source="rmax1ob1", destination="gcs1", period_ms=100)       # someone else's
        secret = adm.add("onboardSet", source="rmax1ob1", destination="rmax1ob2", period_ms=100)  # read policy
        fast = adm.add("gpsOut", source="rmax1ob1", destination="rmax1ob2", period_ms=5)         # min_period_ms
        for r in (foreign, secret, fast):
            adm.activate(r)
        run([air, sec], clock, 300)
        assert [adm.status(r)["nack_reason"] for r in (foreign, secret, fast)] == \
            ["not_authorized", "not_authorized", "limit"]
        assert all(adm.status(r)["status"] == "failed" for r in (foreign, secret, fast))
        c = air.counters()
        assert c["drops"]["not_authorized"] == 2 and c["requests_limited"] == 1, c
        assert air.pubsub_rows("rmax1ob1") == []

        # Within its rights it is served: data to itself, readable, at an allowed rate; its own table set
        # the flow up, so its write policy stores what arrives.
        adm.remove(fast)
        ok = adm.add("gpsOut", source="rmax1ob1", destination="rmax1ob2", period_ms=50)
        adm.activate(ok)
        run([air, sec], clock, 500)
        assert adm.status(ok)["status"] == "active" and adm.status(ok)["nack_reason"] is None
        assert sec.counters()["delivered"] >= 5 and sec.counters()["drops"]["not_allowed"] == 0
        rows = air.pubsub_rows("rmax1ob1")
        assert len(rows) == 1 and rows[0]["lease_until_ms"] > 0   # a non-administrator's row always has a lease
        ids = [adm.status(r)["request_id"] for r in (foreign, secret, ok)]
        assert len(set(ids)) == 3 and min(ids) > 16, ids            # from the OS, not 1, 2, 3
    finally:
        air.close()
        sec.close()


def test_seeded_request_ids_are_reproducible(flightsw: Generated) -> None:
    ids = []
    for _ in range(2):
        n = Node(flightsw.catalogue, config=TABLE2_POLICY, node="gcs", random_seed=7)
        adm = n.admin("gcs1")
        r = adm.add("gpsOut", source="rmax1ob1", destination="gcs1", period_ms=100)
        adm.activate(r)
        ids.append(adm.status(r)["request_id"])
        n.close()
    assert ids[0] == ids[1] and ids[0] not in (0, 1)
