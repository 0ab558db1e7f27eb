"""Layout fingerprints: over packed field names, wire types and dimensions, recursively; not over
the type's own name or skipped members."""

from __future__ import annotations

import hashlib
from pathlib import Path

from gen_testutil import catalogue_of, write

from uavbus_gen import model


def fp(tmp_path: Path, body: str, extra: str = "") -> tuple[int, str]:
    h = write(tmp_path, "f.h", f"#include <stdint.h>\n{extra}\nstruct t {{ {body} }};\nextern struct t inst;\n")
    t = catalogue_of(h).type("struct t")
    return t.fingerprint, t.canonical


def test_canonical_text_and_hash(tmp_path: Path) -> None:
    value, text = fp(tmp_path, "int32_t a; float m[2][3]; uint8_t b : 3; struct in { uint16_t q; } n[4];")
    assert text == "a:i32;m:f32[2][3];b:u8/3;n:{q:u16}[4]"
    assert value == int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


def test_type_name_is_not_hashed(tmp_path: Path) -> None:
    a = fp(tmp_path, "int32_t a; double b;")[0]
    h = write(tmp_path, "g.h", "#include <stdint.h>\nstruct other { int32_t a; double b; };\nextern struct other o;\n")
    assert catalogue_of(h).type("struct other").fingerprint == a


def test_fingerprint_changes_with_layout(tmp_path: Path) -> None:
    base = fp(tmp_path, "int32_t a; double b;")[0]
    assert fp(tmp_path, "int32_t a2; double b;")[0] != base  # field name
    assert fp(tmp_path, "uint32_t a; double b;")[0] != base  # wire type
    assert fp(tmp_path, "int32_t a[2]; double b;")[0] != base  # dimensions
    assert fp(tmp_path, "double b; int32_t a;")[0] != base  # order


def test_nested_changes_propagate(tmp_path: Path) -> None:
    one = fp(tmp_path, "struct in n;", "struct in { int16_t q; };")[0]
    two = fp(tmp_path, "struct in n;", "struct in { int32_t q; };")[0]
    assert one != two


def test_skipped_members_do_not_count(tmp_path: Path) -> None:
    assert fp(tmp_path, "int32_t a; char *s; char name[8];")[0] == fp(tmp_path, "int32_t a;")[0]


def test_fingerprint_range() -> None:
    assert 0 <= model.fingerprint("") <= 0xFFFFFFFF
