"""Every field kind and every skip reason, as the front end + model see tests/gen_cases/all_kinds.h."""

from __future__ import annotations

import pytest
from gen_testutil import ALL_KINDS, catalogue_of

from uavbus_gen import ids, model


@pytest.fixture(scope="module")
def cat() -> model.Catalogue:
    return catalogue_of(ALL_KINDS)


@pytest.fixture(scope="module")
def kinds(cat: model.Catalogue) -> dict[str, model.Field]:
    return {f.name: f for f in cat.type("struct all_kinds").fields if f.name}


@pytest.mark.parametrize(
    "name, wire",
    [
        ("c", "i8"), ("sc", "i8"), ("uc", "u8"), ("s", "i16"), ("us", "u16"), ("i", "i32"), ("ui", "u32"),
        ("l", "i64"), ("ul", "u64"), ("ll", "i64"), ("ull", "u64"), ("i8", "i8"), ("u16", "u16"),
        ("i32", "i32"), ("u64", "u64"), ("flag", "bool"), ("f", "f32"), ("d", "f64"), ("ld", "f64"),
        ("count", "u16"),
    ],
)
def test_scalars(kinds: dict[str, model.Field], name: str, wire: str) -> None:
    f = kinds[name]
    assert f.skipped is None and f.dims == () and f.bits is None
    assert f.wire is not None and f.wire.name == wire


def test_long_double_is_binary64(kinds: dict[str, model.Field]) -> None:
    assert kinds["ld"].long_double and not kinds["d"].long_double


def test_enums_at_their_real_width(kinds: dict[str, model.Field]) -> None:
    assert kinds["mode"].wire.name == "u32"  # type: ignore[union-attr]
    assert kinds["wide"].wire.name == "i64"  # type: ignore[union-attr]
    assert kinds["tiny"].wire.name == "u8"  # type: ignore[union-attr]


@pytest.mark.parametrize(
    "name, wire, bits",
    [("bf_u3", "u8", 3), ("bf_s5", "i8", 5), ("bf_u12", "u16", 12), ("bf_u40", "u64", 40),
     ("bf_s33", "i64", 33), ("bf_b", "bool", 1)],
)
def test_bitfields_in_smallest_container(kinds: dict[str, model.Field], name: str, wire: str, bits: int) -> None:
    f = kinds[name]
    assert (f.wire.name, f.bits) == (wire, bits)  # type: ignore[union-attr]


def test_bitfield_bit_offsets(kinds: dict[str, model.Field]) -> None:
    assert kinds["bf_s5"].offset_bits == kinds["bf_u3"].offset_bits + 3
    assert kinds["bf_u12"].offset_bits == kinds["bf_s5"].offset_bits + 5


def test_nested_and_arrays(cat: model.Catalogue, kinds: dict[str, model.Field]) -> None:
    assert (kinds["vel"].struct, kinds["vel"].dims) == ("struct vec3", ())
    assert (kinds["matrix"].wire.name, kinds["matrix"].dims) == ("f32", (3, 3))  # type: ignore[union-attr]
    assert (kinds["route"].struct, kinds["route"].dims) == ("waypoint_t", (4,))
    assert (kinds["grid"].struct, kinds["grid"].dims) == ("struct vec3", (2, 2))
    assert cat.type("waypoint_t").c_name == "waypoint_t"


def test_anonymous_struct_members_are_flattened(kinds: dict[str, model.Field]) -> None:
    assert kinds["roll"].wire.name == "i16" and kinds["pitch"].wire.name == "i16"  # type: ignore[union-attr]
    assert kinds["pitch"].offset_bits == kinds["roll"].offset_bits + 16


def test_unnamed_member_type_gets_a_parent_scoped_name(cat: model.Catalogue, kinds: dict[str, model.Field]) -> None:
    inner = cat.type(kinds["unnamed_member"].struct)  # type: ignore[arg-type]
    assert inner.name == "struct all_kinds::unnamed_member" and inner.c_name is None
    assert inner not in cat.named_types


def test_byte_arrays_are_data(kinds: dict[str, model.Field]) -> None:
    assert (kinds["bytes"].wire.name, kinds["bytes"].dims) == ("i8", (6,))  # type: ignore[union-attr]
    assert (kinds["raw"].wire.name, kinds["raw"].dims) == ("u8", (2, 3))  # type: ignore[union-attr]
    assert kinds["flags"].wire.name == "bool"  # type: ignore[union-attr]


def test_packed_struct(cat: model.Catalogue) -> None:
    hdr = cat.type("struct packed_hdr")
    assert hdr.packed_attr and hdr.size == 7 and hdr.packed_size == 7
    assert [f.offset_bits // 8 for f in hdr.fields] == [0, 1, 5]


@pytest.mark.parametrize(
    "name, reason",
    [("name", "string"), ("text", "pointer"), ("ptr", "pointer"), ("handler", "pointer"), ("vp", "pointer"),
     ("either", "union"), ("tail", "flexible array member")],
)
def test_skip_reasons(kinds: dict[str, model.Field], name: str, reason: str) -> None:
    assert kinds[name].skipped == reason and kinds[name].wire is None


def test_anonymous_union_member_skipped(cat: model.Catalogue) -> None:
    anon = [f for f in cat.type("struct all_kinds").fields if not f.name]
    assert [f.skipped for f in anon] == ["union"]


def test_zero_packed_fields_still_catalogued(cat: model.Catalogue) -> None:
    empty = cat.type("struct empty_set")
    assert empty.packed_size == 0 and [f.skipped for f in empty.fields] == ["pointer", "pointer"]
    assert "nothing" in {i.name for i in cat.instances}


def test_packed_size_is_sum_of_packed_fields(cat: model.Catalogue) -> None:
    assert cat.type("struct vec3").packed_size == 12
    assert cat.type("waypoint_t").packed_size == 13  # no padding on the wire
    assert cat.type("struct all_kinds").size > cat.type("struct all_kinds").packed_size


def test_instances_visibility_and_macros(cat: model.Catalogue) -> None:
    names = {i.name for i in cat.instances}
    assert {"kinds", "hdr1", "nothing", "macro_set"} <= names
    assert "not_visible" not in names  # static
    assert [(s.name, s.reason.split(":")[0]) for s in cat.skipped_instances] == [("not_a_struct", "union"),
                                                                                   ("not_visible", "static")]


def test_array_elements_are_instances(cat: model.Catalogue) -> None:
    by_name = {i.name: i for i in cat.instances}
    assert {f"waypoints[{k}]" for k in range(3)} <= set(by_name)
    assert {"lattice[0][0]", "lattice[0][1]", "lattice[1][0]", "lattice[1][1]"} <= set(by_name)
    assert "waypoints" not in by_name and "lattice" not in by_name
    assert by_name["lattice[1][0]"].id == ids.dir_id_paper("lattice[1][0]") == b"lattice[ce[1][0]"
    assert by_name["waypoints[2]"].id == b"waypointoints[2]"
    assert by_name["lattice[1][0]"].index == (1, 0) and by_name["lattice[1][0]"].ident == "lattice_1_0"


def test_instances_sorted_by_id(cat: model.Catalogue) -> None:
    got = [i.id for i in cat.instances]
    assert got == sorted(got) and len(set(got)) == len(got)


def test_sizes_and_offsets_from_clang(cat: model.Catalogue) -> None:
    vec = cat.type("struct vec3")
    assert (vec.size, vec.align) == (12, 4)
    assert [f.offset_bits for f in vec.fields] == [0, 32, 64]
