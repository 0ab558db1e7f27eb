"""The C ID functions through cffi agree with the generator's Python rule and with the frame vectors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uavbus._bindings import ub_catalogue as uc
from uavbus_gen import ids

NAMES = ["a", "gps", "imuOut", "onboard", "onboardS", "onboardSet", "navigationSolution",
         "a_very_long_directory_name_indeed", "arr[3][1]"]
VECTORS = json.loads((Path(__file__).resolve().parents[1] / "vectors" / "frames.json").read_text())["vectors"]


def test_lengths_come_from_c() -> None:
    assert (uc.DIR_ID_LEN, uc.ENTITY_ID_LEN) == (16, 12)


@pytest.mark.parametrize("name", NAMES)
def test_dir_id_paper_matches_generator(name: str) -> None:
    assert uc.ub_dir_id_paper(name) == ids.dir_id_paper(name)


@pytest.mark.parametrize("name", ["g", "gcs1", "rmax1ob1", "twelve_chars"])
def test_entity_id_matches_generator(name: str) -> None:
    assert uc.ub_entity_id(name) == ids.entity_id(name)


def test_paper_example_and_vector_ids() -> None:
    assert uc.ub_dir_id_paper("onboardSet") == b"onboardSboardSet" == bytes.fromhex(VECTORS[0]["dir_id"])
    assert uc.ub_entity_id("gcs1") == bytes.fromhex(VECTORS[0]["dest_id"])
