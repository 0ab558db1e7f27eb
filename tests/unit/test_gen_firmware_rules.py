"""Issue #30 item 5: an empty catalogue is -pedantic clean, --exclude matches relative to the current
folder and to each directory input, the payload-limit refusal names the fragment limit and the flag,
and an instance whose declaring header was left out is reported and never emitted as a reference
the generated C cannot resolve."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from gen_testutil import RUNTIME_INCLUDE, gcc, needs_gcc, run_cli, write

from uavbus_gen import cli

PEDANTIC = ["-pedantic", "-Wall", "-Wextra", "-Werror"]


@needs_gcc
@pytest.mark.parametrize("std", ["c99", "c11"])
def test_empty_catalogue_compiles_pedantic(tmp_path: Path, capsys: pytest.CaptureFixture[str], std: str) -> None:
    write(tmp_path, "e.h", "#include <stdint.h>\ntypedef uint32_t word;\nextern word counter;\n")
    code, out, err = run_cli(["gen", "e.h", "--name", "empty", "-o", "out"], tmp_path, capsys)
    assert code == 0, err
    assert "gen: 0 instances of 0 types (no struct type in the inputs)" in out
    proc = gcc([f"-std={std}", *PEDANTIC, "-I", str(RUNTIME_INCLUDE), "-I", "out", "-c", "out/empty.c", "-o", "e.o"],
               tmp_path)
    assert proc.returncode == 0, proc.stderr


def test_exclude_matches_relative_to_the_current_folder_and_each_input_root(tmp_path: Path,
                                                                            capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "fw/lib/vendor/broken.h", "this does not parse;\n")
    write(tmp_path, "fw/app/app.h", "struct app { int a; };\nextern struct app app_state;\n")
    base = ["check", str(tmp_path / "fw")]  # an absolute directory input
    # Relative to the input root, to the current folder, a whole folder, and './' spelled.
    for pat in ("lib/*", "fw/lib/vendor/*", "lib/", "./fw/lib/vendor/broken.h"):
        code, out, err = run_cli([*base, "--exclude", pat], tmp_path, capsys)
        assert code == 0 and "check: 1 instances of 1 types" in out, (pat, err)
        assert "matches no input" not in err
    code, _, err = run_cli([*base, "--exclude", "other/*"], tmp_path, capsys)
    assert code == 2 and "--exclude 'other/*' matches no input" in err


def test_exclude_hit_rules() -> None:
    assert cli.exclude_hit("lib/*", "/abs/fw/lib/x.h", "/abs/fw", cwd="/elsewhere")
    assert cli.exclude_hit("x.h", "/abs/fw/lib/x.h", "/abs/fw")
    assert not cli.exclude_hit("lib/*", "/abs/fw/app/x.h", "/abs/fw", cwd="/elsewhere")
    assert not cli.exclude_hit("fw/lib/*", "/abs/fw/app/lib/x.h", "/abs/fw", cwd="/abs")  # anchored, not a suffix


def test_payload_limit_refusal_names_the_fragment_limit_and_the_flag(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "big.h", "#include <stdint.h>\nstruct log_page { uint8_t data[20000]; };\nextern struct log_page page;\n"
                             "struct huge { uint8_t data[70000]; };\nextern struct huge huge_page;\n")
    code, _, err = run_cli(["check", "big.h"], tmp_path, capsys)
    assert code == 1
    assert "payload limit of 16384 bytes (--max-payload; the runtime's fragment limit UB_MAX_DIRECTORY)" in err
    assert "travels in fragments, up to the fragment limit UB_MAX_DIRECTORY (16384 here, --max-payload; at most 65535)" in err
    assert "no runtime carries more than 65535 bytes" in err  # the 70,000-byte type cannot be raised for
    write(tmp_path, "big2.h", "#include <stdint.h>\nstruct log_page { uint8_t data[20000]; };\nextern struct log_page page;\n")
    code, _, err = run_cli(["check", "big2.h"], tmp_path, capsys)
    assert code == 1 and "build the runtime with -DUB_MAX_DIRECTORY=20000 and pass --max-payload 20000" in err
    assert run_cli(["check", "big2.h", "--max-payload", "20000"], tmp_path, capsys)[0] == 0


def _left_out_tree(tmp_path: Path, defined: bool) -> None:
    write(tmp_path, "fw/inc/types.h", "#ifndef TYPES_H\n#define TYPES_H\ntypedef struct { int a; int b; } usr_t;\n#endif\n")
    # Not self-contained (needs types.h first): fails as an input of its own, as in real trees.
    write(tmp_path, "fw/inc/usr.h", "extern usr_t USR_desc;\nextern usr_t USR_other;\n")
    body = '#include "../inc/types.h"\n#include "../inc/usr.h"\n'
    write(tmp_path, "fw/src/usr.c", body + ("usr_t USR_desc = {1, 2};\n" if defined else "int usr_count;\n"))


@needs_gcc
@pytest.mark.parametrize("defined", [True, False], ids=["defined-in-c", "declared-only"])
def test_instance_declared_in_a_left_out_header(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                defined: bool) -> None:
    _left_out_tree(tmp_path, defined)
    code, _, err = run_cli(["gen", "fw", "-k", "--name", "usr", "-o", "out"], tmp_path, capsys)
    assert code == 3, err
    assert "fw/inc/usr.h: error: cannot be parsed" in err
    doc = json.loads((tmp_path / "out" / "usr.catalogue.json").read_text())
    names = {i["name"] for i in doc["instances"]}
    skipped = {s["name"]: s["reason"] for s in doc["skipped_instances"]}
    assert skipped["USR_other"].startswith("declared in fw/inc/usr.h, an input left out")
    if defined:
        assert names == {"USR_desc"}
        assert "'USR_desc' is declared in fw/inc/usr.h, an input left out; catalogued from fw/src/usr.c:3" in err
    else:
        assert names == set() and skipped["USR_desc"].startswith("declared in fw/inc/usr.h, an input left out")
    # The generated C never refers to what it cannot declare.
    proc = gcc(["-std=c11", *PEDANTIC, "-I", str(RUNTIME_INCLUDE), "-I", "out", "-c", "out/usr.c", "-o", "u.o"], tmp_path)
    assert proc.returncode == 0, proc.stderr


@needs_gcc
def test_left_out_header_the_generated_header_includes_anyway_keeps_its_instances(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "fw/inc/types.h", "#ifndef TYPES_H\n#define TYPES_H\ntypedef struct { int a; } usr_t;\n#endif\n")
    # Fails alone (needs types.h first), but defines a catalogued type: NAME.h includes it in usr.c's
    # context (types.h first), so what it declares is declared in the generated C too.
    write(tmp_path, "fw/inc/usr.h", "typedef struct { usr_t u; int c; } usr_stat_t;\n"
                                    "extern usr_stat_t USR_stat;\nextern usr_t USR_desc;\n")
    write(tmp_path, "fw/src/usr.c", '#include "../inc/types.h"\n#include "../inc/usr.h"\nint usr_count;\n')
    code, _, err = run_cli(["gen", "fw", "-k", "--name", "usr", "-o", "out"], tmp_path, capsys)
    assert code == 3, err
    doc = json.loads((tmp_path / "out" / "usr.catalogue.json").read_text())
    assert {i["name"] for i in doc["instances"]} == {"USR_desc", "USR_stat"}
    assert "left out" not in err.split("warning: 1 of 3 inputs cannot be parsed")[-1]
    proc = gcc(["-std=c11", *PEDANTIC, "-I", str(RUNTIME_INCLUDE), "-I", "out", "-c", "out/usr.c", "-o", "u.o"], tmp_path)
    assert proc.returncode == 0, proc.stderr


def test_host_build_flags_of_gcc_alone_fail_no_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Without --target-cc: a make build's -Werror (clang's `#pragma once in main file` for a header parsed
    # alone), -MMD -MP -MF (clang would write .d files into the tree) and a GCC-only warning flag.
    write(tmp_path, "fw/imu.h", "#pragma once\n#include <stdint.h>\nstruct imu { int16_t acc[3]; };\n"
                                "extern struct imu imu_raw;\n")
    before = sorted(tmp_path.rglob("*"))
    code, out, err = run_cli(["check", "fw", "--", "-Werror", "-Wall", "-Wunsafe-loop-optimizations", "-MMD", "-MP",
                              "-MF", "deps.d"], tmp_path, capsys)
    assert code == 0 and "check: 1 instances of 1 types" in out, err
    assert ("note: clang does not know -Wunsafe-loop-optimizations (flags of the build): left out of parsing"
            in err)
    assert sorted(tmp_path.rglob("*")) == before
