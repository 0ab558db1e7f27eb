"""Issue #13 item 3: the generated C compiles wherever the inputs compile. NAME.h includes the headers
that define the catalogued types (for a `.c` input, its own #include lines up to the one bringing
the type in), never a `.c` file; a type defined only in a `.c` file is named with the fix; the
embedded catalogue is an initializer list, not a string literal over C99's 4095 characters."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from gen_testutil import ALL_KINDS, RUNTIME_INCLUDE, gcc, needs_gcc, run_cli, write

from uavbus_gen import render


def includes_of(out: Path, name: str = "catalogue") -> list[str]:
    """The inputs' headers NAME.h includes (after its own: stddef, stdint, ub_catalogue, ub_error)."""
    return re.findall(r"^#include ([<\"].*[>\"])$", (out / f"{name}.h").read_text(), re.M)[4:]


def compiles(tmp_path: Path, out: Path, flags: list[str], name: str = "catalogue") -> None:
    proc = gcc([*flags, "-Wall", "-Wextra", "-Werror", "-I", str(RUNTIME_INCLUDE), "-I", str(out), "-c",
                str(out / f"{name}.c"), "-o", str(tmp_path / "x.o")], tmp_path)
    assert proc.returncode == 0, proc.stderr


@needs_gcc
def test_c_inputs_get_their_own_include_lines_in_order(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "inc/base.h", "#include <stdint.h>\ntypedef uint16_t word;\n")
    # Not self-contained: needs base.h first (as app.c includes it).
    write(tmp_path, "inc/msg.h", "struct msg { word id; word len; };\n")
    write(tmp_path, "inc/late.h", "struct late { int x; };\n")
    write(tmp_path, "src/local.h", "struct local_t { word v; };\n")  # next to the .c, not on -I
    write(tmp_path, "src/app.c", '#include <string.h>\n#include "base.h"\n#include "msg.h"\n#include "local.h"\n'
                                 '#include "late.h"\nstruct msg last_msg;\nstruct local_t loc;\n')
    code, _, err = run_cli(["gen", "src/app.c", "-I", "inc", "-o", "out"], tmp_path, capsys)
    assert code == 0, err
    # Up to local.h (the last one a catalogued type needs), in app.c's order; late.h is not needed.
    # local.h is found next to app.c, not through -I: by its path relative to the generated header.
    assert includes_of(tmp_path / "out") == ["<string.h>", '"base.h"', '"msg.h"', '"../src/local.h"']
    compiles(tmp_path, tmp_path / "out", ["-std=c11", "-Iinc", "-Isrc"])
    compiles(tmp_path, tmp_path / "out", ["-std=c99", "-pedantic", "-Iinc", "-Isrc"])


@needs_gcc
def test_types_from_system_headers_through_a_c_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "clock.c", "#define _POSIX_C_SOURCE 200809L\n#include <time.h>\nstruct timespec boot_time;\n")
    code, _, err = run_cli(["gen", "clock.c", "-o", "out"], tmp_path, capsys)
    assert code == 0, err
    assert includes_of(tmp_path / "out") == ["<time.h>"]
    compiles(tmp_path, tmp_path / "out", ["-std=c11", "-D_POSIX_C_SOURCE=200809L"])


def test_a_type_defined_in_a_c_file_is_named_with_the_fix(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "t.h", "struct pub { int a; };\nextern struct pub shown;\n")
    write(tmp_path, "m.c", '#include "t.h"\nstruct priv { int b; };\nstruct priv hidden;\nstruct pub shown;\n')
    code, _, err = run_cli(["gen", "m.c", "-o", "out"], tmp_path, capsys)
    assert code == 0
    assert ("m.c:2: warning: 'struct priv' is defined in m.c, a .c file the generated C cannot include: "
            "1 instance(s) not catalogued (hidden); move the definition into a header that file includes") in err
    h = (tmp_path / "out" / "catalogue.h").read_text()
    assert "catalogue_INST_shown" in h and "hidden" not in h and '#include "m.c"' not in h


def test_header_inputs_are_included_by_their_search_path_spelling(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "inc/nav/nav.h", "struct nav { int x; };\nextern struct nav navState;\n")
    assert run_cli(["gen", "inc/nav/nav.h", "-I", "inc", "-o", "out"], tmp_path, capsys)[0] == 0
    assert includes_of(tmp_path / "out") == ['"nav/nav.h"']
    assert run_cli(["gen", "inc/nav/nav.h", "-o", "out2"], tmp_path, capsys)[0] == 0
    # No -I finds it: by its path relative to the generated header, so compiling needs no extra -I.
    assert includes_of(tmp_path / "out2") == ['"../inc/nav/nav.h"']


def test_embedded_catalogue_rows_stay_within_c99_limits() -> None:
    assert render.c_json_rows("abcdefg", row=4) == [(4, ['"abcd"']), (4, ['"efg"'])]
    assert render.c_json_rows("abcd", row=4) == [(4, ['"abcd"']), (1, ['""'])]  # the NUL needs a row
    text = '{"k":"' + "x" * 9000 + '"}'
    rows = render.c_json_rows(text)
    assert sum(size for size, _ in rows) == len(text) + 1 and all(size <= 4095 for size, _ in rows)
    assert all(len(piece) <= 4095 for _, pieces in rows for piece in pieces)  # source lines too
    assert "".join(eval(p) for _, pieces in rows for p in pieces) == text  # noqa: S307 (our own literals)


@needs_gcc
def test_large_catalogue_is_clean_under_c99_pedantic(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    decls = "".join(f"struct t{k} {{ int a{k}; float b{k}[3]; }};\nextern struct t{k} inst{k:04d}Value;\n" for k in range(60))
    write(tmp_path, "many.h", decls)
    assert run_cli(["gen", "many.h", "--name", "manycat", "-o", "out"], tmp_path, capsys)[0] == 0
    json_len = len((tmp_path / "out" / "manycat.catalogue.json").read_text())
    assert json_len > 8000  # pretty form; the compact embedded copy is still far above 4095
    compiles(tmp_path, tmp_path / "out", ["-std=c99", "-pedantic", f"-I{tmp_path}"], "manycat")


@needs_gcc
def test_all_kinds_c99_and_cxx(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Generated with -I of its folder, so kinds.h includes it by name and the folder can be a system
    # directory when compiling: all_kinds.h itself is C11 (anonymous members), -pedantic judges ours.
    assert run_cli(["gen", str(ALL_KINDS), "-I", str(ALL_KINDS.parent), "--name", "kinds", "-o", "out"],
                   tmp_path, capsys)[0] == 0
    out = tmp_path / "out"
    compiles(tmp_path, out, ["-std=c99", "-pedantic", "-isystem", str(ALL_KINDS.parent)], "kinds")
    (tmp_path / "use.cpp").write_text('#include "kinds.h"\nint main() { struct vec3 v = {1, 2, 3}; uint8_t b[12];\n'
                                      '  return kinds_pack_vec3(&v, b, sizeof b) == 12 ? 0 : 1; }\n')
    import subprocess

    proc = subprocess.run(["g++", "-std=c++11", "-pedantic", "-Wall", "-Wextra", "-Werror", "-isystem", str(ALL_KINDS.parent),
                           "-I", str(RUNTIME_INCLUDE), "-I", str(out), "-c", "use.cpp", "-o", "use.o"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
