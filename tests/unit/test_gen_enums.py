"""Enum constants in the catalogue (format fixed in /work/notes/team.md): top-level
`"enums": {"<enum type name>": {"<CONSTANT>": value, ...}}` in declaration order, the name being
`enum tag`, else the typedef name, else `<parent>::<member>`; every field gains `"enum"`."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import jsonschema
import pytest
from gen_testutil import REPO, run_cli, write

from uavbus import Catalogue

SCHEMA = json.loads((REPO / "schemas" / "catalogue.schema.json").read_text())

MODES = """\
    #include <stdint.h>
    typedef enum { MODE_OFF = 0, MODE_SAFE = 4, MODE_NOMINAL = 2 } mode_t;
    enum health { H_FAIL = -1, H_OK = 1, H_WARN };
    enum unused { U_A };
    struct status {
        mode_t mode;
        enum health per_unit[3];
        enum { PHASE_A = 10, PHASE_B = 20 } phase;
        mode_t narrow : 3;
        uint8_t plain;
    };
    extern struct status st;
    """


@pytest.fixture()
def out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    write(tmp_path, "m.h", MODES)
    assert run_cli(["gen", "m.h", "--name", "modes", "-o", "out"], tmp_path, capsys)[0] == 0
    return tmp_path / "out"


def test_json_format(out: Path) -> None:
    doc = json.loads((out / "modes.catalogue.json").read_text())
    jsonschema.validate(doc, SCHEMA)
    assert doc["enums"] == {
        "enum health": {"H_FAIL": -1, "H_OK": 1, "H_WARN": 2},
        "mode_t": {"MODE_OFF": 0, "MODE_SAFE": 4, "MODE_NOMINAL": 2},
        "struct status::phase": {"PHASE_A": 10, "PHASE_B": 20},
    }
    # Declaration order, not value order, survives the round trip through the JSON text.
    assert list(json.loads((out / "modes.catalogue.json").read_text())["enums"]["mode_t"]) == [
        "MODE_OFF", "MODE_SAFE", "MODE_NOMINAL"]
    fields = {f["name"]: f for f in doc["types"][0]["fields"]}
    assert {n: f["enum"] for n, f in fields.items()} == {
        "mode": "mode_t", "per_unit": "enum health", "phase": "struct status::phase", "narrow": "mode_t", "plain": None}


def test_schema_accepts_catalogues_from_before_enums(out: Path) -> None:
    doc = json.loads((out / "modes.catalogue.json").read_text())
    del doc["enums"]
    for t in doc["types"]:
        for f in t["fields"]:
            del f["enum"]
    jsonschema.validate(doc, SCHEMA)
    assert Catalogue(doc).enums == {}


def test_catalogue_accessor(out: Path) -> None:
    cat = Catalogue.load(out / "modes.catalogue.json")
    assert cat.enums["enum health"] == {"H_FAIL": -1, "H_OK": 1, "H_WARN": 2}
    assert cat.enum_of("st", "per_unit") == {"H_FAIL": -1, "H_OK": 1, "H_WARN": 2}
    assert cat.enum_of("struct status", "plain") is None
    assert cat.type("struct status").field("mode").enum == "mode_t"
    cat.enums["mode_t"]["MODE_OFF"] = 99  # a copy
    assert cat.enums["mode_t"]["MODE_OFF"] == 0


def test_generated_python_exposes_them(out: Path) -> None:
    spec = importlib.util.spec_from_file_location("_modes_under_test", out / "modes.py")
    mod = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    assert mod.ENUMS["struct status::phase"] == {"PHASE_A": 10, "PHASE_B": 20}
    assert mod.status.FIELD_ENUMS == {"mode": "mode_t", "per_unit": "enum health", "phase": "struct status::phase",
                                      "narrow": "mode_t"}


def test_an_enum_defined_two_ways_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "a.h", "enum e { A = 1 };\nstruct s { enum e v; };\nextern struct s x;\n")
    write(tmp_path, "b.h", "enum e { A = 2 };\nstruct t { enum e v; };\nextern struct t y;\n")
    code, _, err = run_cli(["check", "a.h", "b.h"], tmp_path, capsys)
    assert code == 1 and "'enum e' has other constants here than at" in err and "a.h:1" in err and "b.h:1" in err
