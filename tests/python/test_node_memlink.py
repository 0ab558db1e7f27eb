"""Two Python nodes over a C memlink, with an injected clock: typed delivery, the admin row life
cycle, counters read back from C, and a struct published by Python equal to the generated pack."""

from __future__ import annotations

import re

import pytest

from binding_testutil import TABLE2, FakeClock, Generated
from binding_testutil import run_nodes as run
from uavbus import Catalogue, MemLink, Node
from uavbus._bindings.ub_error import RangeError
from uavbus_gen import model


@pytest.fixture()
def pair(flightsw: Generated):
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    link = MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
    yield gcs, air, link, clock
    gcs.close()
    air.close()


def test_subscription_delivers_typed_values(pair, flightsw: Generated) -> None:
    gcs, air, link, clock = pair
    gps = air.bind("gpsOut")
    t = gps.type
    first = t.packed_fields[0].name
    values = flightsw.catalogue.default("gpsOut")
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    got = []
    gcs.on_data(got.append)
    run([gcs, air], clock, 400)
    assert got, "no DATA delivered"
    assert got[-1].name == "gpsOut" and got[-1].source == "rmax1ob1" and got[-1].dest == "gcs1"
    assert got[-1].value == values
    # Change a member on the hosting side: the next delivery carries it, decoded to a typed value.
    leaf = next(f for f in t.packed_fields if f.wire in ("f64", "f32") and not f.dims)
    setattr(gps, leaf.name, 12.5)
    run([gcs, air], clock, 200)
    assert got[-1].value[leaf.name] == 12.5
    assert gcs.directory("gpsOut").to_dict()[leaf.name] == 12.5
    assert getattr(gcs.directory("gpsOut"), leaf.name) == 12.5
    c = gcs.counters()
    assert c["delivered"] == len(got) and c["drops"]["layout_mismatch"] == 0
    rows = gcs.pubsub_rows("gcs1")
    assert rows[0]["kind"] == "subscription" and rows[0]["content"] == "gpsOut" and rows[0]["state"] == "receiving"
    assert air.pubsub_rows("rmax1ob1")[0]["kind"] == "publication"
    links = gcs.link_counters()
    assert links["gcsPortDatalink1"]["frames_in"] >= len(got) and links["gcsPortDatalink1"]["transport"] == "mem"
    assert first in gcs.directory("gpsOut").fields


def test_admin_row_pending_acknowledged_active(pair) -> None:
    gcs, air, link, clock = pair
    air.bind("gpsOut")
    adm = gcs.admin("gcs1", retry_ms=100)
    r = adm.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=50, kind="publication")
    assert adm.status(r)["status"] == "inactive"
    adm.activate(r)
    clock.t += 1
    gcs.service()  # tick: PUB_REQUEST queued on the memlink
    assert adm.status(r)["status"] == "pending" and adm.status(r)["attempts"] == 1
    link.pump(clock.t)  # request reaches the source, which queues its ACK (no data sent yet)
    link.pump(clock.t)  # the ACK reaches the GCS
    gcs._dispatch()
    s = adm.status(r)
    assert s["status"] == "acknowledged" and s["acked_at_ms"] == clock.t
    clock.t += 1
    air.service()  # the source's tick sends DATA and an ACK with FLOWING
    gcs.service()
    s = adm.status(r)
    assert s["status"] == "active" and s["active_at_ms"] == clock.t
    assert adm.rows()[0]["content"] == "gpsOut"
    assert gcs.counters()["drops"]["unbound"] == 1  # the GCS hosts no gpsOut yet: counted, not lost
    gcs.bind("gpsOut")
    run([gcs, air], clock, 200)
    assert gcs.counters()["delivered"] > 0
    adm.deactivate(r)
    run([gcs, air], clock, 300)
    assert adm.status(r)["status"] == "inactive"


def test_admin_nack_unbound_fails(pair) -> None:
    gcs, air, link, clock = pair  # air does not bind gpsOut: the source refuses
    adm = gcs.admin("gcs1", max_retries=3)
    r = adm.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=50)
    adm.activate(r)
    run([gcs, air], clock, 300)
    s = adm.status(r)
    assert s["status"] == "failed" and s["nack_reason"] == "unbound"


def test_published_struct_equals_generated_pack(pair, flightsw: Generated) -> None:
    gcs, air, link, clock = pair
    m = flightsw.model
    inst = flightsw.catalogue.instance("gpsOut")
    mt = m.type(inst.type.name)
    values = model.value_tree(model.test_leaves(m, mt), m, mt)
    air.bind("gpsOut").from_dict(values)
    gcs.bind("gpsOut")
    got = []
    gcs.on_data(got.append)
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=20)
    run([gcs, air], clock, 100)
    cls = {c.NAME: c for c in flightsw.module.TYPES}[inst.type.name]
    assert got and got[0].raw == cls.from_dict(values).pack() == model.expected_packed(m, mt)


def test_corruption_counted_by_c(flightsw: Generated) -> None:
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    link = MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", faults={"corrupt_ppm": 500000}, seed=7)
    air.bind("gpsOut")
    gcs.bind("gpsOut")
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=10)
    got = []
    gcs.on_data(got.append)
    run([gcs, air], clock, 500)
    bad = sum(gcs.link_counters()["gcsPortDatalink1"]["bad_frames"].values())
    assert link.stats()["a"]["corrupted"] > 0 and bad == link.stats()["a"]["rejected"] > 0
    assert len(got) == gcs.counters()["delivered"] > 0


def test_unknown_instance_and_entity(pair) -> None:
    gcs, _, _, _ = pair
    with pytest.raises(KeyError, match="no instance"):
        gcs.bind("nope")
    with pytest.raises(LookupError, match="not in the node's table"):
        gcs.subscribe("nobody", "gpsOut", source="rmax1ob1", period_ms=10)
    with pytest.raises(OverflowError):
        gcs.subscribe("gcs1", "gpsOut", source="a_name_too_long", period_ms=10)
    assert [e["name"] for e in gcs.entities()] == ["rmax1ob1", "rmax1ob2", "fcs20", "gcs1"]
    assert gcs.local_entities == ["gcs1"]


def test_directory_views(flightsw: Generated, kinds: Generated) -> None:
    cat: Catalogue = kinds.catalogue
    node = Node(cat)
    node.add_entity("a", local=True)
    d = node.bind("kinds")
    d.vel.x = 1.5
    d.matrix = [[1.0, 2.0, 3.0]] * 3
    d.bf_u3 = 5
    assert d.vel.to_dict() == {"x": 1.5, "y": 0.0, "z": 0.0}
    assert d.to_dict()["matrix"][2] == [1.0, 2.0, 3.0] and d.bf_u3 == 5
    with pytest.raises(ValueError, match="bf_u3"):
        d.bf_u3 = 9
    with pytest.raises(AttributeError, match="no packed member"):
        d.text = 1
    cls = {c.NAME: c for c in kinds.module.TYPES}["struct all_kinds"]
    assert d.to_object(cls).pack() == d.raw
    node.close()


def test_record_with_c_writer(pair, tmp_path) -> None:
    gcs, air, link, clock = pair
    air.bind("gpsOut")
    gcs.bind("gpsOut")
    path = tmp_path / "gcs.ublog"
    gcs.record(path, tx=True)
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=20)
    run([gcs, air], clock, 200)
    assert gcs.counters()["log"]["records"] == gcs.counters()["delivered"] > 0
    stats = gcs.stop_recording()
    assert stats is not None and stats["write_errors"] == 0
    data = path.read_bytes()
    assert data.startswith(b"UBLOG3\r\n") and len(data) == stats["bytes"]
    assert b'"gcs"' in data[:2048]  # the meta names this node


def test_record_refuses_a_size_limit_below_the_header(pair, flightsw: Generated, tmp_path) -> None:
    """Issue 29: a max_bytes below the header started a file per frame (350 files in 5 s). Refused with a
    one-line reason naming the smallest limit; at that limit recording works."""
    gcs, air, link, clock = pair
    path = tmp_path / "small.ublog"
    with pytest.raises(RangeError, match=r"max_bytes 1000 is below (\d+), the smallest file that holds the log "
                                         r"header \(meta and catalogue, twice\) and one largest record") as exc:
        gcs.record(path, max_bytes=1000, max_files=3)
    assert not path.exists()
    floor = int(re.search(r"below (\d+)", str(exc.value)).group(1))
    assert floor > 2 * len(flightsw.catalogue.json_text)  # the catalogue is in both copies of the header
    gcs.record(path, max_bytes=floor, max_files=3)
    assert gcs.stop_recording()["files"] == 1


def test_publisher_sends_the_directory_with_names_resolved_once(pair) -> None:
    gcs, air, link, clock = pair
    gcs.bind("gpsOut")
    got = []
    gcs.on_data(got.append)
    pub = air.publisher("rmax1ob1", "gpsOut", to="gcs1")
    for k in range(5):
        pub.directory.solutionCount = 100 + k       # a plain scalar: the one-pack_into path
        assert pub.send() == 1                      # one link (onboardPortDatalink1) took it
        run([gcs, air], clock, 5)
    assert [m.value["solutionCount"] for m in got] == [100, 101, 102, 103, 104]
    assert [m.seq for m in got] == sorted(m.seq for m in got) and got[0].source == "rmax1ob1"
    assert got[-1].raw == air.directory("gpsOut").raw
    with pytest.raises(Exception, match="solutionCount"):
        pub.directory.solutionCount = -1             # an unsigned member refuses, never wraps
    # Unknown destination: the C router refuses and counts it; nothing is sent.
    before = air.counters()["drops"]["no_route"]
    with pytest.raises(Exception):
        air.publisher("rmax1ob1", "gpsOut", to="nobody").send()
    assert air.counters()["drops"]["no_route"] == before + 1


def test_on_frame_sees_every_frame_and_recording_goes_on(pair, tmp_path) -> None:
    from uavbus.logfile import LogReader

    gcs, air, link, clock = pair
    air.bind("gpsOut")
    gcs.record(tmp_path / "gcs.ublog", tx=True)
    frames = []
    gcs.on_frame(lambda name, direction, frame, t_ms: frames.append((name, direction, len(frame))))
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    run([gcs, air], clock, 300)
    rx = [f for f in frames if f[1] == "rx"]
    tx = [f for f in frames if f[1] == "tx"]
    assert rx and tx and {f[0] for f in frames} == {"gcsPortDatalink1"}
    stats = gcs.stop_recording()
    assert stats is not None and stats["records"] == len(frames) and stats["write_errors"] == 0
    assert sum(1 for _ in LogReader(tmp_path / "gcs.ublog").records()) == len(frames)


def test_recording_rotates_and_keeps_max_files(pair, tmp_path) -> None:
    from uavbus.logfile import LogReader

    gcs, air, link, clock = pair
    air.bind("gpsOut")
    path = tmp_path / "gcs.ublog"
    gcs.record(path, tx=True, max_ms=100, max_files=3)  # the node's clock: a new file every 100 ms
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=10)
    run([gcs, air], clock, 1000)
    stats = gcs.stop_recording()
    assert stats is not None and stats["write_errors"] == 0
    assert stats["files"] >= 9 and stats["files_deleted"] == stats["files"] - 3
    files = sorted(tmp_path.glob("gcs*.ublog"))
    assert len(files) == 3 and path not in files  # the first files were deleted
    seqs = [r.seq for f in files for r in LogReader(f).records()]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # the newest records, none missing
    assert seqs[-1] == stats["records"] - 1
