"""Constants shared by the tool tests (a uniquely named module: several test folders have a conftest)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
UAVBUS = str(Path(sys.executable).parent / "uavbus")  # the console script of this venv
