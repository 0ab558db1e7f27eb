"""tests/vectors/structs.json reproduced byte for byte by uavbus.Catalogue and by the generated
`<name>.py`, and decoded back to the same values; its `refused` images refused by both (the C side:
tests/vectors/CMakeLists.txt builds the same checks against the generated C)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from binding_testutil import REPO, Generated

DOC = json.loads((REPO / "tests" / "vectors" / "structs.json").read_text())
VECTORS = DOC["vectors"]


@pytest.mark.parametrize("vec", VECTORS, ids=lambda v: f"{v['catalogue']}:{v['instance']}")
def test_struct_vector(vec: dict, request: pytest.FixtureRequest) -> None:
    gen: Generated = request.getfixturevalue(vec["catalogue"] if vec["catalogue"] == "kinds" else "flightsw")
    cat = gen.catalogue
    t = cat.type_of(vec["instance"])
    assert (t.name, f"{t.fingerprint:08x}", t.packed_size) == (vec["type"], vec["fingerprint"], vec["packed_size"])
    packed = bytes.fromhex(vec["packed"])
    assert cat.encode(vec["instance"], vec["value"]) == packed
    cls = {c.NAME: c for c in gen.module.TYPES}[t.name]
    assert cls.from_dict(vec["value"]).pack() == packed
    assert cat.decode(vec["instance"], packed) == vec["value"] == cls.unpack(packed).to_dict()


@pytest.mark.parametrize("vec", DOC["refused"], ids=lambda v: f"{v['catalogue']}:{'.'.join(map(str, v['member']))}")
def test_refused_image(vec: dict, request: pytest.FixtureRequest) -> None:
    from uavbus.catalogue import DecodeError

    gen: Generated = request.getfixturevalue(vec["catalogue"] if vec["catalogue"] == "kinds" else "flightsw")
    image = bytes.fromhex(vec["packed"])
    said = "bool byte" if vec["why"].startswith("bool") else f"{vec['member'][-1]}: "  # the message names it
    with pytest.raises(DecodeError, match=said):
        gen.catalogue.decode(vec["instance"], image)
    cls = {c.NAME: c for c in gen.module.TYPES}[vec["type"]]
    with pytest.raises(ValueError):
        cls.unpack(image)


def test_refused_images_cover_bools_and_both_signs_of_bitfields() -> None:
    whys = " | ".join(v["why"] for v in DOC["refused"])
    assert "bool byte 2" in whys and "-17 in a 5-bit signed" in whys and "16 in a 5-bit signed" in whys


def test_vectors_file_is_current() -> None:
    import subprocess
    import sys

    script = Path(REPO / "tests" / "vectors" / "make_struct_vectors.py")
    proc = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
