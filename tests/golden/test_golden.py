"""Golden files: generated C, H, Python and JSON compared byte for byte.

Each case directory holds `args` (the `uavbus` arguments, run from that directory, without -o),
its inputs, and `expected/`. Regenerate after an intended change with
`UPDATE_GOLDEN=1 .venv/bin/python -m pytest tests/golden` and review the diff.
"""

from __future__ import annotations

import os
import shlex
import shutil
from pathlib import Path

import pytest

from uavbus_gen import cli

HERE = Path(__file__).resolve().parent
CASES = sorted(p.name for p in HERE.iterdir() if (p / "args").is_file())


@pytest.mark.parametrize("case", CASES)
def test_golden(case: str) -> None:
    case_dir = HERE / case
    # The output sits inside the case directory (removed after): NAME.h includes an input that no -I
    # finds by its path relative to the output directory, so that path must not depend on /tmp.
    out = case_dir / "out.tmp"
    shutil.rmtree(out, ignore_errors=True)
    argv = shlex.split((case_dir / "args").read_text()) + ["-o", "out.tmp"]
    old = os.getcwd()
    os.chdir(case_dir)
    try:
        assert cli.main(argv) == 0
        got = {p.name: p.read_bytes() for p in sorted(out.iterdir())}
    finally:
        os.chdir(old)
        shutil.rmtree(out, ignore_errors=True)
    expected_dir = case_dir / "expected"
    if os.environ.get("UPDATE_GOLDEN") == "1":
        shutil.rmtree(expected_dir, ignore_errors=True)
        expected_dir.mkdir()
        for name, data in got.items():
            (expected_dir / name).write_bytes(data)
    expected = {p.name: p.read_bytes() for p in sorted(expected_dir.iterdir())}
    assert sorted(got) == sorted(expected)
    for name in expected:
        assert got[name] == expected[name], f"{case}/expected/{name} differs (UPDATE_GOLDEN=1 to accept)"


def test_cases_exist() -> None:
    assert len(CASES) >= 2
