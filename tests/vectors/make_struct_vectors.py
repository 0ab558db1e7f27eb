#!/usr/bin/env python3
"""Writes tests/vectors/structs.json: packed directory structs for deterministic values.

For a few types of the flightsw example and of tests/gen_cases/all_kinds.h, every packed scalar
gets a value from its wire position (a rule unlike the generator's self-test values), and the
bytes come from a per-leaf `struct.pack` written here, sharing no code with the generated codecs
or with uavbus.Catalogue. Python (tests/python/test_vectors_structs.py) must reproduce every
vector byte for byte with both; a C test can do the same with the generated C pack.

    .venv/bin/python tests/vectors/make_struct_vectors.py            # rewrite structs.json
    .venv/bin/python tests/vectors/make_struct_vectors.py --check    # exit 1 if structs.json is stale
    .venv/bin/python tests/vectors/make_struct_vectors.py --emit-c flightsw OUT.c   # the cmocka side (build step)

`--emit-c` writes the C test (tests/vectors/CMakeLists.txt runs it at build time): for every
vector it assigns the values to the C struct member by member and checks that the *generated C*
pack gives the bytes of structs.json, and that the generated unpack gives the members back.

`refused` lists packed images no encoder writes: one vector's bytes with one bool or bitfield
container holding a value outside the field (a bool byte of 2, a 3-bit field holding 8, a 5-bit
signed field holding 16 or -17...). Every codec must refuse them (docs/catalogue.md, canonical
codecs): the generated C unpack returns UB_ERR_RANGE and writes nothing, Python raises.
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import sys
from pathlib import Path

from uavbus_gen import frontend, model

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
OUTPUT = HERE / "structs.json"
CODES = {"bool": "?", "u8": "B", "i8": "b", "u16": "H", "i16": "h", "u32": "I", "i32": "i", "u64": "Q",
         "i64": "q", "f32": "f", "f64": "d"}
# (catalogue, header files relative to the repository, clang -I dirs, id scheme, instances)
CASES = [
    ("flightsw", sorted(p.relative_to(REPO).as_posix() for p in (REPO / "examples/flightsw").glob("*.h")),
     ["examples/flightsw"], "paper", ["gpsOut", "imuOut", "navFilterState", "actuatorOut"]),
    ("kinds", ["tests/gen_cases/all_kinds.h"], [], "hashed", ["kinds", "hdr1", "lattice[0][0]"]),
]


def value(wire: str, bits: int | None, k: int) -> int | float | bool:
    """Leaf k's value: exact in its wire type, near the edges of integer ranges, sign alternating."""
    if wire == "bool":
        return k % 3 == 0
    if wire == "f32":
        return (-1) ** k * (k * 0.5 + 0.25)
    if wire == "f64":
        return (-1) ** (k + 1) * (k * 1024.125 + 0.0625)
    width = bits if bits is not None else struct.calcsize(CODES[wire]) * 8
    if wire.startswith("i"):
        top = (1 << (width - 1)) - 1
        return top - k if k % 2 else -top + k
    return ((1 << width) - 1 - k * 3) % (1 << width)


def vectors_for(name: str, files: list[str], includes: list[str], scheme: str, instances: list[str]) -> list[dict]:
    cat = _catalogue(files, includes, scheme)
    by_name = {i.name: i for i in cat.instances}
    out = []
    for inst_name in instances:
        t = cat.type(by_name[inst_name].type)
        leaves = [model.Leaf(leaf.path, leaf.field, value(leaf.field.wire.name, leaf.field.bits, k))  # type: ignore[union-attr]
                  for k, leaf in enumerate(model.test_leaves(cat, t))]
        packed = b"".join(struct.pack("<" + CODES[leaf.field.wire.name], leaf.value) for leaf in leaves)  # type: ignore[union-attr]
        out.append({"catalogue": name, "instance": inst_name, "type": t.name, "fingerprint": f"{t.fingerprint:08x}",
                    "packed_size": t.packed_size, "value": model.value_tree(leaves, cat, t), "packed": packed.hex()})
    return out


# (catalogue, instance, member path, raw container value): out of the member's width.
REFUSED = [
    ("kinds", "kinds", ("flag",), 2),
    ("kinds", "kinds", ("bf_b",), 2),
    ("kinds", "kinds", ("bf_u3",), 8),
    ("kinds", "kinds", ("bf_s5",), 16),
    ("kinds", "kinds", ("bf_s5",), -17),
    ("kinds", "kinds", ("bf_u12",), 4096),
    ("kinds", "kinds", ("bf_s33",), 1 << 32),
    ("kinds", "kinds", ("flags", 2), 255),
    ("flightsw", "gpsOut", ("status", "jammingLevel"), 16),
]


def refused_for(vectors: list[dict]) -> list[dict]:
    """The REFUSED images: the vector's bytes with the member's container overwritten."""
    out = []
    for name, inst_name, path, raw in REFUSED:
        case = next(c for c in CASES if c[0] == name)
        cat = _catalogue(case[1], case[2], case[3])
        t = cat.type({i.name: i for i in cat.instances}[inst_name].type)
        offset = 0
        for leaf in model.test_leaves(cat, t):
            w = leaf.field.wire
            assert w is not None
            if leaf.path == path:
                break
            offset += w.size
        else:
            raise SystemExit(f"{name}:{inst_name}: no member {path}")
        base = bytearray.fromhex(next(v["packed"] for v in vectors if (v["catalogue"], v["instance"]) == (name, inst_name)))
        base[offset:offset + w.size] = raw.to_bytes(w.size, "little", signed=raw < 0)
        f = leaf.field
        why = (f"bool byte {raw}" if w.name == "bool" else
               f"{raw} in a {f.bits}-bit {'signed ' if w.signed else ''}bitfield ({w.name} container)")
        out.append({"catalogue": name, "instance": inst_name, "type": t.name, "member": list(path),
                    "offset": offset, "why": why, "packed": base.hex()})
    return out


def _catalogue(files: list[str], includes: list[str], scheme: str) -> model.Catalogue:
    old = os.getcwd()
    os.chdir(REPO)
    try:
        units = frontend.parse_files(files, frontend.ParseOptions(tuple(includes)))
        return model.build_catalogue(units, scheme, model.make_relpath(files, str(REPO)))
    finally:
        os.chdir(old)


def emit_c(vectors: list[dict], catalogue: str, refused: list[dict] | None = None) -> str:
    """The cmocka test reproducing the vectors of `catalogue` with its generated C codecs
    (one program per catalogue: their input headers may define the same names)."""
    from uavbus_gen import render

    out = ["/* Generated from tests/vectors/structs.json by tests/vectors/make_struct_vectors.py --emit-c.",
           " * Do not edit. Each vector: values assigned in C, generated pack == the JSON bytes, unpack",
           " * gives the members back. */",
           "#include <setjmp.h>", "#include <stdarg.h>", "#include <stddef.h>", "#include <stdint.h>",
           "#include <cmocka.h>", "#include <stdlib.h>", "#include <string.h>", "",
           f'#include "{catalogue}.h"', ""]
    tests = []
    for case in CASES:
        name, files, includes, scheme, _ = case
        if name != catalogue:
            continue
        cat = _catalogue(files, includes, scheme)
        by_name = {i.name: i for i in cat.instances}
        for k, vec in enumerate(v for v in vectors if v["catalogue"] == name):
            t = cat.type(by_name[vec["instance"]].type)
            leaves = [model.Leaf(leaf.path, leaf.field, value(leaf.field.wire.name, leaf.field.bits, j))  # type: ignore[union-attr]
                      for j, leaf in enumerate(model.test_leaves(cat, t))]
            fn = f"test_{name}_{k}"
            tests.append(fn)
            packed = bytes.fromhex(vec["packed"])
            out += [f"/* {name} {vec['instance']} ({t.name}, {t.packed_size} bytes) */",
                    f"static void {fn}(void **state) {{",
                    "    (void)state;",
                    f"    static const uint8_t expected[{max(len(packed), 1)}] = {{ {render.c_bytes(packed)} }};",
                    f"    {t.c_name} *a = calloc(1, sizeof *a), *b = calloc(1, sizeof *b);",
                    f"    uint8_t buf[{t.packed_size + 1}];",
                    "    assert_non_null(a);", "    assert_non_null(b);"]
            out += [f"    {render.c_path(leaf.path, '(*a)')} = {render.c_literal(leaf.value, leaf.field)};" for leaf in leaves]
            out += [f"    assert_int_equal({name}_pack_{t.ident}(a, buf, sizeof buf), {t.packed_size});",
                    f"    assert_memory_equal(buf, expected, {t.packed_size});",
                    f"    assert_int_equal({name}_unpack_{t.ident}(b, buf, {t.packed_size}u), {t.packed_size});"]
            out += [f"    assert_true({render.c_path(leaf.path, '(*b)')} == {render.c_path(leaf.path, '(*a)')});"
                    for leaf in leaves]
            out += ["    free(a);", "    free(b);", "}", ""]
        types = {t.name: t for t in cat.types}
        for k, vec in enumerate(r for r in (refused or []) if r["catalogue"] == name):
            t = types[vec["type"]]
            fn = f"test_{name}_refused_{k}"
            tests.append(fn)
            packed = bytes.fromhex(vec["packed"])
            out += [f"/* {name} {vec['instance']}: {'.'.join(map(str, vec['member']))} holds {vec['why']}: refused */",
                    f"static void {fn}(void **state) {{",
                    "    (void)state;",
                    f"    static const uint8_t image[{len(packed)}] = {{ {render.c_bytes(packed)} }};",
                    f"    {t.c_name} *a = calloc(1, sizeof *a), *before = calloc(1, sizeof *before);",
                    "    assert_non_null(a);", "    assert_non_null(before);",
                    "    memset(a, 0x5A, sizeof *a);", "    memcpy(before, a, sizeof *a);",
                    f"    assert_int_equal({name}_unpack_{t.ident}(a, image, sizeof image), UB_ERR_RANGE);",
                    "    assert_memory_equal(a, before, sizeof *a); /* nothing written */",
                    "    free(a);", "    free(before);", "}", ""]
    out += ["int main(void) {", "    const struct CMUnitTest tests[] = {"]
    out += [f"        cmocka_unit_test({fn})," for fn in tests]
    out += ["    };", "    return cmocka_run_group_tests(tests, NULL, NULL);", "}", ""]
    return "\n".join(out)


def build() -> str:
    vectors = [v for case in CASES for v in vectors_for(*case)]
    doc = {"description": "Packed directory structs (little-endian, no padding) for deterministic values; "
                          "written by tests/vectors/make_struct_vectors.py. `refused`: images no encoder writes "
                          "(a bool byte other than 0/1, a bitfield value outside its width), which every unpack refuses",
           "vectors": vectors,
           "refused": refused_for(vectors)}
    return json.dumps(doc, indent=1) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if structs.json differs from what would be written")
    ap.add_argument("--emit-c", nargs=2, metavar=("CATALOGUE", "OUT"),
                    help="write the cmocka test for CATALOGUE's vectors in structs.json to OUT")
    args = ap.parse_args()
    if args.emit_c:
        doc = json.loads(OUTPUT.read_text())
        catalogue, out = args.emit_c
        if catalogue not in {case[0] for case in CASES}:
            ap.error(f"--emit-c: no vectors for catalogue '{catalogue}' (known: {', '.join(c[0] for c in CASES)})")
        Path(out).write_text(emit_c(doc["vectors"], catalogue, doc.get("refused", [])))
        return 0
    text = build()
    if args.check:
        if not OUTPUT.exists() or OUTPUT.read_text() != text:
            print(f"{OUTPUT}: stale; run {Path(__file__).name} to rewrite it", file=sys.stderr)
            return 1
        return 0
    OUTPUT.write_text(text)
    print(f"wrote {OUTPUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
