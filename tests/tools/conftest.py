"""Fixtures for the tool tests: the example flight software's catalogue, frames, small logs."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from logwriter import write_log  # noqa: E402
from tools_testutil import ROOT, gps_value, imu_value, make_frame  # noqa: E402,F401 (fixtures use them)

from uavbus.catalogue import Catalogue  # noqa: E402
from uavbus.enums import catalogue_enums  # noqa: E402



@pytest.fixture(scope="session")
def catalogue_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("gen")
    headers = sorted(str(p) for p in (ROOT / "examples" / "flightsw").glob("*.h"))
    subprocess.run([sys.executable, "-m", "uavbus.cli", "gen", *headers, "-I", str(ROOT / "examples" / "flightsw"),
                    "--name", "flightsw", "-o", str(out)], check=True, cwd=ROOT, capture_output=True)
    return out / "flightsw.catalogue.json"


@pytest.fixture(scope="session")
def cat(catalogue_path: Path) -> Catalogue:
    return Catalogue.load(catalogue_path)


@pytest.fixture
def sample_log(tmp_path: Path, cat: Catalogue) -> Callable[..., tuple[Path, bytes, list[dict[str, Any]]]]:
    """A gcs1 log: gpsOut every 100 ms on link 0 and imuOut every 20 ms on link 1, one tx ACK."""

    def make(n_gps: int = 20, name: str = "gcs.ublog") -> tuple[Path, bytes, list[dict[str, Any]]]:
        records = []
        expected = []
        seq = 1
        for k in range(n_gps):
            t = 1000 + 100 * k
            v = gps_value(cat, k)
            records.append((make_frame(cat, "gpsOut", v, "rmax1ob1", "gcs1", seq), t, 0, 0))
            # As the tools show it: enum members by their constants' names.
            shown = catalogue_enums(cat).labels(cat.type_of("gpsOut"), v)
            expected.append({"name": "gpsOut", "t_ms": t, "seq": seq, "value": v, "shown": shown})
            seq += 1
            for j in range(5):
                records.append((make_frame(cat, "imuOut", imu_value(cat, k), "fcs20", "gcs1", 1000 + 5 * k + j),
                                t + 20 * j, 1, 0))
        records.append((make_frame(cat, "gpsOut", {}, "gcs1", "rmax1ob1", 7, admin=5), 5000, 0, 1))
        path = tmp_path / name
        data = write_log(path, "gcs", {0: "gcsPortDatalink1", 1: "gcsPortDatalink2"}, cat.json_text, records)
        return path, data, expected

    return make


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    # Every tool test is bounded: 60 s each (the whole folder takes about 20 s).
    here = Path(__file__).resolve().parent
    for item in items:
        if Path(str(item.fspath)).resolve().parent == here:
            item.add_marker(pytest.mark.timeout(60))
