"""uavbus.config: the paper's Tables 1 and 2, the bad-config corpus shared with the C loader
(runtime_c/tests/test_nodecfg.c), mask helpers, schema agreement and malformed input."""

from __future__ import annotations

import json
import random
from pathlib import Path

import jsonschema
import pytest

from uavbus.config import (
    SCHEMA_PATH, Config, ConfigError, Limits, format_mask_hex, load_config, parse_config, parse_mask_hex,
)

REPO = Path(__file__).resolve().parents[2]
CASES = sorted((REPO / "tests" / "unit" / "config_cases").glob("*.json"))
TABLE1 = REPO / "examples" / "configs" / "table1.json"
TABLE2 = REPO / "examples" / "configs" / "table2.json"

# Cases whose fault is purely structural: the JSON Schema alone must reject them too.
SCHEMA_REJECTS = {
    "top_not_object", "top_unknown_field", "top_missing_entities", "top_system_not_string", "entities_empty",
    "entities_not_list", "entity_not_object", "entity_missing_name", "entity_name_too_long", "entity_name_bad_chars",
    "entity_unknown_field", "links_not_list", "links_too_many", "links_duplicate", "links_bad_name",
    "hex_digit_not_binary", "hex_no_prefix", "hex_no_digits", "hex_too_many_digits", "hex_not_hex", "hex_overlong",
    "mask_bare_number", "list_index_not_whole", "list_index_negative", "list_index_huge", "list_bad_element",
    "lte_bad_key", "lte_wrong_type", "hosts_duplicate", "hosts_not_name", "nodes_empty_list", "nodes_bad_name",
    "nodes_not_object", "ports_missing_transport", "ports_bad_transport", "ports_bad_param_value", "ports_bad_key",
    "ports_not_object", "ports_value_too_long", "ports_value_float", "top_unknown_field_long",
    "top_unknown_field_unsafe", "entity_name_escaped_nul", "hex_non_ascii", "priorities_bad_class",
    "priorities_not_object",
}


def schema_validator() -> jsonschema.Draft202012Validator:
    schema = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_table1_as_published() -> None:
    cfg = load_config(TABLE1)
    assert [e.name for e in cfg.entities] == ["entity0", "entity1", "entity2", "entity3"]
    assert [e.masks for e in cfg.entities] == [
        (0b000, 0b001, 0b001, 0b110),  # 0x00000000 0x00000001 0x00000001 0x00000110
        (0b01, 0b00, 0b10, 0b01),
        (0b1, 0b1, 0b0, 0b1),
        (0b11, 0b11, 0b11, 0b00),
    ]
    assert cfg.entity("entity0").links == ("e0Toe1", "e0Toe3a", "e0Toe3b")
    assert cfg.hosts == ()
    assert cfg.nodes == {"A": ("entity0", "entity1"), "B": ("entity2",), "C": ("entity3",)}
    assert cfg.select_node("A").hosts == ("entity0", "entity1")


def test_table2_as_published() -> None:
    cfg = load_config(TABLE2)
    assert cfg.system == "hitl-table2"
    assert cfg.mask("rmax1ob1", "gcs1") == 0x03
    assert cfg.mask("rmax1ob1", "rmax1ob2") == 0x04
    assert cfg.mask("rmax1ob1", "fcs20") == 0x08
    assert cfg.entity("rmax1ob2").masks == (1, 0, 1, 1)
    assert cfg.entity("fcs20").masks == (1, 1, 0, 1)
    assert cfg.entity("gcs1").masks == (3, 3, 3, 0)
    assert cfg.entity("fcs20").links == ("onboardPortDatalink1",)
    assert cfg.nodes == {"primary": ("rmax1ob1",), "secondary": ("rmax1ob2",), "backup": ("fcs20",),
                         "gcs": ("gcs1",)}
    assert load_config(TABLE2, node="gcs").hosts == ("gcs1",)
    with pytest.raises(ConfigError, match=r"^no node named 'tower' in 'nodes' \(known: primary, secondary, backup, "
                                          r"gcs\)$"):
        cfg.select_node("tower")


def test_paper_tables_pass_the_schema() -> None:
    validator = schema_validator()
    for path in (TABLE1, TABLE2):
        assert list(validator.iter_errors(json.loads(path.read_text()))) == []


def test_documented_example_loads() -> None:
    doc = (REPO / "docs" / "config-format.md").read_text(encoding="utf-8")
    example = doc.split("```json\n", 1)[1].split("```", 1)[0]
    cfg = parse_config(example.encode(), "config-format.md")
    assert cfg.hosts == ("rmax1ob1",)
    assert cfg.mask("rmax1ob1", "gcs1") == 0b11
    assert cfg.mask("rmax1ob1", "rmax1ob2") == 0b100
    assert cfg.entity("gcs1").masks == (0b11, 0b11, 0)


def test_hex_and_list_forms_agree() -> None:
    text = {
        "entities": [
            {"name": "rmax1ob1",
             "links": ["onboardPortDatalink1", "onboardPortDatalink2", "onboardPortIPC", "onboardPortRelay"],
             "linktoentity": {"gcs1": ["onboardPortDatalink1", 1], "rmax1ob2": ["onboardPortIPC"], "fcs20": [3],
                              "rmax1ob1": []}},
            {"name": "rmax1ob2", "links": ["onboard2PortIPC"], "linktoentity": [[0], [], [0], ["onboard2PortIPC"]]},
            {"name": "fcs20", "links": ["onboardPortDatalink1"], "linktoentity": [[0], [0], [], [0]]},
            {"name": "gcs1", "links": ["gcsPortDatalink1", "gcsPortDatalink2"],
             "linktoentity": {"rmax1ob1": [1, 0], "rmax1ob2": "0x11", "fcs20": ["gcsPortDatalink2", 0]}},
        ]
    }
    as_lists = parse_config(json.dumps(text).encode(), "lists.json")
    as_hex = load_config(TABLE2)
    assert [e.masks for e in as_lists.entities] == [e.masks for e in as_hex.entities]


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_shared_bad_config(case: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Same file, same message as the C loader (which reads the same .expect files)."""
    monkeypatch.chdir(REPO)
    relative = case.relative_to(REPO).as_posix()
    expected = case.with_suffix(".expect").read_text(encoding="utf-8").rstrip("\n")
    with pytest.raises(ConfigError) as info:
        load_config(relative)
    assert str(info.value) == expected
    assert info.value.path == relative
    assert info.value.line == int(expected.split(":")[1])


def test_corpus_is_complete() -> None:
    assert len(CASES) >= 60
    assert SCHEMA_REJECTS <= {c.stem for c in CASES}


@pytest.mark.parametrize("name", sorted(SCHEMA_REJECTS))
def test_schema_rejects_structural_cases(name: str) -> None:
    data = json.loads((REPO / "tests" / "unit" / "config_cases" / f"{name}.json").read_text(encoding="utf-8"))
    assert list(schema_validator().iter_errors(data)), f"{name} passes the schema"


def test_mask_hex_helpers() -> None:
    assert parse_mask_hex("0x00000110") == 0b110
    assert parse_mask_hex("0x000000011") == 0b11  # Figure 8's nine digits
    assert format_mask_hex(0b110) == "0x00000110"
    for mask in range(256):
        assert parse_mask_hex(format_mask_hex(mask)) == mask
    for bad in ("", "0x", "110", "0x2", "0x0000000g", "0x100000000", "0x" + "0" * 17):
        with pytest.raises(ValueError):
            parse_mask_hex(bad)
    with pytest.raises(ValueError):
        format_mask_hex(256)


def test_ports_reserved_section() -> None:
    cfg = parse_config(b'{"entities": [{"name": "rmax1ob1", "links": ["onboardPortIPC"]}],\n'
                       b' "ports": {"onboardPortIPC": {"transport": "tcp", "connect": "127.0.0.1:5001",\n'
                       b'   "retry_ms": 500, "nodelay": true}}}', "p.json")
    (port,) = cfg.ports
    assert (port.name, port.transport, port.line) == ("onboardPortIPC", "tcp", 2)
    assert port.params == {"connect": "127.0.0.1:5001", "retry_ms": "500", "nodelay": "true"}


def test_smaller_build_limits() -> None:
    with pytest.raises(ConfigError, match=r"too many entities: this build holds 2 "):
        load_config(TABLE2, limits=Limits(max_entities=2))


def test_missing_file() -> None:
    with pytest.raises(ConfigError, match=r"^nowhere\.json: cannot open: No such file or directory$"):
        load_config("nowhere.json")


def test_every_truncation_rejected() -> None:
    data = TABLE2.read_bytes().rstrip()
    for cut in range(len(data)):
        with pytest.raises(ConfigError, match=r"^cut\.json:\d+: invalid JSON: "):
            parse_config(data[:cut], "cut.json")


def test_random_mutations_fail_cleanly() -> None:
    """Seeded mutations: every outcome is a Config or a located ConfigError, never another exception; and
    every file the C loader accepts also passes the JSON Schema (the schema is a second opinion, kept
    here as a test rather than as a second checker at run time)."""
    rng = random.Random(2005)
    data = TABLE2.read_bytes()
    validator = schema_validator()
    outcomes = {"ok": 0, "error": 0}
    for _ in range(1500):
        mutated = bytearray(data)
        for _ in range(rng.randint(1, 4)):
            mutated[rng.randrange(len(mutated))] = rng.choice(b'{}[]",:0x1\\u 9-eE.tnfa\n\xc3')
        try:
            assert isinstance(parse_config(bytes(mutated), "m.json"), Config)
            outcomes["ok"] += 1
        except ConfigError as exc:
            assert str(exc).startswith("m.json:")
            assert exc.line >= 1
            outcomes["error"] += 1
            continue
        errors = list(validator.iter_errors(json.loads(bytes(mutated))))
        assert errors == [], f"the C loader accepted what the schema refuses: {errors[0].message}"
    assert outcomes["error"] > 0 and outcomes["ok"] > 0


def test_python_goes_through_the_c_loader() -> None:
    """One implementation: the Config carries the C table that Node applies, and nothing in
    uavbus.config scans JSON itself."""
    import uavbus.config as module

    cfg = load_config(TABLE2, node="gcs")
    assert cfg.c_config is not None
    assert cfg.c_config.host_count == 1
    source = Path(module.__file__).read_text(encoding="utf-8")
    assert "json.loads" not in source and "jsonschema" not in source


def test_limits_above_the_build_refused() -> None:
    build = Limits.build()
    assert build.max_entities == 16 and build.max_links_per_entity == 8
    with pytest.raises(ConfigError, match=r"limits: max_entities 17 is more than this build holds \(16\)"):
        load_config(TABLE2, limits=Limits(max_entities=17))


def test_security_section_reaches_python_through_the_c_loader() -> None:
    """The "security" section is checked by the C loader (ub_policy.c; every message: test_policy.c), so
    Python accepts the same files and reports the same errors; the schema describes it too."""
    policy = TABLE2.with_name("table2_policy.json")
    cfg = load_config(policy, node="gcs")
    assert cfg.hosts == ("gcs1",) and cfg.c_config.has_policy == 1
    assert load_config(TABLE2).c_config.has_policy == 0
    doc = json.loads(policy.read_text())
    assert list(schema_validator().iter_errors(doc)) == []
    doc["security"]["administrators"] = ["gcs1", "gcs9"]
    with pytest.raises(ConfigError, match=r"^bad\.json:\d+: field 'security\.administrators\[1\]': no entity named "
                                          r"'gcs9' in 'entities'$"):
        parse_config(json.dumps(doc, indent=1), "bad.json")
