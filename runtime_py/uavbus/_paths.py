"""Where the files uavbus ships beside its code live: Jinja2 templates, JSON schemas, and the C
runtime's headers and sources (for the cffi build, `uavbus selftest` and `uavbus_generate()`).

They are package data under ``uavbus/_data/``. In the repository, ``runtime_py/uavbus/_data/*`` are
symbolic links to the top-level ``templates/``, ``schemas/`` and ``runtime_c/``, so a checkout, an
editable install and an installed wheel all find them at the same place, and the files themselves are
never copied or moved in the tree.
"""

from __future__ import annotations

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent / "_data"
TEMPLATES_DIR = DATA_DIR / "templates"
SCHEMAS_DIR = DATA_DIR / "schemas"
RUNTIME_C_DIR = DATA_DIR / "runtime_c"
RUNTIME_INCLUDE_DIR = RUNTIME_C_DIR / "include"
RUNTIME_SOURCE_DIR = RUNTIME_C_DIR / "src"

__all__ = ["DATA_DIR", "RUNTIME_C_DIR", "RUNTIME_INCLUDE_DIR", "RUNTIME_SOURCE_DIR", "SCHEMAS_DIR", "TEMPLATES_DIR"]
