"""Issue #30 acceptance: the generator on firmware as it is really built, on the corpora of
tests/corpus (README there): const members, a directory input holding a header named like a system
header, a Cortex-M4 tree parsed and built with arm-none-eabi-gcc and its self-test run under qemu-arm,
a -m32 self-test, a UAVObject-style types-only tree catalogued by pattern, and an empty catalogue.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from uavbus_gen.cli import RUNTIME_CATALOGUE_C

REPO = Path(__file__).resolve().parents[2]
CORPUS = REPO / "tests" / "corpus"
RUNTIME_INCLUDE = REPO / "runtime_c" / "include"
SELFTEST_LINE = re.compile(r"^selftest: (C|Python) (\d+) types ok, digest ([0-9a-f]{8})$", re.MULTILINE)
STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-Wcast-qual"]

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")


def uavbus(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "uavbus.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, check=False)


def describe(proc: subprocess.CompletedProcess[str]) -> str:
    return f"exit {proc.returncode}\n--- stdout\n{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}"


def run(cmd: list[str], cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, check=False)


def digests(proc: subprocess.CompletedProcess[str]) -> dict[str, tuple[str, str]]:
    """{'C': (types, digest), 'Python': (...)} from a selftest's output."""
    return {lang: (n, d) for lang, n, d in SELFTEST_LINE.findall(proc.stdout)}


def assert_selftest_passed(proc: subprocess.CompletedProcess[str], types: int) -> None:
    assert proc.returncode == 0, describe(proc)
    found = digests(proc)
    assert set(found) == {"C", "Python"} and found["C"] == found["Python"], proc.stdout
    assert int(found["C"][0]) == types, proc.stdout


# ---------------------------------------------------------------------------------------------
# Const members


CONST = CORPUS / "const"


@needs_gcc
def test_const_members_generated_c_compiles_strict(tmp_path: Path) -> None:
    proc = uavbus("gen", ".", "--name", "cst", "-o", str(tmp_path), cwd=CONST)
    assert proc.returncode == 0, describe(proc)
    dirs = [a for d in ("settings", "tasks", "leds") for a in ("-I", str(CONST / d))]
    comp = run(["gcc", *STRICT, "-I", str(RUNTIME_INCLUDE), *dirs, "-c", str(tmp_path / "cst.c"),
                "-o", str(tmp_path / "cst.o")], tmp_path)
    assert comp.returncode == 0, comp.stderr[-4000:]
    # No assignment through a const member anywhere: every const scalar goes through the byte writer.
    c = (tmp_path / "cst.c").read_text()
    assert "memcpy(cst_RO_ADDR(obj, obj->type), &v, sizeof v);" in c
    assert "obj->type =" not in c and "obj->range.min =" not in c


def test_const_bitfield_is_skipped_with_its_reason(tmp_path: Path) -> None:
    proc = uavbus("gen", ".", "--name", "cst", "-o", str(tmp_path), cwd=CONST)
    assert proc.returncode == 0, describe(proc)
    doc = json.loads((tmp_path / "cst.catalogue.json").read_text())
    fields = {f["name"]: f for t in doc["types"] if t["name"] == "task_attr_t" for f in t["fields"]}
    assert fields["core"]["skipped"].startswith("const bitfield")
    assert fields["spare"]["bits"] == 6 and fields["period_us"]["wire"] == "u32"
    assert "1 const bitfield" in proc.stderr


@needs_gcc
def test_const_members_selftest_round_trips() -> None:
    # The C self-test unpacks into a fresh object and compares every member, const ones included.
    proc = uavbus("selftest", ".", "--name", "cst", "-j", "2", cwd=CONST)
    assert_selftest_passed(proc, 5)


# ---------------------------------------------------------------------------------------------
# A header named like a system header, in a directory input


SHADOW = CORPUS / "shadow"


@needs_gcc
def test_shadowing_header_does_not_hide_the_system_one_in_selftest() -> None:
    # baro.h includes <pthread.h> and <time.h> (the C library's: struct tm) and "../common/time.h" (its own).
    proc = uavbus("selftest", ".", "--name", "shadow", "-j", "2", cwd=SHADOW)
    assert_selftest_passed(proc, 4)  # baro_sample_t, os_time_t, struct timespec, struct tm
    assert "-isystem" not in proc.stderr


@needs_gcc
def test_directory_input_compiles_without_any_input_folder_on_the_path(tmp_path: Path) -> None:
    out = tmp_path / "gen"
    proc = uavbus("gen", ".", "--name", "shadow", "-o", str(out), cwd=SHADOW)
    assert proc.returncode == 0, describe(proc)
    includes = re.findall(r'^#include "(\S+)"', (out / "shadow.h").read_text(), re.M)
    assert includes[-1] == os.path.relpath(SHADOW / "sensors" / "baro.h", out)
    # Only the runtime and the output directory: no -I of the inputs' folders.
    comp = run(["gcc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-I", str(RUNTIME_INCLUDE), "-I", str(out), "-c",
                str(out / "shadow.c"), "-o", str(tmp_path / "shadow.o")], tmp_path)
    assert comp.returncode == 0, comp.stderr[-4000:]


# ---------------------------------------------------------------------------------------------
# A Cortex-M4 firmware tree and its cross compiler


M4 = CORPUS / "m4fw"
M4_FLAGS = M4.joinpath("flags.txt").read_text().split()
ARM_CC = "arm-none-eabi-gcc"
needs_arm = pytest.mark.skipif(shutil.which(ARM_CC) is None, reason="arm-none-eabi-gcc not installed (make setup)")


@pytest.fixture(scope="module")
def m4_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which(ARM_CC) is None:
        pytest.skip("arm-none-eabi-gcc not installed (make setup)")
    out = tmp_path_factory.mktemp("m4")
    proc = uavbus("gen", ".", "--name", "m4", "--target-cc", ARM_CC, "-o", str(out), "--", *M4_FLAGS, cwd=M4)
    assert proc.returncode == 0, describe(proc)
    return out


def arm_compile(out: Path, extra: list[str]) -> subprocess.CompletedProcess[str]:
    return run([ARM_CC, *M4_FLAGS, *extra, "-Wall", "-Wextra", "-Werror", "-I", str(RUNTIME_INCLUDE), "-I", str(out),
                "-c", str(out / "m4.c"), "-o", str(out / "m4.o")], out)


@needs_arm
def test_m4_tree_is_parsed_with_the_target_abi(m4_out: Path) -> None:
    doc = json.loads((m4_out / "m4.catalogue.json").read_text())
    types = {t["name"]: t for t in doc["types"]}
    fields = {f["name"]: f for f in types["attitude_state_t"]["fields"]}
    # The EABI's one-byte enums: `armed` right after `mode`; clang's host default would say 4.
    assert (fields["mode"]["wire"], fields["armed"]["offset"], fields["loop_hz"]["offset"]) == ("u8", 1, 2)
    assert fields["home_lat"]["offset"] % 8 == 0
    assert {i["name"] for i in doc["instances"]} == {"attitude_state", "attitude_setpoints[0]",
                                                     "attitude_setpoints[1]", "imu_latest", "param_rate_p"}


@needs_arm
def test_m4_generated_c_compiles_with_the_firmware_compiler_and_flags(m4_out: Path) -> None:
    # Every layout assertion holds under arm-none-eabi-gcc; no -I of the tree's folders is needed.
    proc = arm_compile(m4_out, [])
    assert proc.returncode == 0, proc.stderr[-4000:]


@needs_arm
def test_m4_layout_mismatch_names_the_abi_flag(m4_out: Path) -> None:
    proc = arm_compile(m4_out, ["-fno-short-enums"])
    assert proc.returncode != 0
    assert "attitude_state_t.armed: offset differs from the catalogue" in proc.stderr
    assert "enum size (-fshort-enums)" in proc.stderr and "--target-cc" in proc.stderr
    assert "parsed with (arm-none-eabi-gcc (arm-none-eabi); check:" in proc.stderr  # whose layout it holds
    assert "; regenerate\"" not in proc.stderr


@needs_arm
def test_m4_host_parse_is_refused() -> None:
    # Without the target the tree does not parse (it refuses any other target), as its build would.
    host = uavbus("check", ".", "-DSTM32F405xx", cwd=M4)
    assert host.returncode == 2 and "build for a Cortex-M4F" in host.stderr, describe(host)



def m32_args(tmp_path: Path) -> list[str]:
    """`-m32`, and where Debian's gcc-multilib is not installed (it conflicts with the cross compilers that
    `make test-cross` needs, so `make setup` installs only its 32-bit libraries: lib32gcc-12-dev and
    libc6-dev-i386) the one thing it adds for -m32: `asm/` headers on the include path. x86's are one set for
    both word sizes (they test __i386__ themselves); gcc-multilib's /usr/include/asm is the same link."""
    if Path("/usr/include/asm").exists() or not Path("/usr/include/x86_64-linux-gnu/asm").is_dir():
        return ["-m32"]
    inc = tmp_path / "m32-include"
    inc.mkdir(exist_ok=True)
    if not (inc / "asm").exists():
        (inc / "asm").symlink_to("/usr/include/x86_64-linux-gnu/asm")
    return ["-m32", "-isystem", str(inc)]


@needs_gcc
def test_abi_flag_no_macro_reveals_is_caught_before_parsing(tmp_path: Path) -> None:
    # A compiler (wrapper) that aligns doubles to 8 in i386 structs: no predefined macro tells, so
    # the probe that the compiler checks against clang's values catches it and names the flag.
    if run(["gcc", "-m32", "-E", "-x", "c", os.devnull], tmp_path).returncode != 0:
        pytest.skip("gcc -m32 not available (lib32gcc-12-dev, libc6-dev-i386: make setup installs them)")
    wrapper = tmp_path / "cc.sh"
    wrapper.write_text('#!/bin/sh\nexec gcc -malign-double "$@"\n')
    wrapper.chmod(0o755)
    wrong = uavbus("check", ".", "--target-cc", str(wrapper), "--", *m32_args(tmp_path), cwd=CONST)
    assert wrong.returncode == 2, describe(wrong)
    assert "lay types out differently: " in wrong.stderr
    assert "double alignment in structs: clang 4 (-malign-double / -m32)" in wrong.stderr
    assert "enum size" not in wrong.stderr and "char signedness" not in wrong.stderr
    right = uavbus("check", ".", "--target-cc", str(wrapper), "--", *m32_args(tmp_path), "-malign-double", cwd=CONST)
    assert right.returncode == 0, describe(right)


@needs_arm
def test_m4_selftest_runs_under_qemu_arm_or_says_why_not() -> None:
    proc = uavbus("selftest", ".", "--name", "m4", "-j", "2", "--target-cc", ARM_CC, "--", *M4_FLAGS, cwd=M4)
    if shutil.which("qemu-arm") is None:
        # The documented skip: built with the firmware's compiler (layout assertions held), not run.
        assert proc.returncode == 0, describe(proc)
        assert "selftest: C 5 types built (arm-none-eabi), run skipped: qemu-arm is not installed" in proc.stdout
        pytest.skip("qemu-arm not installed: the C self-test was built but not run (make setup installs qemu-user)")
    assert_selftest_passed(proc, 5)


@pytest.mark.parametrize("cc,emulator", [("arm-linux-gnueabihf-gcc", "qemu-arm"), ("s390x-linux-gnu-gcc", "qemu-s390x")],
                         ids=["armhf", "s390x"])
def test_linux_cross_target_selftest_runs_under_its_emulator(cc: str, emulator: str) -> None:
    # A Linux target of another architecture (32-bit ARM hard-float; 64-bit big-endian) runs under its
    # qemu user-mode emulator with the cross toolchain's sysroot: the C digest equals Python's, so the
    # codecs' byte order holds on a big-endian target, not only the layout assertions.
    if shutil.which(cc) is None or shutil.which(emulator) is None:
        pytest.skip(f"{cc} or {emulator} not installed (make setup installs them for make test-cross)")
    proc = uavbus("selftest", ".", "--name", "cst", "-j", "2", "--target-cc", cc, cwd=CONST)
    assert_selftest_passed(proc, 5)
    assert "run skipped" not in proc.stdout


# ---------------------------------------------------------------------------------------------
# -m32


@needs_gcc
def test_m32_selftest_links_and_runs(tmp_path: Path) -> None:
    if subprocess.run(["gcc", "-m32", "-x", "c", "-", "-o", os.devnull], input="int main(void){return 0;}",
                      capture_output=True, text=True, check=False).returncode != 0:
        pytest.skip("gcc cannot link -m32 here (lib32gcc-12-dev, libc6-dev-i386: make setup installs them)")
    proc = uavbus("selftest", ".", "--name", "cst32", "-j", "2", "--target-cc", "gcc", "--", *m32_args(tmp_path),
                  cwd=CONST)
    assert_selftest_passed(proc, 5)


# ---------------------------------------------------------------------------------------------
# Handle-based object systems (UAVObject style): types in headers, objects made at run time


UAVO = CORPUS / "uavobjects"
UAVO_NAMES = ["AttitudeState", "FlightStatus", "GPSPositionSensor", "ManualControlCommand", "SystemAlarms"]


def test_types_only_tree_says_how_many_types_and_why_no_instance() -> None:
    proc = uavbus("check", ".", cwd=UAVO)
    assert proc.returncode == 0, describe(proc)
    assert "check: 0 instances of 0 types (7 struct types seen in the inputs, none with an instance" in proc.stdout
    assert "--instance-per-type 'REGEX' or --instances-from FILE" in proc.stderr


def test_types_only_tree_catalogued_by_pattern(tmp_path: Path) -> None:
    proc = uavbus("gen", ".", "--instance-per-type", r"(\w+)Data", "--name", "uavo", "-o", str(tmp_path), cwd=UAVO)
    assert proc.returncode == 0, describe(proc)
    doc = json.loads((tmp_path / "uavo.catalogue.json").read_text())
    assert sorted(i["name"] for i in doc["instances"]) == UAVO_NAMES
    # The manager's own types (UAVObjEvent, UAVObjMetadata) do not match the pattern in full.
    assert sorted(t["name"] for t in doc["types"]) == sorted(n + "Data" for n in UAVO_NAMES)
    # The packed sizes add up to the objects' NUMBYTES (packed structs: sizeof each).
    assert sum(t["packed_size"] for t in doc["types"]) == sum(t["size"] for t in doc["types"]) == 28 + 6 + 42 + 40 + 30
    c = (tmp_path / "uavo.c").read_text()
    assert c.count("created at run time (handle-based): bind its storage with ub_node_bind()") == 5


@needs_gcc
def test_types_only_tree_selftest_c_equals_python() -> None:
    proc = uavbus("selftest", ".", "--instance-per-type", r"(\w+)Data", "--name", "uavo", "-j", "2", cwd=UAVO)
    assert_selftest_passed(proc, 5)


@needs_gcc
def test_types_only_tree_generated_c_compiles_and_binds_at_run_time(tmp_path: Path) -> None:
    out = tmp_path / "gen"
    proc = uavbus("gen", ".", "--instance-per-type", r"(\w+)Data", "--name", "uavo", "-o", str(out), cwd=UAVO)
    assert proc.returncode == 0, describe(proc)
    (tmp_path / "main.c").write_text(
        '#include "uavo.h"\n#include <stdio.h>\n'
        "int main(void) {\n"
        "    if (uavo_storage[uavo_INST_AttitudeState] != NULL) return 1; /* no C object: bound at run time */\n"
        "    AttitudeStateData a = {0}, b = {0};\n"
        "    a.Roll = 1.5f; a.q4 = -2.0f;\n"
        "    uint8_t buf[uavo_AttitudeStateData_PACKED_SIZE];\n"
        "    if (uavo_pack_AttitudeStateData(&a, buf, sizeof buf) != 28) return 2;\n"
        "    if (uavo_unpack_AttitudeStateData(&b, buf, sizeof buf) != 28 || b.Roll != 1.5f || b.q4 != -2.0f) return 3;\n"
        "    printf(\"%u\\n\", (unsigned)uavo_N_INSTANCES);\n"
        "    return 0;\n}\n")
    exe = tmp_path / "main"
    # The runtime's catalogue code, where the self-test takes it from.
    comp = run(["gcc", *STRICT, "-I", str(RUNTIME_INCLUDE), "-I", str(out), str(tmp_path / "main.c"), str(out / "uavo.c"),
                str(RUNTIME_CATALOGUE_C), "-o", str(exe)], tmp_path)
    assert comp.returncode == 0, comp.stderr[-4000:]
    ran = run([str(exe)], tmp_path)
    assert ran.returncode == 0 and ran.stdout.strip() == "5", ran.stdout + ran.stderr


def test_instances_from_a_list_and_its_errors(tmp_path: Path) -> None:
    proc = uavbus("check", ".", "--instances-from", "instances.txt", cwd=UAVO)
    assert proc.returncode == 0, describe(proc)
    assert "check: 3 instances of 3 types" in proc.stdout
    bad = tmp_path / "bad.txt"
    bad.write_text("# objects\nAttitudeState AttitudeStateData\nGps GPSPositionSensorDat\n")
    proc = uavbus("check", ".", "--instances-from", str(bad), cwd=UAVO)
    assert proc.returncode == 2, describe(proc)
    assert f"{bad}:3: error: 'GPSPositionSensorDat' is not a struct type the inputs define " \
           "(did you mean GPSPositionSensorData?)" in proc.stderr
    nomatch = uavbus("check", ".", "--instance-per-type", r"(\w+)State", cwd=UAVO)
    assert "--instance-per-type '(\\w+)State' matches no struct type in full (7 types seen" in nomatch.stderr


# ---------------------------------------------------------------------------------------------
# Heterogeneous fleets (docs/catalogue.md): fingerprints differ across ABIs unless widths are fixed


@needs_gcc
def test_fleet_fingerprints_differ_for_long_and_agree_for_fixed_width(tmp_path: Path) -> None:
    if run(["gcc", "-m32", "-E", "-x", "c", os.devnull], tmp_path).returncode != 0:
        pytest.skip("gcc -m32 not available (lib32gcc-12-dev, libc6-dev-i386: make setup installs them)")
    (tmp_path / "fleet.h").write_text(
        "#include <stdint.h>\n"
        "struct portable { int32_t a; uint64_t t; double d; uint8_t mode; };\n"
        "struct native { long a; uint64_t t; double d; };\n"
        "extern struct portable fleet_portable;\nextern struct native fleet_native;\n")

    def fingerprints(*extra: str) -> dict[str, str]:
        out = tmp_path / ("o" + "".join(extra).replace("-", "_"))
        proc = uavbus("gen", "fleet.h", "-o", str(out), *extra, cwd=tmp_path)
        assert proc.returncode == 0, describe(proc)
        doc = json.loads((out / "catalogue.catalogue.json").read_text())
        return {t["name"]: t["fingerprint"] for t in doc["types"]}

    host, i386 = fingerprints(), fingerprints("--target-cc", "gcc", "--", *m32_args(tmp_path))
    assert host["struct portable"] == i386["struct portable"]
    assert host["struct native"] != i386["struct native"]


# ---------------------------------------------------------------------------------------------
# The compiler is chosen


@needs_gcc
def test_selftest_builds_and_links_with_the_chosen_compiler(tmp_path: Path) -> None:
    log = tmp_path / "cc.log"
    wrapper = tmp_path / "mycc"
    wrapper.write_text(f'#!/bin/sh\necho "$@" >> {log}\nexec gcc "$@"\n')
    wrapper.chmod(0o755)
    proc = uavbus("selftest", ".", "--name", "cst", "-j", "2", "--cc", str(wrapper), "--", "-DUB_SELFTEST_MARK=1",
                  cwd=CONST)
    assert_selftest_passed(proc, 5)
    calls = log.read_text().splitlines()
    compiles = [c for c in calls if " -c " in f" {c} "]
    links = [c for c in calls if " -c " not in f" {c} " and "-o" in c.split() and "-dM" not in c]
    assert len(compiles) >= 3 and len(links) == 1, calls
    assert all("-DUB_SELFTEST_MARK=1" in c for c in compiles + links)  # `--` arguments reach the link too
    assert not any("-isystem" in c for c in compiles)


@needs_arm
def test_cross_compiler_named_by_compile_commands_is_the_target(tmp_path: Path) -> None:
    db = tmp_path / "compile_commands.json"
    # As CMake writes it for a build that uses a compiler launcher.
    db.write_text(json.dumps([{"directory": str(M4), "file": "flight/flight.c",
                               "command": f"ccache {ARM_CC} {' '.join(M4_FLAGS)} -c flight/flight.c -o flight.o"}]))
    proc = uavbus("check", ".", "--compile-commands", str(db), cwd=M4)
    assert proc.returncode == 0, describe(proc)
    assert f"note: parsing with the ABI of {ARM_CC}, the compiler of {db} (--target-cc)" in proc.stderr
    assert "check: 5 instances of 5 types" in proc.stdout


@needs_gcc
def test_target_no_emulator_runs_is_built_and_its_run_stated_as_skipped(tmp_path: Path) -> None:
    # A compiler that says it targets bare-metal AArch64 (it builds with gcc underneath): nothing here
    # can run that, so the self-test is built (layout assertions checked) and the run skipped, saying why.
    wrapper = tmp_path / "aarch64-none-elf-gcc"
    wrapper.write_text('#!/bin/sh\n'
                       'case "$*" in\n'
                       '  -dumpmachine) echo aarch64-none-elf; exit 0;;\n'
                       '  *-dM*) gcc "$@" | grep -v -e __linux__ -e __x86_64__ -e __i386__; echo "#define __aarch64__ 1";'
                       ' exit 0;;\n'
                       'esac\n'
                       'exec gcc "$@"\n')
    wrapper.chmod(0o755)
    proc = uavbus("selftest", ".", "--name", "cst", "-j", "2", "--cc", str(wrapper), cwd=CONST)
    assert proc.returncode == 0, describe(proc)
    assert ("selftest: C 5 types built (aarch64-none-elf), run skipped: aarch64-none-elf is bare metal and only "
            "bare-metal little-endian ARM with newlib runs under qemu user mode here") in proc.stdout
    assert re.search(r"^selftest: Python 5 types ok, digest [0-9a-f]{8}$", proc.stdout, re.M)
    assert "every layout assertion held" in proc.stderr


@needs_arm
def test_gcc_only_flags_of_the_firmware_build_are_left_out_of_parsing_only() -> None:
    gcc_only = ["-mno-thumb-interwork", "-fno-tree-loop-distribute-patterns"]
    before = sorted(M4.rglob("*"))
    # -fstack-usage makes the compiler write a .su file: never into the user's tree.
    proc = uavbus("check", ".", "--target-cc", ARM_CC, "--", *M4_FLAGS, *gcc_only, "-fstack-usage", cwd=M4)
    assert proc.returncode == 0, describe(proc)
    assert sorted(M4.rglob("*")) == before
    assert f"note: clang does not know {', '.join(gcc_only)} (flags of {ARM_CC}): left out of parsing" in proc.stderr


# ---------------------------------------------------------------------------------------------
# A build described only by compile_commands.json (betaflight style: make's flags, -Werror, -MMD,
# GCC-only flags in some entries only, `#pragma once` headers, instances from macros)


PGFW = CORPUS / "pgfw"


def pgfw_compile_commands(tmp_path: Path) -> Path:
    """compile_commands.json for the pgfw tree as make writes it (one entry per .c, arguments form)."""
    build = json.loads((PGFW / "build.json").read_text())
    entries = [{"directory": str(PGFW), "file": e["file"],
                "arguments": [ARM_CC, "-c", "-o", f"obj/{e['file']}.o", *build["common"], *e["flags"], e["file"]]}
               for e in build["entries"]]
    db = tmp_path / "compile_commands.json"
    db.write_text(json.dumps(entries, indent=1))
    return db


@needs_arm
def test_compile_commands_build_parses_with_every_entrys_flags(tmp_path: Path) -> None:
    db = pgfw_compile_commands(tmp_path)
    before = sorted(PGFW.rglob("*"))
    proc = uavbus("check", ".", "--compile-commands", str(db), "--id-scheme", "hashed", cwd=PGFW)
    # -Werror is the build compiler's: clang's own warnings (`#pragma once in main file` for each header
    # parsed alone) fail no input; the GCC-only flags of the second entry (pid.c) alone are found too.
    assert proc.returncode == 0, describe(proc)
    assert "check: 8 instances of 3 types" in proc.stdout
    assert (f"note: clang does not know -fuse-linker-plugin, -Wunsafe-loop-optimizations (flags of {ARM_CC}): "
            "left out of parsing") in proc.stderr
    assert "error" not in proc.stderr.replace("-Werror", "")
    # -MMD -MP make clang write a .d file per input: never into the user's tree.
    assert sorted(PGFW.rglob("*")) == before


@needs_arm
def test_compile_commands_build_generated_c_compiles_with_the_builds_own_flags(tmp_path: Path) -> None:
    db = pgfw_compile_commands(tmp_path)
    out = tmp_path / "gen"
    proc = uavbus("gen", ".", "--compile-commands", str(db), "--id-scheme", "hashed", "--name", "pg", "-o", str(out),
                  cwd=PGFW)
    assert proc.returncode == 0, describe(proc)
    doc = json.loads((out / "pg.catalogue.json").read_text())
    gyro = {f["name"]: f for t in doc["types"] if t["name"] == "struct gyroConfig_s" for f in t["fields"]}
    assert gyro["lpf_mode"]["wire"] == "u8" and gyro["gyro_lpf1_static_hz"]["offset"] == 2  # the EABI's short enums
    # The first entry's command line, -Werror -Wextra -Wdouble-promotion included: every layout assertion holds.
    entry = json.loads(db.read_text())[0]["arguments"]
    flags = [a for a in entry[1:-1] if a != "-c"]
    del flags[flags.index("-o"):flags.index("-o") + 2]
    comp = run([ARM_CC, *flags, "-I", str(RUNTIME_INCLUDE), "-I", str(out), "-c", str(out / "pg.c"),
                "-o", str(tmp_path / "pg.o")], PGFW)
    assert comp.returncode == 0, comp.stderr[-4000:]


@needs_arm
def test_compile_commands_build_selftest_builds_with_the_entrys_flags(tmp_path: Path) -> None:
    # No flags after `--`: the self-test compiles and links with the first entry's (-mcpu, -mfloat-abi, -D,
    # -I: target.h refuses any other build), without its -O/-Werror/-flto/-MMD, and runs under qemu-arm.
    db = pgfw_compile_commands(tmp_path)
    proc = uavbus("selftest", ".", "--compile-commands", str(db), "--id-scheme", "hashed", "--name", "pg", "-j", "2",
                  cwd=PGFW)
    if shutil.which("qemu-arm") is None:
        assert proc.returncode == 0 and "run skipped: qemu-arm is not installed" in proc.stdout, describe(proc)
        pytest.skip("qemu-arm not installed: the C self-test was built but not run (make setup installs qemu-user)")
    assert_selftest_passed(proc, 3)
