"""Issue #13 item 5: strings as data by choice. `char` arrays are skipped by default (the paper's
rule); `--strings bytes` sends every one, `--string-field TYPE.MEMBER` chosen ones, as their bytes:
wire u8 (the layout of a uint8_t array), a `bytes` per innermost row in Python."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest
from gen_testutil import catalogue_of, needs_gcc, run_cli, write

from uavbus import Catalogue
from uavbus_gen import model

ROW = """\
    #include <stdint.h>
    typedef struct { char name[12]; uint16_t id; char path[2][6]; } row_t;
    struct other { char callsign[8]; uint8_t raw[8]; };
    extern row_t table[2];
    extern struct other ac;
    """


def load(out: Path, name: str = "catalogue"):
    spec = importlib.util.spec_from_file_location(f"_strings_{name}_{id(out)}", out / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    return mod


def test_default_is_the_papers_rule(tmp_path: Path) -> None:
    cat = catalogue_of(write(tmp_path, "r.h", ROW))
    row = {f.name: f for f in cat.type("row_t").fields}
    assert row["name"].skipped == model.SKIP_STRING and row["path"].skipped == model.SKIP_STRING
    assert cat.type("row_t").packed_size == 2


def test_strings_bytes_sends_every_char_array(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "r.h", ROW)
    assert run_cli(["gen", "r.h", "--strings", "bytes", "-o", "out"], tmp_path, capsys)[0] == 0
    doc = json.loads((tmp_path / "out" / "catalogue.catalogue.json").read_text())
    fields = {f["name"]: f for t in doc["types"] for f in t["fields"]}
    assert (fields["name"]["wire"], fields["name"]["count"], fields["name"]["text"]) == ("u8", [12], True)
    assert fields["raw"]["text"] is False and fields["callsign"]["text"] is True
    mod = load(tmp_path / "out")
    r = mod.row_t(name=b"GPS", id=7, path=[b"a/b", b"c"])
    packed = r.pack()
    assert packed == b"GPS" + bytes(9) + b"\x07\x00" + b"a/b\0\0\0" + b"c\0\0\0\0\0"
    back = mod.row_t.unpack(packed)
    assert back.name == b"GPS" + bytes(9) and back.path == [b"a/b\0\0\0", b"c" + bytes(5)]
    assert back.pack() == packed  # canonical: all the bytes travel, NULs included
    with pytest.raises(ValueError, match="13 bytes do not fit 12"):
        mod.row_t(name=b"x" * 13).pack()
    with pytest.raises(ValueError, match="expected bytes"):
        mod.row_t(name="GPS").pack()
    # The catalogue-only codec (uavbus.Catalogue) reads the same layout from the JSON.
    cat = Catalogue.load(tmp_path / "out" / "catalogue.catalogue.json")
    assert cat.decode("table[1]", packed) == back.to_dict()
    assert cat.encode("table[0]", back.to_dict()) == packed
    assert cat.encode("table[0]", {"name": b"GPS", "id": 7, "path": [b"a/b", b"c"]}) == packed


def test_string_field_chooses_members(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "r.h", ROW)
    code, _, err = run_cli(["gen", "r.h", "--string-field", "row_t.name", "--string-field", "*.callsign",
                            "--string-field", "row_t.nothing", "-o", "out"], tmp_path, capsys)
    assert code == 0
    assert "warning: --string-field 'row_t.nothing' matches no member" in err
    doc = json.loads((tmp_path / "out" / "catalogue.catalogue.json").read_text())
    fields = {(t["name"], f["name"]): f for t in doc["types"] for f in t["fields"]}
    assert fields[("row_t", "name")]["text"] and fields[("struct other", "callsign")]["text"]
    assert fields[("row_t", "path")]["skipped"] == "string"


def test_text_keeps_the_layout_fingerprint_of_bytes(tmp_path: Path) -> None:
    from uavbus_gen import frontend

    def build(path: Path, strings: str) -> model.Catalogue:
        units = frontend.parse_files([str(path)], frontend.ParseOptions())
        return model.build_catalogue(units, "paper", str, model.BuildOptions(strings=strings))

    chars = write(tmp_path, "a.h", "struct s { char n[4]; int v; };\nextern struct s x;\n")
    octets = write(tmp_path, "b.h", "#include <stdint.h>\nstruct s { uint8_t n[4]; int v; };\nextern struct s x;\n")
    # Same bytes on the wire, same fingerprint: text is how Python shows them, not a layout.
    assert build(chars, "bytes").type("struct s").fingerprint == build(octets, "skip").type("struct s").fingerprint


@needs_gcc
def test_selftest_with_strings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, "r.h", ROW)
    code, out, err = run_cli(["selftest", "r.h", "--strings", "bytes"], tmp_path, capsys)
    assert code == 0, out + err
