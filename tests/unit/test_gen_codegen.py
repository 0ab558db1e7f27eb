"""Generated code: compiles with -std=c11 -Wall -Wextra -Werror, runs clean under ASan/UBSan,
Python bindings behave, JSON validates against the schema, output is deterministic."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import struct
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import jsonschema
import pytest
from uavbus_gen import render
from gen_testutil import ALL_KINDS, REPO, RUNTIME_INCLUDE, gcc, needs_gcc, run_cli, write

SCHEMA = json.loads((REPO / "schemas" / "catalogue.schema.json").read_text())


@pytest.fixture(scope="module")
def kinds_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("kinds")
    from uavbus_gen import cli

    assert cli.main(["gen", str(ALL_KINDS), "--name", "kinds", "-o", str(out)]) == 0
    return out


def load_module(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem + "_under_test", path)
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_outputs(kinds_out: Path) -> None:
    assert sorted(p.name for p in kinds_out.iterdir()) == ["kinds.c", "kinds.catalogue.json", "kinds.h", "kinds.py"]


def test_json_valid_against_schema(kinds_out: Path) -> None:
    doc = json.loads((kinds_out / "kinds.catalogue.json").read_text())
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    jsonschema.validate(doc, SCHEMA)
    assert all(len(i["id"]) == 32 for i in doc["instances"])
    assert all(not i["file"].startswith("/") for i in doc["instances"])


def test_schema_rejects_a_bad_id(kinds_out: Path) -> None:
    doc = json.loads((kinds_out / "kinds.catalogue.json").read_text())
    doc["instances"][0]["id"] = "xyz"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(doc, SCHEMA)


def test_generated_code_has_banner_abi_check_and_static_asserts(kinds_out: Path) -> None:
    h = (kinds_out / "kinds.h").read_text()
    c = (kinds_out / "kinds.c").read_text()
    assert "DO NOT EDIT" in h and "DO NOT EDIT" in c and "DO NOT EDIT" in (kinds_out / "kinds.py").read_text()
    assert f"#if UB_CATALOGUE_ABI_VERSION != {render.ABI_VERSION}" in h
    assert "kinds_LAYOUT_ASSERT(sizeof(struct vec3) == 12u" in c
    assert "kinds_LAYOUT_ASSERT(offsetof(struct all_kinds, roll)" in c
    assert "offsetof(struct all_kinds, bf_u3)" not in c  # bitfields have no offsetof
    # No -I finds the input: it is included by its path relative to the output directory.
    assert f'#include "{os.path.relpath(ALL_KINDS, kinds_out)}"' in h
    assert not re.search(r'["(\s]' + re.escape(str(REPO)), h + c)  # no absolute path (the include is relative)


C_MAIN = r"""
#include <stdio.h>
#include <string.h>
#include "kinds.h"
int main(void) {
    static struct all_kinds a, b;
    uint8_t buf[kinds_all_kinds_PACKED_SIZE];
    a.i = -5; a.bf_s5 = -9; a.ld = 1.5L; a.raw[1][2] = 7; a.route[3].pos.z = 2.5f; a.wide = WIDE_NEG;
    a.ptr = (int *)&a; b.ptr = (int *)&b;
    if (kinds_pack_all_kinds(&a, buf, sizeof buf - 1) != UB_ERR_NOSPACE) return 1;
    if (kinds_pack_all_kinds(&a, buf, sizeof buf) != (int)sizeof buf) return 2;
    if (kinds_unpack_all_kinds(&b, buf, sizeof buf - 1) != UB_ERR_TRUNCATED) return 3;
    if (kinds_unpack_all_kinds(&b, buf, sizeof buf) != (int)sizeof buf) return 4;
    if (b.i != -5 || b.bf_s5 != -9 || b.ld != 1.5L || b.raw[1][2] != 7 || b.route[3].pos.z != 2.5f) return 5;
    if (b.wide != WIDE_NEG || b.ptr != (int *)&b) return 6;
    uint8_t id[16] = kinds_ID_kinds;
    int at = ub_catalogue_find(&kinds_catalogue, id);
    if (at != (int)kinds_INST_kinds || strcmp(kinds_catalogue.instances[at].name, "kinds") != 0) return 7;
    if (kinds_catalogue.instances[kinds_INST_lattice_1_0].type->pack != kinds_catalogue.types[kinds_TYPE_vec3].pack) return 8;
    printf("ok %u\n", (unsigned)kinds_all_kinds_FINGERPRINT);
    return 0;
}
"""


@needs_gcc
@pytest.mark.parametrize("sanitize", [False, True], ids=["plain", "asan-ubsan"])
def test_generated_c_compiles_with_werror_and_runs(kinds_out: Path, tmp_path: Path, sanitize: bool) -> None:
    (tmp_path / "main.c").write_text(C_MAIN)
    flags = ["-std=c11", "-Wall", "-Wextra", "-Werror", "-g"]
    if sanitize:
        flags += ["-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    build = gcc(flags + ["-I", str(RUNTIME_INCLUDE), "-I", str(kinds_out), "-I", str(ALL_KINDS.parent),
                         str(kinds_out / "kinds.c"), "main.c", str(REPO / "runtime_c/src/codec/ub_catalogue.c"), "-o", "t"],
                tmp_path)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / "t")], capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.startswith("ok ")


def test_python_module_round_trip(kinds_out: Path) -> None:
    mod = load_module(kinds_out / "kinds.py")
    v = mod.vec3(x=1.0, y=2.0, z=3.0)
    assert v.pack() == struct.pack("<3f", 1.0, 2.0, 3.0)  # hand-checked wire form
    assert mod.vec3.unpack(v.pack()) == v
    w = mod.waypoint_t(id=9, pos=v)
    assert w.pack() == b"\x09" + struct.pack("<3f", 1.0, 2.0, 3.0)  # no padding
    big = mod.all_kinds()
    big.matrix[2][1] = -4.5
    big.route[1].pos.y = 8.0
    big.raw[1][2] = 200
    big.bf_s33 = -(2**32)
    back = mod.all_kinds.unpack(big.pack())
    assert back.matrix[2][1] == -4.5 and back.route[1].pos.y == 8.0 and back.raw[1][2] == 200
    assert back.bf_s33 == -(2**32)
    assert len(big.pack()) == mod.all_kinds.PACKED_SIZE
    assert mod.all_kinds.from_dict(back.to_dict()) == back
    assert not hasattr(back, "name") and not hasattr(back, "ptr")  # skipped members are absent
    assert back.bytes_ == [0] * 6  # a Python builtin name is mangled; the dict keeps the C name
    assert "bytes" in back.to_dict()


def test_python_module_catalogue(kinds_out: Path) -> None:
    mod = load_module(kinds_out / "kinds.py")
    ids = [iid for iid, _, _ in mod.INSTANCES]
    assert ids == sorted(ids)
    assert mod.BY_NAME["kinds"][1] is mod.all_kinds
    assert mod.BY_ID[b"lattice[ce[1][0]"] == ("lattice[1][0]", mod.vec3)
    assert mod.ID_SCHEME == "paper" and mod.ABI_VERSION == render.ABI_VERSION
    assert mod.empty_set().pack() == b""


def test_python_unpack_rejects_short_input(kinds_out: Path) -> None:
    mod = load_module(kinds_out / "kinds.py")
    with pytest.raises(ValueError, match="needs 12 bytes"):
        mod.vec3.unpack(b"\0" * 11)


def test_deterministic_output(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "a/x.h", (ALL_KINDS.read_text()))
    outs = []
    for k in range(2):
        code, _, _ = run_cli(["gen", "a/x.h", "--name", "det", "-o", f"out{k}"], tmp_path, capsys)
        assert code == 0
        outs.append({p.name: p.read_bytes() for p in (tmp_path / f"out{k}").iterdir()})
    assert outs[0] == outs[1] and len(outs[0]) == 4


def test_output_independent_of_checkout_location(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    texts = []
    for where in ("one", "two/deeper"):
        write(tmp_path / where, "x.h", ALL_KINDS.read_text())
        code, _, _ = run_cli(["gen", "x.h", "--name", "loc", "-o", "out"], tmp_path / where, capsys)
        assert code == 0
        texts.append({p.name: p.read_text() for p in (tmp_path / where / "out").iterdir()})
    assert texts[0] == texts[1]


def test_python_module_imports_in_a_fresh_interpreter(kinds_out: Path) -> None:
    code = "import kinds; print(len(kinds.TYPES), len(kinds.INSTANCES))"
    run = subprocess.run([sys.executable, "-c", code], cwd=kinds_out, capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["5", str(len(json.loads((kinds_out / "kinds.catalogue.json").read_text())["instances"]))]
