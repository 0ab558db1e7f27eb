"""cffi builder for `uavbus._ub`: out-of-line API mode over the C runtime's own sources.

setuptools runs this through `cffi_modules` in setup.py, so `pip install` builds the extension with
no manual step. The runtime's C sources are compiled into the extension itself (one router for C and
Python), and the cdefs in `_cdefs/` are checked against the real headers by the C compiler.

The sources are found from the package, under `uavbus/_data/runtime_c/` (package data, see
`uavbus._paths`; in the repository a link to the top-level runtime_c/), so the same build runs in a
checkout, in an unpacked sdist and for `python -m build`. After editing a C source or a cdef, rebuild
with `pip install -e .` (from the repository root; `make setup` does it when they change).
"""

from __future__ import annotations

from pathlib import Path

from cffi import FFI

PACKAGE_DIR = Path(__file__).resolve().parent
ROOT = PACKAGE_DIR.parents[1]
CDEF_DIR = PACKAGE_DIR / "_cdefs"
C_RUNTIME_DIR = PACKAGE_DIR / "_data" / "runtime_c"  # not resolved: the paths stay inside the tree
C_INCLUDE_DIR = C_RUNTIME_DIR / "include"
C_SOURCE_DIR = C_RUNTIME_DIR / "src"


def _relative_to_root(path: Path) -> str:
    # setuptools refuses absolute paths in setup() arguments; it runs with the repository root as cwd.
    return path.relative_to(ROOT).as_posix()


def _cdef_headers() -> list[Path]:
    # Sorted, as PyNaCl's build.py does; each cdef file declares only what it uses itself.
    return sorted(CDEF_DIR.glob("*.h"))


def _c_header_names() -> list[str]:
    return [f"ub/{header.name}" for header in _cdef_headers()]


def make_ffibuilder() -> FFI:
    builder = FFI()
    for header in _cdef_headers():
        builder.cdef(header.read_text(encoding="utf-8"))
    includes = "".join(f"#include <{name}>\n" for name in _c_header_names())
    builder.set_source(
        "uavbus._ub",
        includes,
        sources=[_relative_to_root(src) for src in sorted(C_SOURCE_DIR.glob("*/*.c"))],
        # src/ too: private headers are included by their layer ("core/ub_node_private.h").
        include_dirs=[_relative_to_root(C_INCLUDE_DIR), _relative_to_root(C_SOURCE_DIR)],
        # Frame security (ub_sec.c) is libsodium's: the same build as CMake's UAVBUS_SECURITY=ON.
        define_macros=[("_POSIX_C_SOURCE", "200809L"), ("UB_SECURITY", "1")],
        libraries=["sodium", "m"],  # libsodium for ub_sec, libm for ub_motion
        extra_compile_args=["-std=c11"],
    )
    return builder


ffibuilder = make_ffibuilder()
