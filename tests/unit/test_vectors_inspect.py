"""The remote-inspection vectors (tests/vectors/inspect.json): the committed file is exactly what the
independent Python reference writes; Python's record decoder (uavbus._bindings.ub_inspect, what
Remote.table() uses) reads every LIST record back to its fields, and the op/table numbers and record
sizes agree with the C header. (The C side, runtime_c/tests/test_inspect_vectors.c, rebuilds every
payload byte for byte from the same fields.)"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from uavbus._bindings import ub_inspect

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
JSON_PATH = VECTORS_DIR / "inspect.json"
DOC: dict[str, Any] = json.loads(JSON_PATH.read_text(encoding="utf-8"))
TABLE_OF = {"entity": "entities", "link": "links", "pubsub": "pubsub", "admin": "admin"}


def load_reference() -> ModuleType:
    spec = importlib.util.spec_from_file_location("make_inspect_vectors", VECTORS_DIR / "make_inspect_vectors.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_regenerating_reproduces_committed_json_exactly() -> None:
    assert load_reference().render() == JSON_PATH.read_text(encoding="utf-8"), (
        f"{JSON_PATH}:1: stale; run python3 tests/vectors/make_inspect_vectors.py")


def test_numbers_and_sizes_agree_with_the_c_header() -> None:
    ref = load_reference()
    assert ref.OPS == {k: int(v) for k, v in ub_inspect.OPS.items()}
    assert ref.TABLES == {k: int(v) for k, v in ub_inspect.TABLES.items()}
    for v in DOC["vectors"]:
        if v["layout"] in TABLE_OF:
            assert len(bytes.fromhex(v["bytes"])) == ub_inspect.RECORD_SIZE[TABLE_OF[v["layout"]]], v["name"]


def entity(hex_id: str) -> str:
    return bytes.fromhex(hex_id).rstrip(b"\0").decode("ascii")


@pytest.mark.parametrize("v", [v for v in DOC["vectors"] if v["layout"] in TABLE_OF], ids=lambda v: v["name"])
def test_python_decodes_each_record_to_its_fields(v: dict[str, Any]) -> None:
    dir_names = {bytes.fromhex(v[k]): f"dir:{v[k]}" for k in ("dir_id",) if k in v}
    (got,) = ub_inspect.decode_records(TABLE_OF[v["layout"]], bytes.fromhex(v["bytes"]),
                                       lambda d: dir_names[bytes(d)])
    if v["layout"] == "entity":
        assert got == {"entity": entity(v["entity_id"]), "local": bool(v["local"]),
                       "mask": "0x" + "".join("1" if v["mask"] >> k & 1 else "0" for k in reversed(range(8))), "pinned": bool(v["pinned"])}
    elif v["layout"] == "link":
        assert got == {"link": bytes.fromhex(v["name"]).decode(), "index": v["index"], "attached": bool(v["attached"]),
                       **{k: v[k] for k in ("frames_in", "frames_out", "bytes_in", "bytes_out", "drops", "accepted")}}
    elif v["layout"] == "pubsub":
        assert got == {"row": v["row"], "kind": {1: "publication", 2: "subscription"}[v["kind"]], "state": v["state"],
                       "content": f"dir:{v['dir_id']}", "peer": entity(v["peer"]), "owner": entity(v["owner"]) or None,
                       "period_ms": v["period_ms"], "frames": v["frames"]}
    else:
        assert got["row"] == v["row"] and got["type"] == ["publication", "subscription"][v["type"]]
        assert got["status"] == "failed" and v["status"] == 4  # ub_admin_status_t: UB_ADMIN_FAILED
        assert (got["content"], got["source"], got["destination"]) == (f"dir:{v['dir_id']}", entity(v["source"]),
                                                                      entity(v["destination"]))
        assert (got["period_ms"], got["active"], got["reason"]) == (v["period_ms"], bool(v["active"]), "not_authorized")
