"""Constants shared by the tool tests (a uniquely named module: several test folders have a conftest)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from uavbus._bindings.ub_catalogue import ub_entity_id
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus.catalogue import Catalogue

ROOT = Path(__file__).resolve().parents[2]
UAVBUS = str(Path(sys.executable).parent / "uavbus")  # the console script of this venv


def gps_value(cat: Catalogue, k: int) -> dict[str, Any]:
    v = cat.default("gpsOut")
    v["latitudeDeg"] = 33.7 + k * 1e-5
    v["longitudeDeg"] = -84.4 - k * 0.25
    v["satellitesUsed"] = k % 12
    v["solutionCount"] = k
    return v


def imu_value(cat: Catalogue, k: int) -> dict[str, Any]:
    v = cat.default("imuOut")
    v["p"] = 0.01 * k
    v["sampleCount"] = k
    v["temperatureC"] = 20.0 + k * 0.5
    return v


def make_frame(cat: Catalogue, name: str, value: dict[str, Any], src: str, dest: str, seq: int,
               admin: int = 0) -> bytes:
    inst = cat.instance(name)
    payload = cat.encode(inst, value) if admin == 0 else bytes(8)
    return ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=ub_entity_id(dest), src_id=ub_entity_id(src),
                                       admin=admin, seq=seq, fingerprint=inst.type.fingerprint if admin == 0 else 0),
                           payload)
