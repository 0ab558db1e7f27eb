"""Real headers nobody here wrote: the MAVLink C library that pymavlink's mavgen generates from common.xml.

Tried the way a new user would: generate the MAVLink headers, write one header that includes
`common/mavlink.h` and declares one instance per message type (a "last received message" cache,
`mav_<message>`), then run the uavbus CLI on it. Parsing mavgen's headers needs no -D flags: they
are C99 with `MAVPACKED(...)` (`__attribute__((packed))` under GCC/clang) on the messages whose
extension fields would otherwise be padded, plus `static inline` helpers.

Checks: no parse error; `uavbus check` exits 1 and names every colliding group under the paper's 8+8
rule (the groups are computed here independently); `uavbus check --id-scheme hashed` exits 0;
`uavbus selftest --id-scheme hashed` is green in C and Python with equal digests over every message.

Found while trying: under gcc -Wall -Werror (the selftest's C build), mavgen's own inline encoders
fail with -Waddress-of-packed-member, so the selftest passes `-- -Wno-address-of-packed-member`.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

pymavlink = pytest.importorskip(
    "pymavlink", reason="pymavlink is not installed (it is in the `test` extras: pip install -e '.[test]')"
)

MESSAGE_STRUCT = re.compile(r"typedef struct __mavlink_(\w+)_t\b")
SELFTEST_LINE = re.compile(r"^selftest: (C|Python) (\d+) types ok, digest ([0-9a-f]{8})$", re.MULTILINE)
INSTANCE_PREFIX = "mav_"


def run(cmd: list[str], cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)


def describe(proc: subprocess.CompletedProcess[str]) -> str:
    return f"exit {proc.returncode}\n--- stdout\n{proc.stdout[-6000:]}\n--- stderr\n{proc.stderr[-6000:]}"


def common_xml() -> Path:
    """common.xml as shipped in the installed pymavlink (the wheel's layout has moved between releases)."""
    root = Path(pymavlink.__file__).resolve().parent
    candidates = [root / "message_definitions" / "v1.0" / "common.xml", root / "dialects" / "v20" / "common.xml"]
    for path in candidates:
        if path.is_file():
            return path
    pytest.fail(f"common.xml not found in the installed pymavlink; looked at {[str(p) for p in candidates]}")


def paper_id(name: str) -> bytes:
    """The paper's 8+8 content ID, computed independently of the generator (all names here are >= 8 chars)."""
    raw = name.encode("ascii")
    assert len(raw) >= 8, name
    return raw[:8] + raw[-8:]


class MavlinkWorkspace:
    """mavgen's output plus the instances header, in one temporary directory."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.include = root / "mavlink"
        self.header = root / "mav_instances.h"
        self.messages: list[str] = []

    def generate(self) -> None:
        proc = run(
            [sys.executable, "-m", "pymavlink.tools.mavgen", "--lang=C", "--wire-protocol=2.0",
             f"--output={self.include}", str(common_xml())],
            cwd=self.root,
        )
        assert proc.returncode == 0, describe(proc)
        found = set()
        for path in self.include.rglob("mavlink_msg_*.h"):
            found.update(MESSAGE_STRUCT.findall(path.read_text(encoding="utf-8")))
        self.messages = sorted(found)
        assert len(self.messages) > 100, f"mavgen produced only {len(self.messages)} message types"
        lines = ["/* One received-message cache per MAVLink message type. */", '#include "common/mavlink.h"', ""]
        lines += [f"extern mavlink_{m}_t {INSTANCE_PREFIX}{m};" for m in self.messages]
        self.header.write_text("\n".join(lines) + "\n")

    def instance_line(self, instance: str) -> int:
        for number, line in enumerate(self.header.read_text().splitlines(), start=1):
            if line.endswith(f" {instance};"):
                return number
        raise AssertionError(f"{instance} not declared in {self.header}")

    def inputs(self) -> list[str]:
        return [self.header.name, "-I", self.include.name]

    def uavbus(self, *args: str) -> subprocess.CompletedProcess[str]:
        return run([sys.executable, "-m", "uavbus.cli", *args], cwd=self.root)


@pytest.fixture(scope="module")
def mavlink(tmp_path_factory: pytest.TempPathFactory) -> MavlinkWorkspace:
    workspace = MavlinkWorkspace(tmp_path_factory.mktemp("mavlink"))
    workspace.generate()
    return workspace


def colliding_groups(messages: list[str]) -> list[list[str]]:
    groups: dict[bytes, list[str]] = defaultdict(list)
    for message in messages:
        groups[paper_id(INSTANCE_PREFIX + message)].append(INSTANCE_PREFIX + message)
    return [sorted(members) for members in groups.values() if len(members) > 1]


def test_check_names_every_colliding_group_under_the_paper_rule(mavlink: MavlinkWorkspace) -> None:
    groups = colliding_groups(mavlink.messages)
    assert groups, "expected real collisions, e.g. mav_mission_current / mav_mission_set_current"
    proc = mavlink.uavbus("check", *mavlink.inputs())
    assert proc.returncode == 1, describe(proc)
    report = proc.stdout + proc.stderr
    for members in groups:
        for instance in members:
            where = f"{mavlink.header.name}:{mavlink.instance_line(instance)}"
            assert re.search(rf"{re.escape(where)}\b.*\b{re.escape(instance)}\b", report), (
                f"{instance} ({where}) is not named:\n{report[-4000:]}"
            )
    colliding = {instance for members in groups for instance in members}
    unique = [INSTANCE_PREFIX + m for m in mavlink.messages if INSTANCE_PREFIX + m not in colliding]
    for instance in unique:
        assert not re.search(rf"\b{re.escape(instance)}\b", report), f"{instance} is unique but was reported"


def test_check_is_clean_with_hashed_ids(mavlink: MavlinkWorkspace) -> None:
    proc = mavlink.uavbus("check", *mavlink.inputs(), "--id-scheme", "hashed")
    assert proc.returncode == 0, describe(proc)


def test_selftest_hashed_is_green_in_both_languages(mavlink: MavlinkWorkspace) -> None:
    # MAVLink's own static inline encoders pass packed members' arrays by pointer, which gcc's -Wall
    # flags (-Waddress-of-packed-member) and the selftest build's -Werror turns into an error inside
    # mavgen's headers. Any MAVLink user building with -Werror needs this flag; clang accepts it too.
    proc = mavlink.uavbus(
        "selftest", *mavlink.inputs(), "--id-scheme", "hashed", "--name", "mavcache",
        "--", "-Wno-address-of-packed-member",
    )
    assert proc.returncode == 0, describe(proc)
    results = {lang: (int(n), digest) for lang, n, digest in SELFTEST_LINE.findall(proc.stdout + proc.stderr)}
    assert set(results) == {"C", "Python"}, describe(proc)
    assert results["C"] == results["Python"], results
    assert results["C"][0] == len(mavlink.messages), f"{results['C'][0]} types, {len(mavlink.messages)} messages"


@pytest.mark.parametrize("flags", [
    ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"],          # the inputs are system headers here
    ["-std=c99", "-Wall", "-Werror", "-Wno-address-of-packed-member"],  # MAVLink's own C99 build
], ids=["c99-pedantic", "mavlink-flags"])
def test_generated_c_compiles(mavlink: MavlinkWorkspace, tmp_path: Path, flags: list[str]) -> None:
    proc = mavlink.uavbus("gen", *mavlink.inputs(), "--id-scheme", "hashed", "--name", "mavcache",
                          "-o", str(tmp_path / "out"))
    assert proc.returncode == 0, describe(proc)
    runtime_include = Path(__file__).resolve().parents[2] / "runtime_c" / "include"
    dirs = ["-isystem" if "-pedantic" in flags else "-I", str(mavlink.include),
            "-isystem" if "-pedantic" in flags else "-I", str(mavlink.root)]
    cc = run(["gcc", *flags, *dirs, "-I", str(runtime_include), "-I", str(tmp_path / "out"), "-c",
              str(tmp_path / "out" / "mavcache.c"), "-o", str(tmp_path / "m.o")], cwd=tmp_path)
    assert cc.returncode == 0, describe(cc)
