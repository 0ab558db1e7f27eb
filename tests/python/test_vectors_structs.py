"""tests/vectors/structs.json reproduced byte for byte by uavbus.Catalogue and by the generated
`<name>.py`, and decoded back to the same values (the C side: see the room B report)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from binding_testutil import REPO, Generated

VECTORS = json.loads((REPO / "tests" / "vectors" / "structs.json").read_text())["vectors"]


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


def test_vectors_file_is_current() -> None:
    import subprocess
    import sys

    script = Path(REPO / "tests" / "vectors" / "make_struct_vectors.py")
    proc = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
