"""Issue #13 item 7: size limits known at generation time. `check`/`gen` name every type packing to
more than the payload limit (--max-payload, default UB_MAX_DIRECTORY = 16384: larger than one frame, sent in fragments); the runtime's refusal
names the type and the limit (ub_catalogue_oversize() in C, the exception text in Python)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from gen_testutil import run_cli, write

from uavbus_gen import model

BIG = """\
    #include <stdint.h>
    struct small { uint32_t v; };
    struct dump { uint32_t address; uint16_t words[9000]; };     /* 18004 bytes */
    typedef struct { uint8_t blob[20000]; } image_t;             /* 20000 bytes */
    struct holder { struct dump d; };                            /* contains one */
    extern struct small s;
    extern struct dump memDump;
    extern image_t frameImage;
    extern struct holder hold;
    """


def test_default_limit_is_the_runtimes() -> None:
    header = Path(__file__).resolve().parents[2] / "runtime_c" / "include" / "ub" / "ub_config.h"
    assert f"#define UB_MAX_DIRECTORY {model.DEFAULT_MAX_PAYLOAD}" in header.read_text()


@pytest.mark.parametrize("command", ["check", "gen"])
def test_every_type_over_the_limit_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str) -> None:
    write(tmp_path, "big.h", BIG)
    code, _, err = run_cli([command, "big.h", "-o", "out"], tmp_path, capsys)
    assert code == 1 and not (tmp_path / "out").exists()
    assert "error: 3 type(s) pack to more than the payload limit of 16384 bytes" in err
    for line in ("big.h:3: struct dump: 18004 bytes on the wire", "big.h:4: image_t: 20000 bytes on the wire",
                 "big.h:5: struct holder: 18004 bytes on the wire"):
        assert line in err
    assert "struct small" not in err and "--max-payload" in err


def test_max_payload_raises_the_limit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "big.h", BIG)
    code, _, err = run_cli(["gen", "big.h", "--max-payload", "19000", "-o", "out"], tmp_path, capsys)
    assert code == 1 and "1 type(s) pack to more than the payload limit of 19000" in err
    assert run_cli(["gen", "big.h", "--max-payload", "32768", "-o", "out"], tmp_path, capsys)[0] == 0
    assert "#define catalogue_PAYLOAD_LIMIT 32768u" in (tmp_path / "out" / "catalogue.h").read_text()


def test_keep_going_leaves_them_out_and_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "big.h", BIG)
    code, _, err = run_cli(["gen", "big.h", "-k", "-o", "out"], tmp_path, capsys)
    assert code == 3 and "their instances are not catalogued" in err
    doc = json.loads((tmp_path / "out" / "catalogue.catalogue.json").read_text())
    assert [i["name"] for i in doc["instances"]] == ["s"]
    assert [t["name"] for t in doc["types"]] == ["struct small"]
    reasons = {s["name"]: s["reason"] for s in doc["skipped_instances"]}
    assert reasons["memDump"] == "larger than the payload limit (18004 > 16384 bytes)"


def test_size_and_collision_problems_are_reported_together(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "both.h", BIG + "extern struct small currentSensorADCConfig_System;\n"
                                    "extern struct small currentSensorVirtualConfig_System;\n")
    code, _, err = run_cli(["check", "both.h"], tmp_path, capsys)
    assert code == 1
    assert "payload limit" in err and "share a content ID" in err


def test_python_node_refusal_names_the_type_and_the_limit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "big.h", BIG)
    assert run_cli(["gen", "big.h", "--max-payload", "32768", "-o", "out"], tmp_path, capsys)[0] == 0
    from uavbus import Node
    from uavbus._bindings.ub_error import InvalidArgumentError

    with pytest.raises(InvalidArgumentError) as exc:
        Node(tmp_path / "out" / "catalogue.catalogue.json")
    text = str(exc.value)
    assert "packs to 20000 bytes" in text and "image_t" in text and "payload limit of 16384 bytes" in text
