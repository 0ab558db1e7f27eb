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


def _catalogue(files: list[str], includes: list[str], scheme: str) -> model.Catalogue:
    old = os.getcwd()
    os.chdir(REPO)
    try:
        units = frontend.parse_files(files, frontend.ParseOptions(tuple(includes)))
        return model.build_catalogue(units, scheme, model.make_relpath(files, str(REPO)))
    finally:
        os.chdir(old)


def emit_c(vectors: list[dict], catalogue: str) -> str:
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
    out += ["int main(void) {", "    const struct CMUnitTest tests[] = {"]
    out += [f"        cmocka_unit_test({fn})," for fn in tests]
    out += ["    };", "    return cmocka_run_group_tests(tests, NULL, NULL);", "}", ""]
    return "\n".join(out)


def build() -> str:
    doc = {"description": "Packed directory structs (little-endian, no padding) for deterministic values; "
                          "written by tests/vectors/make_struct_vectors.py",
           "vectors": [v for case in CASES for v in vectors_for(*case)]}
    return json.dumps(doc, indent=1) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if structs.json differs from what would be written")
    ap.add_argument("--emit-c", nargs=2, metavar=("CATALOGUE", "OUT"),
                    help="write the cmocka test for CATALOGUE's vectors in structs.json to OUT")
    args = ap.parse_args()
    if args.emit_c:
        vectors = json.loads(OUTPUT.read_text())["vectors"]
        catalogue, out = args.emit_c
        if catalogue not in {case[0] for case in CASES}:
            ap.error(f"--emit-c: no vectors for catalogue '{catalogue}' (known: {', '.join(c[0] for c in CASES)})")
        Path(out).write_text(emit_c(vectors, catalogue))
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
