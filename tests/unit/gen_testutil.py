"""Helpers for the generator tests (tests/unit/test_gen_*.py, tests/golden)."""

from __future__ import annotations

import os
import shutil
import subprocess
import textwrap
from pathlib import Path

import pytest

from uavbus_gen import cli, frontend, model

REPO = Path(__file__).resolve().parents[2]
GEN_CASES = REPO / "tests" / "gen_cases"
ALL_KINDS = GEN_CASES / "all_kinds.h"
RUNTIME_INCLUDE = REPO / "runtime_c" / "include"

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")


def write(dir_: Path, name: str, text: str) -> Path:
    path = dir_ / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text))
    return path


def catalogue_of(*files: Path, scheme: str = "paper", **opts) -> model.Catalogue:
    """Front end + model in-process, paths relative to the files' directory."""
    units = frontend.parse_files([str(f) for f in files], frontend.ParseOptions(**opts))
    return model.build_catalogue(units, scheme, model.make_relpath([str(f) for f in files], str(files[0].parent)))


def run_cli(argv: list[str], cwd: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """`uavbus <argv>` in-process with `cwd` as the current directory."""
    old = os.getcwd()
    os.chdir(cwd)
    try:
        code = cli.main(argv)
    finally:
        os.chdir(old)
    out, err = capsys.readouterr()
    return code, out, err


def gcc(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["gcc", *args], cwd=cwd, capture_output=True, text=True, timeout=120, check=False)
