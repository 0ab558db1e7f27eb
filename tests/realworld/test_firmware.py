"""Issue #30 acceptance: the generator on firmware as it is really built, on the corpora of
tests/corpus (README there): const members, a directory input holding a header named like a system
header, a Cortex-M4 tree parsed and built with arm-none-eabi-gcc and its self-test run under qemu-arm,
a -m32 self-test, a UAVObject-style types-only tree catalogued by pattern, and an empty catalogue.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CORPUS = REPO / "tests" / "corpus"
RUNTIME_INCLUDE = REPO / "runtime_c" / "include"
SELFTEST_LINE = re.compile(r"^selftest: (C|Python) (\d+) types ok, digest ([0-9a-f]{8})$", re.MULTILINE)
STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-Wcast-qual"]

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")


def uavbus(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "uavbus.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, check=False)


def describe(proc: subprocess.CompletedProcess[str]) -> str:
    return f"exit {proc.returncode}\n--- stdout\n{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}"


def run(cmd: list[str], cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, check=False)


def digests(proc: subprocess.CompletedProcess[str]) -> dict[str, tuple[str, str]]:
    """{'C': (types, digest), 'Python': (...)} from a selftest's output."""
    return {lang: (n, d) for lang, n, d in SELFTEST_LINE.findall(proc.stdout)}


def assert_selftest_passed(proc: subprocess.CompletedProcess[str], types: int) -> None:
    assert proc.returncode == 0, describe(proc)
    found = digests(proc)
    assert set(found) == {"C", "Python"} and found["C"] == found["Python"], proc.stdout
    assert int(found["C"][0]) == types, proc.stdout


# ---------------------------------------------------------------------------------------------
# Const members


CONST = CORPUS / "const"


@needs_gcc
def test_const_members_generated_c_compiles_strict(tmp_path: Path) -> None:
    proc = uavbus("gen", ".", "--name", "cst", "-o", str(tmp_path), cwd=CONST)
    assert proc.returncode == 0, describe(proc)
    dirs = [a for d in ("settings", "tasks", "leds") for a in ("-I", str(CONST / d))]
    comp = run(["gcc", *STRICT, "-I", str(RUNTIME_INCLUDE), *dirs, "-c", str(tmp_path / "cst.c"),
                "-o", str(tmp_path / "cst.o")], tmp_path)
    assert comp.returncode == 0, comp.stderr[-4000:]
    # No assignment through a const member anywhere: every const scalar goes through the byte writer.
    c = (tmp_path / "cst.c").read_text()
    assert "memcpy(cst_RO_ADDR(obj, obj->type), &v, sizeof v);" in c
    assert "obj->type =" not in c and "obj->range.min =" not in c


def test_const_bitfield_is_skipped_with_its_reason(tmp_path: Path) -> None:
    proc = uavbus("gen", ".", "--name", "cst", "-o", str(tmp_path), cwd=CONST)
    assert proc.returncode == 0, describe(proc)
    doc = json.loads((tmp_path / "cst.catalogue.json").read_text())
    fields = {f["name"]: f for t in doc["types"] if t["name"] == "task_attr_t" for f in t["fields"]}
    assert fields["core"]["skipped"].startswith("const bitfield")
    assert fields["spare"]["bits"] == 6 and fields["period_us"]["wire"] == "u32"
    assert "1 const bitfield" in proc.stderr


@needs_gcc
def test_const_members_selftest_round_trips() -> None:
    # The C self-test unpacks into a fresh object and compares every member, const ones included.
    proc = uavbus("selftest", ".", "--name", "cst", "-j", "2", cwd=CONST)
    assert_selftest_passed(proc, 5)
