"""Issue #13 acceptance on the corpora of tests/corpus (README there): a cFS-style mission tree fed
in whole, as a new user would, and a synthetic 1,000-instance / 250-type tree.

For each: `gen` succeeds (or with --keep-going lists exactly the failing inputs), the generated C
compiles with -std=c99 -pedantic -Wall -Wextra -Werror, with -std=c11, from C++, and with the
corpus's own flags, and `selftest` passes with equal digests. Time is measured by `make bench`
(bench/run.sh: selftest at 1,000 and 10,000 instances), not asserted here; the 1,000-instance test
prints its figure (`pytest -s`).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FSW = REPO / "tests" / "corpus" / "fsw"
MAKE_BIG = REPO / "tests" / "corpus" / "big" / "make_big.py"
RUNTIME_INCLUDE = REPO / "runtime_c" / "include"
SELFTEST_LINE = re.compile(r"^selftest: (C|Python) (\d+) types ok, digest ([0-9a-f]{8})$", re.MULTILINE)

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("g++") is None, reason="gcc/g++ not installed")

FSW_FLAGS = FSW.joinpath("flags.txt").read_text().split()
FSW_GEN_FLAGS = ["--std", "gnu99", *(f for f in FSW_FLAGS if not f.startswith("-std="))]
# Inputs that cannot parse on their own: two headers that need common_types.h first, one that
# needs a header the tree no longer has, and one that includes that one.
FSW_FAILING = ["apps/legacy/fsw/inc/legacy_app.h", "apps/legacy/fsw/inc/legacy_cfg.h",
               "apps/nav/fsw/src/nav_events.h", "mission_inc/msg_hdr.h"]


def uavbus(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "uavbus.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, check=False)


def describe(proc: subprocess.CompletedProcess[str]) -> str:
    return f"exit {proc.returncode}\n--- stdout\n{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}"


def compile_c(args: list[str], cwd: Path, cxx: bool = False) -> None:
    proc = subprocess.run(["g++" if cxx else "gcc", *args], cwd=cwd, capture_output=True, text=True, timeout=300,
                          check=False)
    assert proc.returncode == 0, f"{' '.join(args)}\n{proc.stderr[-4000:]}"


# ---------------------------------------------------------------------------------------------
# The cFS-style tree


@pytest.fixture(scope="module")
def fsw_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`uavbus gen` on the whole tree (a directory input) with --keep-going and the payload limit
    of a runtime built with -DUB_MAX_PAYLOAD=2048."""
    out = tmp_path_factory.mktemp("fsw")
    proc = uavbus("gen", ".", *FSW_GEN_FLAGS, "--name", "fsw", "-k", "--max-payload", "2048", "-o", str(out), cwd=FSW)
    assert proc.returncode == 3, describe(proc)  # written, but some inputs are left out
    return out


def test_fsw_every_failing_input_is_listed_with_its_include_chain() -> None:
    proc = uavbus("check", ".", *FSW_GEN_FLAGS, cwd=FSW)
    assert proc.returncode == 2, describe(proc)
    failing = sorted(re.findall(r"^(\S+): error: cannot be parsed", proc.stderr, re.M))
    assert failing == FSW_FAILING, proc.stderr
    assert "4 of 17 inputs cannot be parsed; nothing was written" in proc.stderr
    # The legacy error is attributed to the input parsed and to the header it occurred in.
    assert ("apps/legacy/fsw/inc/legacy_app.h: error: cannot be parsed (1 error):\n"
            "  In file included from apps/legacy/fsw/inc/legacy_app.h:5:\n"
            "  apps/legacy/fsw/inc/legacy_cfg.h:8: error: unknown type name 'legacy_word_t'\n") in proc.stderr


def test_fsw_keep_going_lists_exactly_the_failing_inputs(fsw_out: Path) -> None:
    proc = uavbus("check", ".", *FSW_GEN_FLAGS, "-k", "--max-payload", "2048", cwd=FSW)
    assert proc.returncode == 3, describe(proc)
    listed = re.search(r"warning: 4 of 17 inputs cannot be parsed and are not catalogued \(--keep-going\): (.*)",
                       proc.stderr)
    assert listed and listed.group(1).split(", ") == FSW_FAILING
    assert uavbus("check", ".", *FSW_GEN_FLAGS, "-k", "--exit-zero", "--max-payload", "2048", cwd=FSW).returncode == 0
    excluded = uavbus("check", ".", *FSW_GEN_FLAGS, "--max-payload", "2048", "--exclude", "apps/legacy/*",
                      "--exclude", "msg_hdr.h", "--exclude", "nav_events.h", cwd=FSW)
    assert excluded.returncode == 0, describe(excluded)


def test_fsw_catalogue_holds_every_construct(fsw_out: Path) -> None:
    doc = json.loads((fsw_out / "fsw.catalogue.json").read_text())
    names = {i["name"] for i in doc["instances"]}
    assert {"NAV_HkTlm", "NAV_Route", "NAV_AltRoutes[0]", "NAV_AltRoutes[1]", "NAV_EventLog", "NAV_Providers",
            "NAV_Limits[0]", "NAV_Limits[3]", "HK_HkTlm", "HK_MemDump", "HK_CopyTable[7]", "NAV_CfgLimits[2]",
            "SC_Rts001", "SC_Rts002", "__NavAlign"} <= names
    # One name defined in four table files: one instance per file, qualified by it.
    assert sorted(n for n in names if n.startswith("TBL_FileDef")) == [
        "TBL_FileDef@hk_cpy_tbl", "TBL_FileDef@nav_cfg_tbl", "TBL_FileDef@sc_rts001", "TBL_FileDef@sc_rts002"]
    skipped = {s["name"]: s["reason"] for s in doc["skipped_instances"]}
    assert skipped["NAV_HkTlmShadow"].startswith("static")
    assert skipped["NAV_SpareLimits"].startswith("array of unknown bound")
    assert skipped["NAV_Filter"].startswith("type defined in a .c file: 'NAV_FilterState_t'")
    assert skipped["HK_Raw"] == "union"
    assert "NAV_Limits" not in skipped  # declared [] in a header, defined [4] in nav_app.c
    types = {t["name"]: t for t in doc["types"]}
    providers = {f["name"]: f for f in types["NAV_ProviderList_t"]["fields"]}
    assert providers["Providers"]["skipped"] == "flexible array member"  # GNU `[0]`
    hk = {f["name"]: f for f in types["NAV_HkTlm_t"]["fields"]}
    assert hk["Mode"]["enum"] == "NAV_Mode_t" and hk["Fix"]["enum"] == "enum nav_fix"
    assert doc["enums"]["enum nav_fix"] == {"NAV_FIX_NONE": 0, "NAV_FIX_2D": 1, "NAV_FIX_3D": 2, "NAV_FIX_RTK": 5}
    assert (hk["SatsUsed"]["bits"], hk["ClockDrift"]["wire"]) == (6, "i16")
    assert types["HK_MemDump_t"]["packed_size"] == 1218


def test_fsw_generated_header_includes_what_defines_each_type(fsw_out: Path) -> None:
    h = (fsw_out / "fsw.h").read_text()
    includes = re.findall(r'^#include "(\S+)"', h, re.M)
    # nav_app.c's own includes, in its order, up to nav_events.h: that header needs the two before it.
    # nav_events.h sits next to nav_app.c, on no -I: by its path relative to the generated header.
    events = os.path.relpath(FSW / "apps/nav/fsw/src/nav_events.h", fsw_out)
    assert includes.index("common_types.h") < includes.index("msg_hdr.h") < includes.index(events)
    assert not any(i.endswith(".c") for i in includes)


@needs_gcc
@pytest.mark.parametrize("flags", [
    ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"],
    ["-std=c11", "-pedantic", "-Wall", "-Wextra", "-Werror"],
    "own",
], ids=["c99-pedantic", "c11-pedantic", "corpus-flags"])
def test_fsw_generated_c_compiles(fsw_out: Path, tmp_path: Path, flags: list[str] | str) -> None:
    dirs = ["mission_inc", "platform_inc", "apps/nav/fsw/inc", "apps/hk/fsw/inc", "apps/sc/fsw/inc", "apps/nav/fsw/src"]
    if flags == "own":
        # The corpus's own flags, its headers as ordinary (non-system) includes.
        args = [*FSW_FLAGS, "-Wall", "-Wextra", "-Werror", "-Iapps/nav/fsw/src"]
    else:
        # -Werror judges the generated code; the corpus's GNU extensions (zero-length arrays, uint8
        # bitfields) are its own business: its directories are system directories here.
        args = [*flags, "-DMISSION_CPU=1", *(a for d in dirs for a in ("-isystem", d))]
    args += ["-I", str(RUNTIME_INCLUDE), "-I", str(fsw_out), "-c", str(fsw_out / "fsw.c"), "-o", str(tmp_path / "fsw.o")]
    compile_c(args, FSW)


CXX_MAIN = r"""
#include "fsw.h"
#include <cstdio>
int main() {
    NAV_HkTlm_t a = NAV_HkTlm_t(), b = NAV_HkTlm_t();
    a.LatDeg = 1.5; a.ClockDrift = -3; a.Fix = NAV_FIX_RTK;
    uint8_t buf[fsw_NAV_HkTlm_t_PACKED_SIZE];
    if (fsw_pack_NAV_HkTlm_t(&a, buf, sizeof buf) != (int)sizeof buf) return 1;
    if (fsw_unpack_NAV_HkTlm_t(&b, buf, sizeof buf) != (int)sizeof buf) return 2;
    if (b.LatDeg != 1.5 || b.ClockDrift != -3 || b.Fix != NAV_FIX_RTK) return 3;
    uint8_t id[16] = fsw_ID_NAV_HkTlm;
    if (ub_catalogue_find(&fsw_catalogue, id) != (int)fsw_INST_NAV_HkTlm) return 4;
    std::printf("ok %zu\n", fsw_catalogue.json_len);
    return 0;
}
"""


@needs_gcc
def test_fsw_generated_c_is_usable_from_cxx(fsw_out: Path, tmp_path: Path) -> None:
    dirs = ["mission_inc", "platform_inc", "apps/nav/fsw/inc", "apps/hk/fsw/inc", "apps/sc/fsw/inc", "apps/nav/fsw/src"]
    common = ["-DMISSION_CPU=1", *(a for d in dirs for a in ("-isystem", d)), "-I", str(RUNTIME_INCLUDE), "-I", str(fsw_out)]
    (tmp_path / "main.cpp").write_text(CXX_MAIN)
    compile_c(["-std=c99", "-Wall", "-Werror", *common, "-c", str(fsw_out / "fsw.c"), "-o", str(tmp_path / "fsw.o")], FSW)
    compile_c(["-std=c99", "-I", str(RUNTIME_INCLUDE), "-c", str(REPO / "runtime_c/src/codec/ub_catalogue.c"),
               "-o", str(tmp_path / "cat.o")], FSW)
    compile_c(["-std=c++11", "-pedantic", "-Wall", "-Wextra", "-Werror", *common, str(tmp_path / "main.cpp"),
               str(tmp_path / "fsw.o"), str(tmp_path / "cat.o"), "-o", str(tmp_path / "main")], FSW, cxx=True)
    run = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0 and run.stdout.startswith("ok "), run.stdout + run.stderr
    assert int(run.stdout.split()[1]) > 4095  # the embedded catalogue is past C99's string-literal bound


@needs_gcc
@pytest.mark.parametrize("strings", [[], ["--strings", "bytes"]], ids=["paper-strings", "strings-as-bytes"])
def test_fsw_selftest(strings: list[str]) -> None:
    proc = uavbus("selftest", ".", *FSW_GEN_FLAGS, "--name", "fsw", "--max-payload", "2048", *strings,
                  "--exclude", "apps/legacy/*", "--exclude", "msg_hdr.h", "--exclude", "nav_events.h", cwd=FSW)
    assert proc.returncode == 0, describe(proc)
    found = dict((lang, (n, d)) for lang, n, d in SELFTEST_LINE.findall(proc.stdout))
    assert set(found) == {"C", "Python"} and found["C"] == found["Python"], proc.stdout


def test_fsw_python_names_for_names_python_cannot_take(fsw_out: Path) -> None:
    code = ("import fsw; c = fsw.C__nav_align(Word=1, lambda_=2, m__pad=3); b = c.pack(); "
            "print(fsw.C__nav_align.unpack(b).to_dict())")
    run = subprocess.run([sys.executable, "-c", code], cwd=fsw_out, capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "{'Word': 1, 'lambda': 2, '__pad': 3}"


# ---------------------------------------------------------------------------------------------
# 1,000 instances of 250 types


@needs_gcc
def test_selftest_at_scale_1000_instances_250_types(tmp_path: Path) -> None:
    subprocess.run([sys.executable, str(MAKE_BIG), str(tmp_path / "big"), "--instances", "1000", "--types", "250"],
                   check=True, timeout=60)
    started = time.monotonic()
    proc = uavbus("selftest", "big/big_all.h", "-I", "big/include", "--name", "big", "-v", cwd=tmp_path, timeout=600)
    elapsed = time.monotonic() - started
    assert proc.returncode == 0, describe(proc)
    found = dict((lang, (int(n), d)) for lang, n, d in SELFTEST_LINE.findall(proc.stdout))
    assert found["C"] == found["Python"] and found["C"][0] >= 250, proc.stdout
    print(f"selftest of 1,000 instances / {found['C'][0]} types: {elapsed:.1f} s (os.cpu_count() = {os.cpu_count()})")
