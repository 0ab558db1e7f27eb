"""Content and entity IDs: the paper's rule at every interesting length, the hashed scheme, and
agreement with the C runtime's ub_dir_id_paper()."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from gen_testutil import RUNTIME_INCLUDE, REPO, gcc, needs_gcc

from uavbus_gen import ids

ALPHA = "abcdefghijklmnopqrstuvwxyz0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ"


def name_of(n: int) -> str:
    return (ALPHA * 2)[:n]


def test_paper_example_onboardSet() -> None:
    assert ids.dir_id_paper("onboardSet") == b"onboardSboardSet"


@pytest.mark.parametrize(
    "length, expected",
    [
        (1, b"a\0\0\0\0\0\0\0a\0\0\0\0\0\0\0"),
        (7, b"abcdefg\0abcdefg\0"),
        (8, b"abcdefghabcdefgh"),
        (15, b"abcdefghhijklmno"),
        (16, b"abcdefghijklmnop"),
        (17, b"abcdefghjklmnopq"),
        (80, b"abcdefghklmnopqr"),
    ],
)
def test_paper_rule_lengths(length: int, expected: bytes) -> None:
    name = name_of(length)
    got = ids.dir_id_paper(name)
    assert len(got) == 16
    assert got == expected
    if length >= 8:
        assert got == (name[:8] + name[-8:]).encode()


def test_length_80_uses_first_and_last_eight() -> None:
    name = name_of(80)
    assert ids.dir_id_paper(name) == (name[:8] + name[-8:]).encode()
    assert name[-8:] != name[8:16]  # the test name really has a distinct tail


def test_gps_padding() -> None:
    assert ids.dir_id_paper("gps") == b"gps\0\0\0\0\0gps\0\0\0\0\0"


def test_array_element_names() -> None:
    assert ids.dir_id_paper("waypoints[3]") == b"waypointoints[3]"
    assert ids.dir_id_paper("grid[1][2]") == b"grid[1][id[1][2]"


def test_crc16_ccitt_false_check_value() -> None:
    assert ids.crc16_ccitt_false(b"123456789") == 0x29B1


def test_hashed_scheme_layout() -> None:
    name = "currentSensorADCConfig_System"
    got = ids.dir_id_hashed(name)
    crc = ids.crc16_ccitt_false(name.encode())
    assert got[:7] == b"current" and got[7:14] == b"_System"
    assert got[14:] == bytes((crc & 0xFF, crc >> 8))
    assert ids.dir_id_hashed("gps")[:14] == b"gps\0\0\0\0gps\0\0\0\0"


def test_hashed_separates_what_paper_merges() -> None:
    a, b = "currentSensorADCConfig_System", "currentSensorVirtualConfig_System"
    assert ids.dir_id_paper(a) == ids.dir_id_paper(b)
    assert ids.dir_id_hashed(a) != ids.dir_id_hashed(b)


def test_entity_id() -> None:
    assert ids.entity_id("rmax1ob1") == b"rmax1ob1\0\0\0\0"
    assert ids.entity_id("twelve_chars") == b"twelve_chars"
    with pytest.raises(ids.IdError, match="at most 12"):
        ids.entity_id("thirteen_char")
    with pytest.raises(ids.IdError):
        ids.entity_id("")


def test_unknown_scheme() -> None:
    with pytest.raises(ids.IdError, match="unknown ID scheme"):
        ids.dir_id("x", "md5")


@needs_gcc
def test_python_rule_matches_c_runtime(tmp_path: Path) -> None:
    names = ["onboardSet", "gps", "x"] + [name_of(n) for n in (1, 7, 8, 15, 16, 17, 80)] + ["grid[1][2]"]
    prog = tmp_path / "ids.c"
    calls = "\n".join(f'    show("{n}");' for n in names)
    prog.write_text(
        '#include <stdio.h>\n#include "ub/ub_catalogue.h"\n'
        "static void show(const char *n) { uint8_t id[16]; ub_dir_id_paper(n, id);\n"
        '    for (int i = 0; i < 16; i++) printf("%02x", id[i]);\n'
        '    printf("\\n");\n}\n'
        f"int main(void) {{\n{calls}\n    return 0;\n}}\n"
    )
    build = gcc(["-std=c11", "-Wall", "-Wextra", "-Werror", "-I", str(RUNTIME_INCLUDE), str(prog),
                 str(REPO / "runtime_c" / "src" / "codec" / "ub_catalogue.c"), "-o", "ids"], tmp_path)
    assert build.returncode == 0, build.stderr
    out = subprocess.run([str(tmp_path / "ids")], capture_output=True, text=True, check=True).stdout.split()
    assert out == [ids.dir_id_paper(n).hex() for n in names]
