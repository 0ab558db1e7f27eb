"""Finding (and if needed building) the C node program `uavbus_node` (programs/node; its protocol:
docs/program-protocol.md, uavbus.sim.protocol).

Order: $UAVBUS_NODE (a path to the program); else the build directory $UAVBUS_BUILD_DIR (default
<repo>/build, the one `make test` builds), configured with CMake + Ninja if needed and brought up to
date with ``cmake --build DIR --target uavbus_node`` -- the catalogue is generated there by the CMake
function uavbus_generate(), the path real flight software takes.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

__all__ = ["REPO", "node_program", "NodeProgramMissing"]

REPO = Path(__file__).resolve().parents[3]
NODE_TARGET = "uavbus_node"
PROGRAM_DIR = Path("programs") / "node"  # in the source tree and in the build directory (programs/node/CMakeLists.txt)


class NodeProgramMissing(RuntimeError):
    """The program cannot be built here (no cmake/ninja, or the sources of programs/node are missing)."""


def node_program(build_dir: str | Path | None = None, *, build: bool = True, quiet: bool = True) -> Path:
    env_prog = os.environ.get("UAVBUS_NODE")
    if env_prog:
        p = Path(env_prog)
        if not os.access(p, os.X_OK):
            raise NodeProgramMissing(f"UAVBUS_NODE={env_prog}: not an executable file; unset it or fix the path")
        return p
    bdir = Path(build_dir or os.environ.get("UAVBUS_BUILD_DIR") or REPO / "build")
    prog = bdir / PROGRAM_DIR / NODE_TARGET
    if not build:
        if prog.exists():
            return prog
        raise NodeProgramMissing(f"{prog}: not built; run `make test` or `cmake --build {bdir} --target uavbus_node`")
    if not (REPO / PROGRAM_DIR).is_dir():
        raise NodeProgramMissing(f"{REPO / PROGRAM_DIR}: the node program's sources are missing")
    if shutil.which("cmake") is None or shutil.which("ninja") is None:
        raise NodeProgramMissing("cmake and ninja are needed to build uavbus_node: run `make setup`")
    out = subprocess.DEVNULL if quiet else None
    if not (bdir / "CMakeCache.txt").exists():
        subprocess.run(["cmake", "-S", str(REPO), "-B", str(bdir), "-G", "Ninja",
                        f"-DUAVBUS_PYTHON={sys.executable}"], check=True, stdout=out)
    r = subprocess.run(["cmake", "--build", str(bdir), "--target", NODE_TARGET], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        raise NodeProgramMissing(f"building {NODE_TARGET} in {bdir} failed:\n{r.stdout[-3000:]}")
    if not prog.exists():
        raise NodeProgramMissing(f"{prog}: the build succeeded but the program is not there")
    return prog
