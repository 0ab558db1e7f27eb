"""cmake/uavbus.cmake used from a project outside this repository, as a flight-software team would.

Builds a small project whose catalogue is generated at build time by `uavbus_generate()`, runs its
program, and checks the dependency wiring: a second build does not regenerate; touching a header
regenerates; adding an instance to a header shows up in the rebuilt program.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
GEN_MARK = "uavbus: generating catalogue"

pytestmark = pytest.mark.skipif(
    shutil.which("cmake") is None or shutil.which("ninja") is None, reason="cmake and ninja are needed (make setup)"
)

PROJECT = """\
cmake_minimum_required(VERSION 3.20)
project(regen_probe C)
set(CMAKE_C_STANDARD 11)
add_compile_options(-Wall -Wextra -Werror)

# uavbus as a subproject: the runtime library uavbus::ub and uavbus_generate(), no tests (docs/cmake.md).
add_subdirectory("{repo}" uavbus)
uavbus_generate(TARGET probe_codecs NAME probe HEADERS include/rotor.h INCLUDE_DIRS include)
add_executable(probe main.c)
target_link_libraries(probe PRIVATE probe_codecs)
"""

HEADER = """\
#ifndef ROTOR_H
#define ROTOR_H
#include <stdint.h>
typedef struct rotorState {{
    float rpm;
    uint16_t faults;
}} rotorState_t;
extern rotorState_t mainRotorState;
{extra}
#endif
"""

MAIN = """\
#include <stdio.h>
#include "probe.h" /* generated: probe_catalogue */
#include "rotor.h"
rotorState_t mainRotorState;
rotorState_t tailRotorState;
int main(void) {
    printf("instances=%zu\\n", probe_catalogue.n_instances);
    return ub_catalogue_find_name(&probe_catalogue, "mainRotorState") >= 0 ? 0 : 1;
}
"""


def run(cmd: list[str], cwd: Path) -> str:
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout + proc.stderr


def write_header(project: Path, extra: str) -> None:
    (project / "include" / "rotor.h").write_text(HEADER.format(extra=extra))


def bump_mtime(path: Path) -> None:
    """Touches `path` past the last build's outputs even on a filesystem with 1-second timestamps."""
    time.sleep(1.1)
    path.touch()


def test_uavbus_generate_reruns_when_a_header_changes(tmp_path: Path) -> None:
    project = tmp_path / "proj"
    (project / "include").mkdir(parents=True)
    (project / "CMakeLists.txt").write_text(PROJECT.format(repo=REPO.as_posix()))
    (project / "main.c").write_text(MAIN)
    write_header(project, "")
    build = tmp_path / "build"
    run(["cmake", "-S", str(project), "-B", str(build), "-G", "Ninja", f"-DUAVBUS_PYTHON={sys.executable}"], tmp_path)

    first = run(["cmake", "--build", str(build)], tmp_path)
    assert GEN_MARK in first
    assert "instances=1" in run([str(build / "probe")], tmp_path)

    idle = run(["cmake", "--build", str(build)], tmp_path)
    assert GEN_MARK not in idle, f"regenerated without a change:\n{idle}"

    bump_mtime(project / "include" / "rotor.h")
    touched = run(["cmake", "--build", str(build)], tmp_path)
    assert GEN_MARK in touched, f"touching the header did not regenerate:\n{touched}"

    write_header(project, "extern rotorState_t tailRotorState;")
    bump_mtime(project / "include" / "rotor.h")
    edited = run(["cmake", "--build", str(build)], tmp_path)
    assert GEN_MARK in edited
    assert "instances=2" in run([str(build / "probe")], tmp_path)
