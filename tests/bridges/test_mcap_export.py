"""`uavbus log export FILE --mcap OUT`, read back with the `mcap` package's own reader.

The log is written by the C log writer (Node.record) from real traffic: one instance of every type of
the example flight software's catalogue (nested structs, 2-D arrays, bitfields, bools, every integer
width) with seeded random values, published between two nodes over a memlink, received and sent
frames both recorded. Checked, each able to fail:
  - every channel's JSON Schema (jsonschema, draft 2020-12) validates every one of its messages, and
    stays within what Foxglove's JSON Schema reader takes (one type per field, one array dimension);
  - each message equals the log's value of that frame (decoded from the log by the catalogue,
    arrays of 2+ dimensions row-major), its log time is the record's time in Unix ns, its
    sequence the frame's; one channel per (source, directory), topic /<source>/<directory>;
  - frames recorded twice are written once, admin frames not at all, and the counts say so;
  - a NaN becomes null and is counted.
"""

from __future__ import annotations

import json
import math
import random
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader

from uavbus import Catalogue, MemLink, Node
from uavbus.catalogue import Type
from uavbus.logfile import LogReader
from uavbus.sim.hitl import catalogue_for
from uavbus.tools import logcmd

TABLE2 = Path(__file__).resolve().parents[2] / "examples" / "configs" / "table2.json"
INT = {"u8": (0, 255), "i8": (-128, 127), "u16": (0, 65535), "i16": (-32768, 32767), "u32": (0, 2**32 - 1),
       "i32": (-(2**31), 2**31 - 1), "u64": (0, 2**64 - 1), "i64": (-(2**63), 2**63 - 1)}


class Clock:
    def __init__(self) -> None:
        self.t = 5000

    def __call__(self) -> int:
        return self.t


def random_value(t: Type, cat: Catalogue, rng: random.Random) -> dict:
    def leaf(f):
        if f.struct:
            return random_value(cat.type(f.struct), cat, rng)
        if f.wire == "bool":
            return rng.random() < 0.5
        if f.wire == "f32":
            return float(__import__("struct").unpack("<f", __import__("struct").pack("<f", rng.uniform(-1e3, 1e3)))[0])
        if f.wire == "f64":
            return rng.uniform(-1e6, 1e6)
        lo, hi = INT[f.wire]
        if f.bits:
            lo, hi = (-(1 << (f.bits - 1)), (1 << (f.bits - 1)) - 1) if f.wire.startswith("i") else (0, (1 << f.bits) - 1)
        return rng.randint(lo, hi)

    def shaped(f, dims):
        if not dims:
            return leaf(f)
        return [shaped(f, dims[1:]) for _ in range(dims[0])]

    return {f.name: shaped(f, f.dims) for f in t.packed_fields}


FOXGLOVE_FIELD_TYPES = {"boolean", "string", "number", "integer", "object", "array"}


def foxglove_readable(schema: dict, where: str = "") -> None:
    """The constraints of Foxglove's JSON Schema reader (parseJsonSchema in its mcap-support package):
    an object root, one type name per field, arrays of scalars or objects (no array of arrays)."""
    assert schema.get("type") == "object", f"{where}: root is not an object"
    for name, field in schema["properties"].items():
        kind = field.get("type")
        assert isinstance(kind, str) and kind in FOXGLOVE_FIELD_TYPES, f"{where}.{name}: type {kind!r}"
        if kind == "object":
            foxglove_readable(field, f"{where}.{name}")
        if kind == "array":
            item = field["items"].get("type")
            assert item in FOXGLOVE_FIELD_TYPES - {"array"}, f"{where}.{name}: items of type {item!r}"
            if item == "object":
                foxglove_readable(field["items"], f"{where}.{name}[]")


def flat_value(t: Type, cat: Catalogue, v: dict) -> dict:
    """The log's decoded value as the export writes it (2+ dimensional arrays row-major)."""
    def flat(x):
        return [y for e in x for y in flat(e)] if isinstance(x, list) else [x]

    def leaf(f, x):
        return flat_value(cat.type(f.struct), cat, x) if f.struct else x

    out = {}
    for f in t.packed_fields:
        x = v[f.name]
        out[f.name] = [leaf(f, e) for e in (flat(x) if len(f.dims) > 1 else x)] if f.dims else leaf(f, x)
    return out


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, uavbus_node):
    """A log of every type's values published rmax1ob1 -> gcs1, recorded at gcs1 (rx and tx)."""
    cat = Catalogue.load(catalogue_for(uavbus_node))
    tmp = tmp_path_factory.mktemp("mcap")
    clock = Clock()
    gcs = Node(cat, config=TABLE2, node="gcs", clock=clock)
    air = Node(cat, config=TABLE2, node="primary", clock=clock)
    MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=3)
    rng = random.Random(18)
    chosen = {}
    for inst in cat.instances:
        if inst.type.name not in chosen and inst.type.packed_size > 0:
            chosen[inst.type.name] = inst
    senders = []
    for inst in chosen.values():
        gcs.bind(inst.name)
        senders.append(air.publisher("rmax1ob1", inst.name, to="gcs1"))
    # Admin frames in the log too: a request for a directory rmax1ob1 does not host (NACKed).
    other = next(i for i in cat.instances if i not in chosen.values() and i.type.packed_size > 0)
    gcs.subscribe("gcs1", other.name, source="rmax1ob1", period_ms=20)
    log_path = tmp / "gcs1.ublog"
    gcs.record(log_path, tx=True)
    for step in range(120):  # 600 ms: every directory sent with new values every 50 ms
        if step % 10 == 0:
            for inst, sender in zip(chosen.values(), senders):
                sender.directory.from_dict(random_value(inst.type, cat, rng))
                sender.send()
        clock.t += 5
        air.poll(0)
        gcs.poll(0)
    gcs.stop_recording()
    gcs.close()
    air.close()
    return log_path, cat, chosen


def test_every_message_validates_and_equals_the_log(recorded, tmp_path):
    log_path, cat, chosen = recorded
    out = tmp_path / "gcs1.mcap"
    assert logcmd.main(["export", str(log_path), "--mcap", str(out)], out=open(tmp_path / "o.txt", "w")) == 0
    report = json.loads((tmp_path / "o.txt").read_text())
    log = LogReader(log_path)
    expected = {}
    for rec in log:
        h = rec.header
        inst = cat.find(bytes(h.dir_id))
        if h.admin == 0 and inst is not None:
            expected.setdefault((h.src_id.rstrip(b"\0").decode(), h.seq), (rec, inst))
    assert report["messages"] == len(expected) > 400, report
    assert report["not_data"] > 0 and report["non_finite"] == 0, report

    seen_topics: dict[str, int] = {}
    with open(out, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert {a.name for a in reader.iter_attachments()} == {"catalogue.json"}
        validators = {sid: jsonschema.Draft202012Validator(json.loads(s.data)) for sid, s in summary.schemas.items()}
        # The units reach the file itself (imu.h: `double p; /**< [rad/s] roll rate, body x */`).
        imu = [json.loads(s.data) for s in summary.schemas.values() if s.name == cat.type_of("imuOut").name]
        assert len(imu) == 1 and imu[0]["properties"]["p"]["unit"] == "rad/s", imu
        for sid, s in summary.schemas.items():
            assert s.encoding == "jsonschema"
            jsonschema.Draft202012Validator.check_schema(json.loads(s.data))
            foxglove_readable(json.loads(s.data), s.name)
        n = 0
        locations = 0
        for schema, channel, message in reader.iter_messages():
            value = json.loads(message.data)
            validators[channel.schema_id].validate(value)
            source, directory = channel.metadata["source"], channel.metadata["directory"]
            if schema.name == "foxglove.LocationFix":  # the map's channel beside a directory with lat/lon
                assert channel.topic == f"/{source}/{directory}/location"
                rec, inst = expected[(source, message.sequence)]
                decoded = cat.decode(inst, rec.payload)
                assert value["latitude"] == decoded["latitudeDeg"] and value["longitude"] == decoded["longitudeDeg"]
                assert value["frame_id"] == source
                locations += 1
                continue
            assert channel.topic == f"/{source}/{directory}" and channel.message_encoding == "json"
            rec, inst = expected[(source, message.sequence)]
            assert inst.name == directory and schema.name == inst.type.name
            assert value == flat_value(inst.type, cat, cat.decode(inst, rec.payload))
            assert message.log_time == (log.header.start_unix_ms + rec.t_ms - log.header.start_t_ms) * 1_000_000
            seen_topics[channel.topic] = seen_topics.get(channel.topic, 0) + 1
            n += 1
    assert n == len(expected)
    with_position = [i for i in chosen.values() if {"latitudeDeg", "longitudeDeg"} <= {f.name for f in i.type.packed_fields}]
    assert with_position and locations == sum(seen_topics[f"/rmax1ob1/{i.name}"] for i in with_position)
    assert set(seen_topics) == {f"/rmax1ob1/{i.name}" for i in chosen.values()}, set(seen_topics) ^ {
        f"/rmax1ob1/{i.name}" for i in chosen.values()}


def test_non_finite_floats_become_null_and_are_counted(recorded, tmp_path):
    log_path, cat, chosen = recorded
    from uavbus.tools.mcap_export import McapStats, _Shaper

    t = cat.type_of("gpsOut")
    value = cat.decode("gpsOut", cat.encode("gpsOut", random_value(t, cat, random.Random(1))))
    leaf = next(f for f in t.packed_fields if f.wire in ("f32", "f64") and not f.dims)
    value[leaf.name] = math.nan
    stats = McapStats()
    shaped = _Shaper(cat, stats).value(t, value)
    assert shaped[leaf.name] is None and stats.non_finite == 1
    json.dumps(shaped, allow_nan=False)  # valid JSON for any reader


def test_units_from_the_headers_are_in_the_schemas(recorded):
    """imu.h documents imuOut.p as `/**< [rad/s] roll rate, body x */` and specificForce as `/* m/s^2, ... */`."""
    _, cat, _ = recorded
    from uavbus.tools.mcap_export import schema_document

    props = schema_document(cat.type_of("imuOut"), cat)["properties"]
    assert props["p"]["unit"] == "rad/s" and props["p"]["description"] == "[rad/s] roll rate, body x"
    assert props["specificForce"]["unit"] == "m/s^2" and props["specificForce"]["type"] == "object"
    assert "unit" not in props["sampleCount"]
    foxglove_readable(schema_document(cat.type_of("imuOut"), cat), "imuOut")
