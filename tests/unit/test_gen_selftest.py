"""`uavbus selftest`: C and Python round trips with the model's values, digests equal."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from gen_testutil import ALL_KINDS, catalogue_of, needs_gcc, run_cli, write

from uavbus_gen import model

LINE = re.compile(r"^selftest: (C|Python) (\d+) types ok, digest ([0-9a-f]{8})$", re.M)


@needs_gcc
@pytest.mark.parametrize("extra", [[], ["--sanitize"]], ids=["plain", "asan-ubsan"])
def test_selftest_all_kinds(tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str]) -> None:
    code, out, err = run_cli(["selftest", str(ALL_KINDS), "--name", "kinds", *extra], tmp_path, capsys)
    assert code == 0, out + err
    found = LINE.findall(out)
    assert [lang for lang, _, _ in found] == ["C", "Python"]
    assert found[0][1:] == found[1][1:] and found[0][1] == "5"
    assert found[0][2] == f"{model.expected_digest(catalogue_of(ALL_KINDS)):08x}"
    assert list(tmp_path.iterdir()) == []  # writes nothing where it runs


@needs_gcc
def test_selftest_hashed_scheme(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "c.h", "struct cfg { int v; };\nextern struct cfg currentSensorADCConfig_System;\n"
                           "extern struct cfg currentSensorVirtualConfig_System;\n")
    assert run_cli(["selftest", "c.h"], tmp_path, capsys)[0] == 1
    code, out, _ = run_cli(["selftest", "c.h", "--id-scheme", "hashed"], tmp_path, capsys)
    assert code == 0 and len(LINE.findall(out)) == 2


@needs_gcc
def test_selftest_fails_when_the_c_build_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "a.h", "#ifndef __clang__\n#error only clang may read this\n#endif\n"
                           "struct s { int x; };\nextern struct s one;\n")
    code, out, err = run_cli(["selftest", "a.h"], tmp_path, capsys)
    assert code == 1
    assert "selftest: C failed" in out and "C build failed" in err and "only clang may read this" in err
    assert "selftest: Python 1 types ok" in out


def test_test_values_fit_their_fields() -> None:
    cat = catalogue_of(ALL_KINDS)
    for t in cat.named_types:
        for leaf in model.test_leaves(cat, t):
            f = leaf.field
            if f.wire and not f.wire.is_float and f.wire.name != "bool":
                width = f.bits or f.wire.bits
                lo, hi = (-(1 << (width - 1)), (1 << (width - 1)) - 1) if f.wire.signed else (0, (1 << width) - 1)
                assert lo <= leaf.value <= hi, (t.name, leaf.path, leaf.value)
    values = [leaf.value for leaf in model.test_leaves(cat, cat.type("struct all_kinds"))]
    assert len(set(map(repr, values))) > len(values) // 2  # values vary, so swapped fields would show


@needs_gcc
def test_selftest_pointer_members_and_awkward_names(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # A `uint8_t *` member used to trip -Werror=sizeof-pointer-memaccess in the generated test; a
    # leading `__` made Python mangle the class name; keywords must not reach Python as names.
    write(tmp_path, "p.h", "#include <stdint.h>\n#include <stdbool.h>\n"
                           "struct __buf { uint8_t *data; const char *name; uint16_t n; void *ctx; };\n"
                           "typedef struct { struct __buf b[2]; uint8_t None; bool True; int __init__; } lambda;\n"
                           "struct with { lambda def; struct __buf last; };\n"
                           "extern struct __buf __rx;\nextern lambda L;\nextern struct with W;\n")
    code, out, err = run_cli(["selftest", "p.h", "--name", "awk", "--sanitize"], tmp_path, capsys)
    assert code == 0, out + err
    assert len(LINE.findall(out)) == 2 and "warning" not in err


@needs_gcc
def test_selftest_timeout_is_one_line_with_what_to_do(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_cli(["selftest", str(ALL_KINDS), "--name", "kinds", "--timeout", "0.01"], tmp_path, capsys)
    assert code == 1 and "Traceback" not in out + err
    lines = [line for line in err.splitlines() if line.startswith("selftest: error:")]
    assert lines and "--timeout" in lines[0], err
    assert "selftest: C failed" in out


@needs_gcc
def test_selftest_is_split_into_translation_units(tmp_path: Path) -> None:
    from uavbus_gen import render

    decls = "".join(f"struct t{k} {{ float v[100]; int w[100]; }};\nextern struct t{k} inst{k:04d}x;\n" for k in range(100))
    h = write(tmp_path, "many.h", decls)
    cat = catalogue_of(h)
    files = render.Renderer(cat, render.RenderInputs("m")).render_selftest()
    chunks = sorted(f for f in files if re.fullmatch(r"m_selftest_\d+\.c", f))
    assert len(chunks) > 1 and {"m_selftest.c", "m_selftest.h", "m_selftest.py"} <= set(files)
    # Every type is checked once, in catalogue order across the chunks.
    checked = [m for f in chunks for m in re.findall(r"failed \+= check_(\w+)\(crc\)", files[f])]
    assert checked == [t.ident for t in cat.named_types]
    # Arrays are filled from value tables in loops, not one statement per element.
    assert "static const float v[100]" in files[chunks[0]]
