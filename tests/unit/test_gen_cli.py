"""`uavbus gen|check` end to end: union of inputs, duplicate definitions, collisions, the hashed
scheme, clang errors, flags (-I, -D, --std, --compile-commands, `--`), and usage errors."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from gen_testutil import run_cli, write

from uavbus_gen import cli

TYPES_H = """\
    #include <stdint.h>
    struct gps_out { double lat, lon; float alt; uint8_t fix; };
    """


def test_check_ok_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "types.h", TYPES_H)
    write(tmp_path, "a.h", '#include "types.h"\nextern struct gps_out gps;\n')
    code, out, _ = run_cli(["check", "a.h"], tmp_path, capsys)
    assert code == 0 and "1 instances" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h", "types.h"]


def test_same_instance_in_several_headers_counts_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "types.h", TYPES_H)
    write(tmp_path, "a.h", '#include "types.h"\nextern struct gps_out gps;\n')
    write(tmp_path, "b.h", '#include "types.h"\nextern struct gps_out gps;\nextern struct gps_out gps2;\n')
    code, _, _ = run_cli(["gen", "a.h", "b.h", "--name", "cat", "-o", "out"], tmp_path, capsys)
    assert code == 0
    doc = json.loads((tmp_path / "out" / "cat.catalogue.json").read_text())
    assert [i["name"] for i in doc["instances"]] == ["gps", "gps2"]
    assert doc["instances"][0]["file"] == "a.h" and doc["instances"][0]["line"] == 2


def test_type_defined_differently_names_both_places(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "a.h", "struct s { int x; };\nextern struct s one;\n")
    write(tmp_path, "b.h", "\n\nstruct s { int x; float y; };\nextern struct s two;\n")
    code, _, err = run_cli(["check", "a.h", "b.h"], tmp_path, capsys)
    assert code == 1
    assert "a.h:1" in err and "b.h:3" in err and "'struct s'" in err


def test_instance_declared_with_two_types_names_both_places(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "a.h", "struct s { int x; };\nextern struct s thing;\n")
    write(tmp_path, "b.h", "struct t { int x; };\n\nextern struct t thing;\n")
    code, _, err = run_cli(["gen", "a.h", "b.h", "-o", "out"], tmp_path, capsys)
    assert code == 1
    assert "a.h:2" in err and "b.h:3" in err and "'thing'" in err
    assert not (tmp_path / "out").exists()


COLLIDING = """\
    struct cfg { int v; };
    extern struct cfg currentSensorADCConfig_System;
    extern struct cfg currentSensorVirtualConfig_System;
    extern struct cfg vehicleHealth_SystemArray[2];
    extern struct cfg vehicleHealth_CopyArray[2];
    extern struct cfg fine;
    """


def test_collisions_exit_1_naming_every_member(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "c.h", COLLIDING)
    code, _, err = run_cli(["check", "c.h"], tmp_path, capsys)
    assert code == 1
    for line, name in [(2, "currentSensorADCConfig_System"), (3, "currentSensorVirtualConfig_System"),
                       (4, "vehicleHealth_SystemArray[0]"), (5, "vehicleHealth_CopyArray[0]"),
                       (4, "vehicleHealth_SystemArray[1]"), (5, "vehicleHealth_CopyArray[1]")]:
        assert f"c.h:{line}: {name}" in err
    assert "3 group(s)" in err and "--id-scheme hashed" in err and "fine" not in err


def test_gen_refuses_colliding_catalogue(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "c.h", COLLIDING)
    code, _, _ = run_cli(["gen", "c.h", "-o", "out"], tmp_path, capsys)
    assert code == 1 and not (tmp_path / "out").exists()


def test_hashed_scheme_resolves_collisions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "c.h", COLLIDING)
    code, _, _ = run_cli(["check", "c.h", "--id-scheme", "hashed"], tmp_path, capsys)
    assert code == 0
    code, _, _ = run_cli(["gen", "c.h", "--id-scheme", "hashed", "-o", "out"], tmp_path, capsys)
    assert code == 0
    doc = json.loads((tmp_path / "out" / "catalogue.catalogue.json").read_text())
    assert doc["id_scheme"] == "hashed" and len(doc["instances"]) == 7
    assert "UB_ID_SCHEME_HASHED" in (tmp_path / "out" / "catalogue.c").read_text()


def test_syntax_error_exits_2_with_clang_location(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "bad.h", "struct s { int x; };\nstruct s broken = {1,,};\n")
    code, _, err = run_cli(["check", "bad.h"], tmp_path, capsys)
    assert code == 2
    assert re.search(r"bad\.h:2: error: expected expression", err), err


def test_missing_include_exits_2_with_clang_location(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "inc.h", "#include <stdint.h>\n#include \"nowhere.h\"\nstruct s { int x; };\n")
    code, _, err = run_cli(["gen", "inc.h", "-o", "out"], tmp_path, capsys)
    assert code == 2
    assert "inc.h:2: fatal error: 'nowhere.h' file not found" in err
    assert not (tmp_path / "out").exists()


def test_missing_input_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(["check", "absent.h"], tmp_path, capsys)
    assert code == 2 and "absent.h" in err


@pytest.mark.parametrize(
    "argv",
    [["gen", "a.h"], ["check"], ["gen", "a.h", "-o", "x", "--id-scheme", "md5"], ["check", "a.h", "--name", "9x"],
     ["frobnicate", "a.h"]],
)
def test_usage_errors_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    write(tmp_path, "a.h", "struct s { int x; };\nextern struct s one;\n")
    with pytest.raises(SystemExit) as exc:
        raise SystemExit(run_cli(argv, tmp_path, capsys)[0])
    assert exc.value.code == 2


def test_include_dirs_defines_and_std(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "inc/types.h", "struct s { int x; };\n")
    write(tmp_path, "a.h", '#include "types.h"\n#if WANT == 2 && __STDC_VERSION__ >= 201710L\nextern struct s one;\n#endif\n')
    code, out, _ = run_cli(["check", "a.h", "-I", "inc", "-D", "WANT=2", "--std", "c17"], tmp_path, capsys)
    assert code == 0 and "1 instances" in out
    code, out, _ = run_cli(["check", "a.h", "-I", "inc", "-D", "WANT=2"], tmp_path, capsys)
    assert code == 0 and "0 instances" in out  # c11 default
    code, _, _ = run_cli(["check", "a.h", "-D", "WANT=2"], tmp_path, capsys)
    assert code == 2  # types.h not found without -I


def test_clang_args_after_double_dash(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "prelude.h", "struct s { int x; };\n")
    write(tmp_path, "a.h", "extern struct s one;\n")
    code, out, err = run_cli(["check", "a.h", "-v"], tmp_path, capsys)
    assert code == 0 and "0 instances" in out
    assert "a.h:1: note: instance 'one' not catalogued: incomplete struct type" in err
    code, out, _ = run_cli(["check", "a.h", "--", "-include", "prelude.h"], tmp_path, capsys)
    assert code == 0 and "1 instances" in out


def test_compile_commands(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "src/inc/types.h", "struct s { int x; };\n")
    write(tmp_path, "src/unit.c", '#include "types.h"\n#ifndef FROM_DB\n#error no flags\n#endif\nstruct s from_c;\n')
    db = [{"directory": str(tmp_path / "src"), "file": "unit.c",
           "arguments": ["cc", "-Iinc", "-DFROM_DB=1", "-c", "unit.c", "-o", "unit.o"]}]
    (tmp_path / "compile_commands.json").write_text(json.dumps(db))
    assert run_cli(["check", "src/unit.c"], tmp_path, capsys)[0] == 2
    code, out, _ = run_cli(["check", "src/unit.c", "--compile-commands", "compile_commands.json"], tmp_path, capsys)
    assert code == 0 and "1 instances" in out


def test_main_is_reached_through_uavbus_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from uavbus import cli as top

    write(tmp_path, "a.h", "struct s { int x; };\nextern struct s one;\n")
    import os

    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert top.main(["check", "a.h"]) == 0
    finally:
        os.chdir(old)
    assert cli.main is not None


def test_verbose_prints_generation_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "a.h", "struct s { int x; };\nextern struct s one;\n")
    code, _, err = run_cli(["gen", "a.h", "-o", "out", "-v"], tmp_path, capsys)
    assert code == 0 and re.search(r"generation time: \d+\.\d+ s", err)


def test_name_that_shadows_an_input_header_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "nav.h", "struct s { int x; };\nextern struct s one;\n")
    # Found through -I, the input is included as "nav.h": out/nav.h would include itself.
    code, _, err = run_cli(["gen", "nav.h", "-I", ".", "--name", "nav", "-o", "out"], tmp_path, capsys)
    assert code == 2 and "include itself" in err
    # Without -I it is included by its path relative to the output ("../nav.h"): no clash.
    code, _, err = run_cli(["gen", "nav.h", "--name", "nav", "-o", "out"], tmp_path, capsys)
    assert code == 0, err
    assert '#include "../nav.h"' in (tmp_path / "out" / "nav.h").read_text()
