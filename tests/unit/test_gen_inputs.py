"""Issue #13 items 1-2: every input parsed and every failure reported before deciding; --keep-going,
--exclude, directory inputs; every construct catalogued or listed with a reason (GNU zero-length
arrays, unknown bounds, statics, one name defined in several files, types without instances)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from gen_testutil import catalogue_of, run_cli, write

from uavbus_gen import frontend, model

TYPES = """\
    #include <stdint.h>
    struct pos { double lat, lon; float alt; };
    """


def doc_of(out: Path, name: str = "catalogue") -> dict:
    return json.loads((out / f"{name}.catalogue.json").read_text())


def test_every_failing_input_is_reported_with_its_header_and_include_chain(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "inc/broken.h", "struct b { undefined_t x; };\n")
    write(tmp_path, "inc/mid.h", '#include "broken.h"\n')
    write(tmp_path, "a.h", '#include <stdint.h>\n#include "mid.h"\nextern struct b one;\n')
    write(tmp_path, "b.h", "struct ok { int v; };\nextern struct ok fine;\n")
    write(tmp_path, "c.h", "struct c { int v; };\nextern struct c bad = ;\n")
    code, out, err = run_cli(["gen", "a.h", "b.h", "c.h", "-I", "inc", "-o", "out"], tmp_path, capsys)
    assert code == 2 and not (tmp_path / "out").exists()
    # a.h's error is in broken.h, reached through mid.h: both steps are named, outermost first.
    assert ("a.h: error: cannot be parsed (1 error):\n"
            "  In file included from a.h:2:\n"
            "  In file included from inc/mid.h:1:\n"
            "  inc/broken.h:1: error: unknown type name 'undefined_t'\n") in err
    assert re.search(r"^c\.h: error: cannot be parsed \(1 error\):\n  c\.h:2: error: expected expression", err, re.M)
    assert "b.h" not in re.findall(r"^(\S+): error: cannot be parsed", err, re.M)
    assert "2 of 3 inputs cannot be parsed; nothing was written" in err and "--keep-going" in err


def test_keep_going_catalogues_the_others_and_exits_3(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "bad.h", "struct s { int x; };\nextern struct s lost;\nstruct s broken = {1,,};\n")
    write(tmp_path, "good.h", "struct t { int y; };\nextern struct t kept;\n")
    code, _, err = run_cli(["gen", "bad.h", "good.h", "-k", "-o", "out"], tmp_path, capsys)
    assert code == 3
    assert "warning: 1 of 2 inputs cannot be parsed and are not catalogued (--keep-going): bad.h" in err
    # Never a partial translation unit: `lost` parsed fine before the error, and is still absent.
    assert [i["name"] for i in doc_of(tmp_path / "out")["instances"]] == ["kept"]
    assert run_cli(["gen", "bad.h", "good.h", "-k", "--exit-zero", "-o", "out2"], tmp_path, capsys)[0] == 0
    assert run_cli(["gen", "good.h", "--exit-zero", "-o", "out3"], tmp_path, capsys)[0] == 2  # needs -k
    assert run_cli(["check", "bad.h", "-k"], tmp_path, capsys)[0] == 2  # nothing at all parsed


def test_exclude_by_path_or_file_name_and_directory_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "tree/a/one.h", "struct s1 { int x; };\nextern struct s1 one;\n")
    write(tmp_path, "tree/b/two.h", "struct s2 { int x; };\nextern struct s2 two;\n")
    write(tmp_path, "tree/b/three.c", '#include "two.h"\nstruct s2 three;\n')
    write(tmp_path, "tree/b/notes.txt", "not C\n")
    code, out, _ = run_cli(["check", "tree"], tmp_path, capsys)
    assert code == 0 and "3 instances" in out
    code, out, _ = run_cli(["check", "tree", "--exclude", "tree/b/*"], tmp_path, capsys)
    assert code == 0 and "1 instances" in out
    code, out, err = run_cli(["check", "tree", "--exclude", "three.c", "--exclude", "nomatch*.h"], tmp_path, capsys)
    assert code == 0 and "2 instances" in out and "warning: --exclude 'nomatch*.h' matches no input" in err
    assert run_cli(["check", "tree/a/one.h", "--exclude", "*.h"], tmp_path, capsys)[0] == 2  # nothing left


def test_gnu_zero_length_array_member_is_a_flexible_array_member(tmp_path: Path) -> None:
    h = write(tmp_path, "z.h", "#include <stdint.h>\n"
                               "struct list { uint16_t n; uint32_t items[0]; };\n"
                               "struct grid { uint8_t w; uint8_t cells[2][0]; };\n"
                               "extern struct list lst;\nextern struct grid grd;\nextern struct list none[0];\n")
    cat = catalogue_of(h)
    items = {f.name: f for f in cat.type("struct list").fields}["items"]
    cells = {f.name: f for f in cat.type("struct grid").fields}["cells"]
    assert items.skipped == cells.skipped == model.SKIP_FLEXIBLE
    assert cat.type("struct list").packed_size == 2
    assert {s.name: s.reason for s in cat.skipped_instances}["none"].startswith("zero-length array")


def test_unknown_bound_arrays_and_statics_are_listed(tmp_path: Path) -> None:
    h = write(tmp_path, "u.h", TYPES + "extern struct pos track[];\nextern struct pos known[];\n"
                                       "static struct pos hidden __attribute__((unused));\n")
    c = write(tmp_path, "u.c", '#include "u.h"\nstruct pos known[3];\n')
    cat = catalogue_of(h, c)
    reasons = {s.name: s.reason for s in cat.skipped_instances}
    assert reasons["track"].startswith("array of unknown bound")
    assert reasons["hidden"].startswith("static")
    assert "known" not in reasons  # the .c file gives its bound
    assert [i.name for i in cat.instances if i.base == "known"] == ["known[0]", "known[1]", "known[2]"]


def test_one_name_defined_in_several_files_is_qualified_by_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "inc/t.h", TYPES + "extern struct pos home;\nstruct pos shared_def;\n")
    write(tmp_path, "apps/a/tbl.c", '#include "t.h"\nstruct pos home = {1, 2, 3};\n')
    write(tmp_path, "apps/b/tbl.c", '#include "t.h"\nstruct pos home = {4, 5, 6};\n')
    write(tmp_path, "apps/b/other.c", '#include "t.h"\nstruct pos alone = {0};\n')
    code, _, err = run_cli(["gen", "apps/a/tbl.c", "apps/b/tbl.c", "apps/b/other.c", "-I", "inc", "-o", "out"],
                           tmp_path, capsys)
    assert code == 0
    names = sorted(i["name"] for i in doc_of(tmp_path / "out")["instances"])
    # `home`: defined in two files (same file name): qualified by the shortest path telling them
    # apart. `shared_def`: defined in t.h, which both include: one definition. `alone`: one file.
    assert names == ["alone", "home@a/tbl", "home@b/tbl", "shared_def"]
    assert "'home' is defined in 2 files; catalogued once per file as home@a/tbl, home@b/tbl" in err
    h = (tmp_path / "out" / "catalogue.h").read_text()
    assert "#define catalogue_INST_home__a_tbl " in h and "#define catalogue_INST_home__b_tbl " in h
    insts = {i["name"]: i for i in doc_of(tmp_path / "out")["instances"]}
    assert (insts["home@b/tbl"]["file"], insts["home@b/tbl"]["line"]) == ("apps/b/tbl.c", 2)


def test_qualifiers_are_the_shortest_distinguishing_trailing_path() -> None:
    assert model._qualifiers(["apps/sc/tables/sc_rts001.c", "apps/sc/tables/sc_rts002.c"]) == {
        "apps/sc/tables/sc_rts001.c": "sc_rts001", "apps/sc/tables/sc_rts002.c": "sc_rts002"}
    assert model._qualifiers(["x/a/t.c", "x/b/t.c", "y/a/t.c"]) == {"x/a/t.c": "x/a/t", "x/b/t.c": "b/t", "y/a/t.c": "y/a/t"}


def test_types_without_instances_warn_with_what_to_declare(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "only_types.h", TYPES + "typedef struct { int a; } att_t;\n")
    code, out, err = run_cli(["gen", "only_types.h", "-o", "out"], tmp_path, capsys)
    assert code == 0 and "0 instances" in out
    assert "warning: no instance to catalogue: the inputs define 2 struct type(s) (att_t, struct pos)" in err
    assert "e.g. `extern att_t att;`" in err


def test_skipped_members_one_line_per_reason_and_per_type_with_v(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "s.h", "struct a { char name[8]; int *p; int v; };\nstruct b { void *q; union { int i; } u; };\n"
                           "extern struct a one;\nextern struct b two;\n")
    _, _, err = run_cli(["check", "s.h"], tmp_path, capsys)
    assert "note: skipped members (not on the wire): 2 pointer, 1 string, 1 union (-v lists them per type)" in err
    assert "struct a: name" not in err
    _, _, err = run_cli(["check", "s.h", "-v"], tmp_path, capsys)
    assert "s.h:1: note: struct a: name (string), p (pointer)" in err
    assert "s.h:2: note: struct b: q (pointer), u (union)" in err


def test_frontend_failure_record_keeps_every_diagnostic(tmp_path: Path) -> None:
    bad = write(tmp_path, "bad.h", "struct s { a_t x; b_t y; };\n")
    results = frontend.parse_inputs([str(bad), str(tmp_path / "absent.h")], frontend.ParseOptions())
    assert [type(r).__name__ for r in results] == ["FeFailure", "FeFailure"]
    assert [d.message for d in results[0].diagnostics] == ["unknown type name 'a_t'", "unknown type name 'b_t'"]
    assert "no such file" in results[1].diagnostics[0].message
