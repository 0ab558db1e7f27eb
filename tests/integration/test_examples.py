"""The example flight software and the colliding fixture, through the `uavbus` CLI as a user runs it.

- `uavbus check` on examples/flightsw exits 0; `uavbus gen` writes a catalogue of >= 700 instances
  (the paper's system had about 700) whose IDs follow the paper's 8+8 rule;
- `uavbus selftest` on examples/flightsw is green with equal C and Python digests;
- `uavbus check` on tests/fixtures/colliding exits 1 naming both members of every colliding group with
  file:line, and 0 with `--id-scheme hashed`.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import jsonschema
import pytest

REPO = Path(__file__).resolve().parents[2]
FLIGHTSW = REPO / "examples" / "flightsw"
COLLIDING = REPO / "tests" / "fixtures" / "colliding" / "colliding.h"
SELFTEST_LINE = re.compile(r"^selftest: (C|Python) (\d+) types ok, digest ([0-9a-f]{8})$", re.MULTILINE)


def run_uavbus(*args: str, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    """Runs `python -m uavbus.cli ARGS` from the repository root, capturing text output."""
    return subprocess.run(
        [sys.executable, "-m", "uavbus.cli", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def flightsw_inputs() -> list[str]:
    headers = sorted(str(p.relative_to(REPO)) for p in FLIGHTSW.glob("*.h"))
    assert headers, f"no headers in {FLIGHTSW}"
    return [*headers, "-I", str(FLIGHTSW.relative_to(REPO))]


def paper_id_hex(name: str) -> str:
    """The paper's content ID, computed here independently of the generator: the first 8 and the last 8
    bytes of the name (overlapping when shorter than 16); each half of a name shorter than 8 is padded on
    the right with 0x00 (ub_catalogue.h, ub_dir_id_paper)."""
    raw = name.encode("ascii")
    head = raw[:8].ljust(8, b"\0")
    tail = raw[-8:] if len(raw) >= 8 else raw.ljust(8, b"\0")
    return (head + tail).hex()


def declaration_line(path: Path, name: str) -> int:
    """1-based line of the `extern` declaration of `name` in `path`."""
    pattern = re.compile(rf"^extern\b.*\b{re.escape(name)}\b")
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if pattern.match(line):
            return number
    raise AssertionError(f"{path}: no extern declaration of {name}")


def describe(proc: subprocess.CompletedProcess[str]) -> str:
    return f"exit {proc.returncode}\n--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}"


@pytest.fixture(scope="module")
def flightsw_generated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, float]:
    """Generates the flightsw catalogue once; returns the output directory and the wall time of `gen`."""
    out = tmp_path_factory.mktemp("flightsw-gen")
    start = time.perf_counter()
    proc = run_uavbus("gen", *flightsw_inputs(), "--name", "flightsw", "-o", str(out))
    elapsed = time.perf_counter() - start
    assert proc.returncode == 0, describe(proc)
    print(f"\nuavbus gen examples/flightsw: {elapsed:.2f} s wall")
    return out, elapsed


def test_check_flightsw_is_unique() -> None:
    proc = run_uavbus("check", *flightsw_inputs())
    assert proc.returncode == 0, describe(proc)


def test_gen_flightsw_has_at_least_700_instances(flightsw_generated: tuple[Path, float]) -> None:
    out, _ = flightsw_generated
    catalogue = json.loads((out / "flightsw.catalogue.json").read_text())
    schema = json.loads((REPO / "schemas" / "catalogue.schema.json").read_text())
    jsonschema.validate(catalogue, schema)
    instances = catalogue["instances"]
    assert catalogue["id_scheme"] == "paper"
    assert len(instances) >= 700, f"only {len(instances)} instances"
    names = [inst["name"] for inst in instances]
    assert len(set(names)) == len(names), "an instance is listed twice"
    ids = [inst["id"] for inst in instances]
    assert len(set(ids)) == len(ids), "IDs are not unique"
    for inst in instances:
        assert inst["id"] == paper_id_hex(inst["name"]), inst
    by_name = {inst["name"]: inst for inst in instances}
    # The paper's own example (Figure 7) and element naming of 1-D and 2-D arrays.
    assert by_name["onboardSet"]["id"] == b"onboardSboardSet".hex()
    assert {f"waypointPlan[{i}]" for i in range(128)} <= by_name.keys()
    assert {f"batteryCell[{p}][{c}]" for p in range(2) for c in range(12)} <= by_name.keys()


def test_gen_flightsw_records_source_locations(flightsw_generated: tuple[Path, float]) -> None:
    out, _ = flightsw_generated
    catalogue = json.loads((out / "flightsw.catalogue.json").read_text())
    by_name = {inst["name"]: inst for inst in catalogue["instances"]}
    for name, header in (("gpsOut", "gps.h"), ("onboardPortRelay", "datalink.h"), ("thermocouple[3][7]", "sensors.h")):
        line = declaration_line(FLIGHTSW / header, name.split("[")[0])
        inst = by_name[name]
        assert Path(inst["file"]).as_posix().endswith(f"examples/flightsw/{header}"), inst
        assert inst["line"] == line, f"{name}: expected {header}:{line}, got {inst}"


def test_gen_flightsw_skips_every_kind_the_example_holds(flightsw_generated: tuple[Path, float]) -> None:
    out, _ = flightsw_generated
    catalogue = json.loads((out / "flightsw.catalogue.json").read_text())
    skip_reasons = {
        t["name"]: {f["name"]: f["skipped"] for f in t["fields"]} for t in catalogue["types"]
    }
    port = skip_reasons["struct datalinkPort"]
    assert port["deviceName"] and "string" in port["deviceName"]
    assert port["driver"] and "pointer" in port["driver"]
    assert port["bytesIn"] is None and port["messagesByType"] is None
    queue = skip_reasons["struct datalinkRxQueue"]
    assert queue["ring"] and "flexible" in queue["ring"]
    assert skip_reasons["struct gpsRaw"]["rawMessage"] is None, "uint8_t arrays are data, not strings"
    governor = skip_reasons["struct throttleGovernor"]
    assert governor["limiterHook"] and "pointer" in governor["limiterHook"]


def test_gen_flightsw_is_deterministic(flightsw_generated: tuple[Path, float], tmp_path: Path) -> None:
    first, _ = flightsw_generated
    proc = run_uavbus("gen", *flightsw_inputs(), "--name", "flightsw", "-o", str(tmp_path))
    assert proc.returncode == 0, describe(proc)
    produced = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    again = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    assert produced == again
    for rel in produced:
        assert (first / rel).read_bytes() == (tmp_path / rel).read_bytes(), f"{rel} differs between two runs"


def test_selftest_flightsw_digests_agree() -> None:
    proc = run_uavbus("selftest", *flightsw_inputs(), "--name", "flightsw")
    assert proc.returncode == 0, describe(proc)
    results = {lang: (int(n), digest) for lang, n, digest in SELFTEST_LINE.findall(proc.stdout + proc.stderr)}
    assert set(results) == {"C", "Python"}, describe(proc)
    assert results["C"] == results["Python"], results
    assert results["C"][0] > 0


def expected_paper_groups(names: list[str]) -> list[list[str]]:
    groups: dict[str, list[str]] = defaultdict(list)
    for name in names:
        groups[paper_id_hex(name)].append(name)
    return [members for members in groups.values() if len(members) > 1]


COLLIDING_NAMES = [
    "currentSensorADCConfig_System",
    "currentSensorVirtualConfig_System",
    *[f"vehicleHealth_SystemArray[{i}]" for i in range(3)],
    *[f"vehicleHealth_CopyArray[{i}]" for i in range(3)],
    "vehicleHealthSummary",
]


def test_check_colliding_fixture_names_every_member() -> None:
    groups = expected_paper_groups(COLLIDING_NAMES)
    assert len(groups) == 4  # the fixture's own claim, checked independently of the generator
    proc = run_uavbus("check", str(COLLIDING.relative_to(REPO)))
    assert proc.returncode == 1, describe(proc)
    report = proc.stdout + proc.stderr
    for members in groups:
        for name in members:
            line = declaration_line(COLLIDING, name.split("[")[0])
            assert re.search(rf"colliding\.h:{line}\b.*{re.escape(name)}", report) or re.search(
                rf"{re.escape(name)}.*colliding\.h:{line}\b", report
            ), f"{name} (colliding.h:{line}) not named:\n{report}"
    assert "vehicleHealthSummary" not in report, "a unique instance was reported as colliding"


def test_check_colliding_fixture_is_unique_when_hashed() -> None:
    proc = run_uavbus("check", str(COLLIDING.relative_to(REPO)), "--id-scheme", "hashed")
    assert proc.returncode == 0, describe(proc)
