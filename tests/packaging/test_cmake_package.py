"""The CMake package, as another project uses it (issue 14, item 2; issue 29, item 5).

- A separate consumer project (tests/packaging/consumer: its own header, uavbus_generate(), two nodes over
  a memlink, the GCS requiring signed frames) is configured, built and run four ways: find_package(uavbus)
  after `cmake --install` of a packager's tests-off build and of a default (tests on) build,
  add_subdirectory(<uavbus>) and FetchContent. pkg-config finds libsodium and nothing else, so none can need
  cmocka, and the consumer's build must not contain uavbus's tests or examples. Each consumer must sign: its
  value arrives in a verified SIGNED frame and a changed tag is refused (`consumer --require-security`).
- The core alone cross-compiles for a Cortex-M4F (examples/mcu, arm-none-eabi-gcc + newlib), links into a
  firmware image, and contains none of the POSIX parts.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CONSUMER = REPO / "tests" / "packaging" / "consumer"
PYTHON = sys.executable
EXPECTED = "consumer: attitudeOut delivered signed, verified (roll 0.1, pitch -0.2, yaw 1.5, mode 3)"


def no_cmocka_env() -> dict[str, str]:
    """pkg-config that finds no package at all: a configure step that asks for cmocka (or libsodium) fails."""
    env = dict(os.environ)
    env["PKG_CONFIG_LIBDIR"] = "/nonexistent"
    env["PKG_CONFIG_PATH"] = ""
    return env


def sodium_only_env(tmp_path: Path) -> dict[str, str]:
    """pkg-config that finds libsodium (frame security) and nothing else: no cmocka."""
    pcdir = run(["pkg-config", "--variable", "pcfiledir", "libsodium"]).strip()
    only = tmp_path / "pkgconfig-sodium-only"
    only.mkdir(exist_ok=True)
    shutil.copy(Path(pcdir) / "libsodium.pc", only / "libsodium.pc")
    env = dict(os.environ)
    env["PKG_CONFIG_LIBDIR"] = str(only)
    env["PKG_CONFIG_PATH"] = ""
    return env


def run(cmd: list[str], env: dict[str, str] | None = None, cwd: Path | None = None) -> str:
    proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env, cwd=cwd, timeout=600)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def ninja_targets(build: Path) -> str:
    return run(["ninja", "-C", build, "-t", "targets", "all"])


def build_consumer(consumer: Path, build: Path, env: dict[str, str], *defs: str) -> Path:
    run(["cmake", "-S", consumer, "-B", build, "-G", "Ninja", f"-DUAVBUS_PYTHON={PYTHON}", *defs], env)
    run(["cmake", "--build", build], env)
    assert run([build / "consumer", "--require-security"]).strip() == EXPECTED
    return build


def check_installed(prefix: Path) -> None:
    assert (prefix / "lib" / "libub.a").is_file()
    assert (prefix / "include" / "ub" / "ub_node.h").is_file()
    for f in ("uavbus-config.cmake", "uavbus-config-version.cmake", "uavbus.cmake", "uavbusTargets.cmake"):
        assert (prefix / "lib" / "cmake" / "uavbus" / f).is_file(), f
    config = (prefix / "lib" / "cmake" / "uavbus" / "uavbus-config.cmake").read_text()
    assert "set(UAVBUS_SECURITY ON)" in config


def consumer_copy(tmp_path: Path) -> Path:
    """The consumer project copied out of the tree, so only the prefix (or the given checkout) can serve."""
    consumer = tmp_path / "consumer-src"
    shutil.copytree(CONSUMER, consumer)
    return consumer


def test_consumer_of_a_packagers_tests_off_install_signs(tmp_path: Path) -> None:
    env = sodium_only_env(tmp_path)
    consumer = consumer_copy(tmp_path)
    # uavbus built and installed on its own, as a packager would (no tests: no cmocka needed). Security is
    # its own option: the tests-off library signs as the test build's does.
    prefix = tmp_path / "prefix"
    run(["cmake", "-S", REPO, "-B", tmp_path / "uavbus-build", "-G", "Ninja", "-DUAVBUS_BUILD_TESTS=OFF",
         "-DUAVBUS_BUILD_EXAMPLES=OFF", f"-DCMAKE_INSTALL_PREFIX={prefix}"], env)
    run(["cmake", "--build", tmp_path / "uavbus-build"], env)
    run(["cmake", "--install", tmp_path / "uavbus-build"], env)
    check_installed(prefix)

    # The consumer against the installed package: find_package(uavbus 0.1 CONFIG REQUIRED) finds libsodium
    # for it (find_dependency + pkg-config): the documented three lines and nothing else.
    b1 = build_consumer(consumer, tmp_path / "consumer-installed", env, f"-DCMAKE_PREFIX_PATH={prefix}")
    cache = (b1 / "CMakeCache.txt").read_text()
    assert f"uavbus_DIR:PATH={prefix / 'lib' / 'cmake' / 'uavbus'}" in cache

    # Without libsodium on the consumer's machine the package says what is missing at configure time.
    proc = subprocess.run(["cmake", "-S", consumer, "-B", tmp_path / "consumer-nosodium", "-G", "Ninja",
                           f"-DUAVBUS_PYTHON={PYTHON}", f"-DCMAKE_PREFIX_PATH={prefix}"],
                          capture_output=True, text=True, env=no_cmocka_env(), timeout=600)
    assert proc.returncode != 0 and "needs libsodium" in proc.stderr, proc.stderr


def test_consumer_of_a_default_build_install_signs(tmp_path: Path) -> None:
    """Installed from a default build (tests and examples on, as `cmake -S uavbus -B b` does; it needs cmocka
    to configure, so with the real pkg-config), only libub built before installing. Before issue 29 its
    package named PkgConfig::SODIUM without finding it: the consumer failed at configure."""
    env = sodium_only_env(tmp_path)
    consumer = consumer_copy(tmp_path)
    prefix = tmp_path / "prefix-default"
    run(["cmake", "-S", REPO, "-B", tmp_path / "uavbus-default", "-G", "Ninja", f"-DUAVBUS_PYTHON={PYTHON}",
         f"-DCMAKE_INSTALL_PREFIX={prefix}"])
    run(["cmake", "--build", tmp_path / "uavbus-default", "--target", "ub"])
    run(["cmake", "--install", tmp_path / "uavbus-default"])
    check_installed(prefix)
    build_consumer(consumer, tmp_path / "consumer-installed-default", env, f"-DCMAKE_PREFIX_PATH={prefix}")


def test_add_subdirectory_and_fetchcontent_consumers_sign(tmp_path: Path) -> None:
    env = sodium_only_env(tmp_path)
    consumer = consumer_copy(tmp_path)
    # add_subdirectory(<uavbus checkout>): only the library and uavbus_generate().
    b2 = build_consumer(consumer, tmp_path / "consumer-subdir", env, f"-DUAVBUS_SOURCE_DIR={REPO}")
    targets = ninja_targets(b2)
    assert "libub.a" in targets
    for absent in ("test_node", "uavbus_node", "test_struct_vectors", "flightsw_codecs"):
        assert absent not in targets, f"{absent}: uavbus's own tests/examples leak into a consumer's build"
    assert not (b2 / "CTestTestfile.cmake").exists() or "test_" not in (b2 / "CTestTestfile.cmake").read_text()

    # The same through FetchContent (declared with SOURCE_DIR here; a Git mirror in real use).
    b3 = build_consumer(consumer, tmp_path / "consumer-fetch", env, f"-DUAVBUS_FETCH_DIR={REPO}")
    assert "test_node" not in ninja_targets(b3)


def test_version_file_refuses_another_minor_version(tmp_path: Path) -> None:
    """find_package(uavbus 0.2) must not accept 0.1 (0.x: minor versions may change the API)."""
    env = sodium_only_env(tmp_path)
    run(["cmake", "-S", REPO / "runtime_c", "-B", tmp_path / "b", "-G", "Ninja",
         f"-DCMAKE_INSTALL_PREFIX={tmp_path / 'prefix'}"], env)
    run(["cmake", "--build", tmp_path / "b"], env)
    run(["cmake", "--install", tmp_path / "b"], env)
    probe = tmp_path / "probe"
    probe.mkdir()
    (probe / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.20)\nproject(p C)\n"
        "find_package(uavbus ${WANT} CONFIG QUIET)\n"
        "if(uavbus_FOUND)\n  message(STATUS \"found uavbus ${uavbus_VERSION}\")\nelse()\n"
        "  message(STATUS \"no uavbus ${WANT}\")\nendif()\n")
    ok = run(["cmake", "-S", probe, "-B", tmp_path / "p1", f"-DCMAKE_PREFIX_PATH={tmp_path / 'prefix'}",
              "-DWANT=0.1", f"-DUAVBUS_PYTHON={PYTHON}"], env)
    assert "found uavbus 0.1.0" in ok
    refused = run(["cmake", "-S", probe, "-B", tmp_path / "p2", f"-DCMAKE_PREFIX_PATH={tmp_path / 'prefix'}",
                   "-DWANT=0.2", f"-DUAVBUS_PYTHON={PYTHON}"], env)
    assert "no uavbus 0.2" in refused


def test_core_cross_compiles_for_cortex_m4(tmp_path: Path) -> None:
    gcc = shutil.which("arm-none-eabi-gcc")
    assert gcc, "arm-none-eabi-gcc missing: `make setup` installs gcc-arm-none-eabi and libnewlib-arm-none-eabi"
    build = tmp_path / "mcu"
    run(["cmake", "-S", REPO / "examples" / "mcu", "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=MinSizeRel",
         f"-DCMAKE_TOOLCHAIN_FILE={REPO / 'cmake' / 'toolchains' / 'arm-none-eabi-cortex-m4.cmake'}",
         f"-DUAVBUS_PYTHON={PYTHON}"], no_cmocka_env())
    out = run(["cmake", "--build", build, "-v"])
    assert "arm-none-eabi-gcc" in out and "-mcpu=cortex-m4" in out
    elf = build / "firmware.elf"
    header = run(["arm-none-eabi-readelf", "-h", elf])
    assert "ARM" in header and "EXEC" in header
    text, data, bss = (int(x) for x in run(["arm-none-eabi-size", elf]).splitlines()[1].split()[:3])
    assert text > 10_000 and bss > 20_000  # the router's code, and the static node
    lib_symbols = run(["arm-none-eabi-nm", build / "uavbus" / "runtime_c" / "libub.a"])
    assert " T ub_node_rx" in lib_symbols and " T ub_nodecfg_parse" in lib_symbols
    for posix in ("ub_udp_open", "ub_tcp_", "ub_serial_open", "ub_ports_open", "ub_log_open", "ub_impair_"):
        assert posix not in lib_symbols, f"{posix}: a POSIX part in the bare-metal core"
    for alloc in (" U malloc", " U calloc", " U realloc", " U free"):
        assert alloc not in lib_symbols, f"the core references an allocator ({alloc.strip()})"
