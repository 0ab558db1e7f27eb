"""What the bench tests share: a bench program (bench/src/<name>.c) built here, as bench/run.sh builds it, from
the bench catalogue (generated into <out>/gen) and the runtime sources, with libsodium."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def build_bench_program(out: Path, program: str, *extra: str) -> Path:
    """Generates the bench catalogue into out/gen, then compiles bench/src/`program`.c with `extra` (more
    flags or sources) into out/`program`; returns its path."""
    subprocess.run([sys.executable, "-m", "uavbus.cli", "gen", str(ROOT / "bench/catalogue/bench_msgs.h"), "--name",
                    "benchcat", "-o", str(out / "gen")], check=True, cwd=ROOT, capture_output=True)
    sodium = subprocess.run(["pkg-config", "--libs", "libsodium"], capture_output=True, text=True,
                            check=True).stdout.split()
    exe = out / program
    subprocess.run(["gcc", "-O1", "-std=gnu11", "-Wall", "-Wextra", "-Werror", "-D_POSIX_C_SOURCE=200809L",
                    "-DUB_SECURITY=1", "-Iruntime_c/include", "-Iruntime_c/src", *extra, f"bench/src/{program}.c",
                    *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "runtime_c/src").glob("*/*.c")),
                    *sodium, "-lm", "-o", str(exe)], check=True, cwd=ROOT)
    return exe


@pytest.fixture(scope="session")
def build_bench() -> Callable[..., Path]:
    """build_bench(out, program, *extra): see build_bench_program."""
    return build_bench_program
