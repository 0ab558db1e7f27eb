"""uavbus.Catalogue against the generator: the layout derived from the JSON alone must pack the
generator's self-test values to the model's expected bytes, exactly as the generated `<name>.py`."""

from __future__ import annotations

import pytest

from uavbus import Catalogue
from uavbus.catalogue import CatalogueError, EncodeError
from uavbus_gen import model
from uavbus_gen.catalogue_json import catalogue_json

from binding_testutil import Generated


def _cases(gen: Generated) -> list[tuple[model.StructType, dict, bytes]]:
    m = gen.model
    return [(t, model.value_tree(model.test_leaves(m, t), m, t), model.expected_packed(m, t)) for t in m.named_types]


@pytest.mark.parametrize("which", ["flightsw", "kinds"])
def test_every_type_matches_generator(which: str, request: pytest.FixtureRequest) -> None:
    gen: Generated = request.getfixturevalue(which)
    cat = gen.catalogue
    classes = {cls.NAME: cls for cls in gen.module.TYPES}
    cases = _cases(gen)
    assert len(cases) == len(classes) and cases
    for t, values, expected in cases:
        ct = cat.type(t.name)
        assert ct.packed_size == t.packed_size and ct.fingerprint == t.fingerprint
        packed = cat.encode(t.name, values)
        assert packed == expected, t.name
        assert packed == classes[t.name].from_dict(values).pack(), t.name
        assert cat.decode(t.name, packed) == values, t.name
        assert cat.decode(t.name, packed) == classes[t.name].unpack(packed).to_dict(), t.name


def test_instances_in_id_order(flightsw: Generated) -> None:
    cat = flightsw.catalogue
    assert [i.name for i in cat.instances] == [i.name for i in flightsw.model.instances]
    assert [i.id for i in cat.instances] == [iid for iid, _, _ in flightsw.module.INSTANCES]
    gps = cat.instance("gpsOut")
    assert cat.instances[gps.index] is gps and cat.instance_by_id(gps.id) is gps
    assert cat.type_of("gpsOut") is gps.type


def test_bitfield_and_shape_errors(kinds: Generated) -> None:
    cat = kinds.catalogue
    value = cat.default("kinds")
    assert cat.decode("kinds", cat.encode("kinds", value)) == value
    value["bf_u3"] = 8  # 3 bits: C would truncate to 0; refuse instead
    with pytest.raises(EncodeError, match="bf_u3"):
        cat.encode("kinds", value)
    value["bf_u3"] = 7
    value["bf_s5"] = -16
    assert cat.decode("kinds", cat.encode("kinds", value))["bf_s5"] == -16
    value["matrix"] = [[0.0] * 3] * 2
    with pytest.raises(EncodeError, match="matrix: expected a list of 3"):
        cat.encode("kinds", value)
    del value["matrix"]
    with pytest.raises(EncodeError, match="matrix: missing"):
        cat.encode("kinds", value)
    with pytest.raises(ValueError, match="needs 302 bytes"):
        cat.decode("kinds", b"\0" * 301)


def test_skipped_members_absent(kinds: Generated) -> None:
    t = kinds.catalogue.type("struct all_kinds")
    names = [f.name for f in t.packed_fields]
    assert "text" not in names and "name" not in names and "tail" not in names
    assert t.field("count").wire_offset == t.packed_size - 2
    assert t.field("ld").long_double and t.field("ld").wire == "f64"


def test_compact_json_round_trip(flightsw: Generated) -> None:
    cat = flightsw.catalogue
    again = Catalogue.from_json_text(cat.json_text)
    assert again.json_text == cat.json_text and len(again) == len(cat)
    # Byte-identical to what the generated C embeds in ub_catalogue_t.json.
    assert cat.json_text == catalogue_json(flightsw.model, "flightsw", compact=True)


def test_bad_documents(tmp_path) -> None:
    with pytest.raises(CatalogueError, match="invalid JSON"):
        Catalogue.from_json_text("{", origin="x.json")
    with pytest.raises(CatalogueError, match="not a uavbus catalogue"):
        Catalogue.from_json_text("{}")
    with pytest.raises(CatalogueError, match="cannot read"):
        Catalogue.load(tmp_path / "missing.json")


def test_c_catalogue_agrees(flightsw: Generated) -> None:
    from uavbus._bindings.ub_catalogue import ub_catalogue_find, ub_catalogue_find_name

    cat = flightsw.catalogue
    c = cat.c_catalogue
    assert c.n_instances == len(cat.instances)
    for inst in cat.instances[::37]:
        assert ub_catalogue_find(c, inst.id) == inst.index
        assert ub_catalogue_find_name(c, inst.name) == inst.index
        assert c.instances[inst.index].type.packed_size == inst.type.packed_size
        assert c.instances[inst.index].type.pack == c.instances[inst.index].type.pack  # NULL: wire image
    assert c.json_len == len(cat.json_text)
