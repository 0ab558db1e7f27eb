"""The flight-controller firmware (examples/mcu) on QEMU's Cortex-M4 board, its UART on a pty.

    elf = firmware_elf()                   # build-mcu/firmware.elf (built with the arm-none-eabi toolchain)
    with QemuBoard(elf) as board:          # qemu-system-arm -machine mps2-an386 -serial pty
        node.open_port("uart", f"serial:device={board.pty},baud=115200")

The firmware hosts entity fcs20 with one link on UART0 (examples/mcu/firmware.c). QEMU passes the
UART's bytes to and from the pty unchanged and at any speed (the emulated baud rate is not enforced).

Order of the firmware: $UAVBUS_FIRMWARE (a path to the ELF); else <repo>/build-mcu/firmware.elf, which
`make test` and `make demo` build (target `firmware`), configured and built here if asked to (`build=True`).
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
import tty
from dataclasses import dataclass
from pathlib import Path

from uavbus.sim.build import REPO

__all__ = ["FW_CAPACITIES", "MACHINE", "FirmwareMissing", "FirmwareSize", "QemuBoard", "build_firmware",
           "firmware_capacities", "firmware_elf", "firmware_size", "qemu_missing"]

MACHINE = "mps2-an386"
QEMU = "qemu-system-arm"
BUILD_DIR = REPO / "build-mcu"
TOOLCHAIN = REPO / "cmake" / "toolchains" / "arm-none-eabi-cortex-m4.cmake"
FLASH_BUDGET, RAM_BUDGET = 128 * 1024, 64 * 1024
# examples/mcu/firmware.c's fw_capacities, in its order: the ub_config.h capacities the image was built with.
FW_CAPACITIES = ("entities", "node_links", "links_per_entity", "local_entities", "pubsub_rows", "dedup_sources")


class FirmwareMissing(RuntimeError):
    """The firmware is not built and cannot be built here (no cross-compiler, or the build failed)."""


def qemu_missing() -> str | None:
    """Why the emulated board cannot run here (a sentence naming the fix), or None if it can."""
    if shutil.which(QEMU) is None:
        return f"{QEMU} not installed: `make setup` installs it (Debian package qemu-system-arm)"
    return None


def firmware_elf(build_dir: str | Path | None = None, *, build: bool = False, board: str = "mps2-an386") -> Path:
    env = os.environ.get("UAVBUS_FIRMWARE")
    if env:
        if not Path(env).is_file():
            raise FirmwareMissing(f"UAVBUS_FIRMWARE={env}: no such file; unset it or fix the path")
        return Path(env)
    bdir = Path(build_dir or BUILD_DIR)
    elf = bdir / "firmware.elf"
    if not build:
        if elf.exists():
            return elf
        raise FirmwareMissing(f"{elf}: not built; run `make firmware` (make test and make demo build it)")
    return build_firmware(bdir, board)


def build_firmware(bdir: Path, board: str = "mps2-an386") -> Path:
    """Configures (once) and builds examples/mcu for `board` in `bdir`; returns the ELF."""
    elf = bdir / "firmware.elf"
    if shutil.which("arm-none-eabi-gcc") is None:
        raise FirmwareMissing("arm-none-eabi-gcc not installed: run `make setup` (gcc-arm-none-eabi)")
    if not (bdir / "CMakeCache.txt").exists():
        r = subprocess.run(["cmake", "-S", str(REPO / "examples" / "mcu"), "-B", str(bdir), "-G", "Ninja",
                            "-DCMAKE_BUILD_TYPE=MinSizeRel", f"-DCMAKE_TOOLCHAIN_FILE={TOOLCHAIN}",
                            f"-DUAVBUS_BOARD={board}", f"-DUAVBUS_PYTHON={sys.executable}"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if r.returncode != 0:
            raise FirmwareMissing(f"configuring the firmware in {bdir} failed:\n{r.stdout[-3000:]}")
    r = subprocess.run(["cmake", "--build", str(bdir), "-j2"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True)
    if r.returncode != 0:
        raise FirmwareMissing(f"building the firmware in {bdir} failed:\n{r.stdout[-3000:]}")
    return elf


@dataclass(frozen=True)
class FirmwareSize:
    text: int
    data: int
    bss: int   # with the stack the linker script reserves (a NOLOAD section)

    @property
    def flash(self) -> int:
        """What the board flashes: code and constants, plus the initial values of .data."""
        return self.text + self.data

    @property
    def ram(self) -> int:
        """What the board needs in RAM: .data, .bss and the stack."""
        return self.data + self.bss

    def fits(self) -> bool:
        return self.flash <= FLASH_BUDGET and self.ram <= RAM_BUDGET

    def __str__(self) -> str:
        return (f"flash {self.flash / 1024:.1f} KiB of {FLASH_BUDGET // 1024}, "
                f"RAM {self.ram / 1024:.1f} KiB of {RAM_BUDGET // 1024} (stack included)")


def firmware_size(elf: str | Path) -> FirmwareSize:
    """Sizes from the ELF (`arm-none-eabi-size`, Berkeley format)."""
    out = subprocess.run(["arm-none-eabi-size", str(elf)], check=True, stdout=subprocess.PIPE, text=True).stdout
    text, data, bss = (int(x) for x in out.splitlines()[1].split()[:3])
    return FirmwareSize(text, data, bss)


def firmware_capacities(elf: str | Path) -> dict[str, int]:
    """The capacities the image was built with, read from the ELF (the firmware's `fw_capacities`, little-endian
    uint16 in flash): what a size figure holds for, whatever the headers or the command line said."""
    syms = subprocess.run(["arm-none-eabi-nm", "-S", str(elf)], check=True, stdout=subprocess.PIPE, text=True).stdout
    found = [line.split() for line in syms.splitlines() if line.endswith(" fw_capacities")]
    if len(found) != 1 or len(found[0]) != 4 or int(found[0][1], 16) != 2 * len(FW_CAPACITIES):
        raise FirmwareMissing(f"{elf}: no fw_capacities of {len(FW_CAPACITIES)} uint16 (not examples/mcu's firmware, "
                              "or one older than its capacity record): rebuild with `make firmware`")
    addr, size = int(found[0][0], 16), int(found[0][1], 16)
    img = Path(elf).read_bytes()
    if img[:6] != b"\x7fELF\x01\x01":
        raise FirmwareMissing(f"{elf}: not a 32-bit little-endian ELF")
    shoff, = struct.unpack_from("<I", img, 32)
    shentsize, shnum = struct.unpack_from("<HH", img, 46)
    for k in range(shnum):   # the loaded section (SHF_ALLOC) whose file bytes hold it (not NOBITS: type 8)
        _name, kind, flags, sh_addr, sh_offset, sh_size = struct.unpack_from("<6I", img, shoff + k * shentsize)
        if kind != 8 and flags & 2 and sh_addr <= addr and addr + size <= sh_addr + sh_size:
            raw = img[sh_offset + addr - sh_addr:sh_offset + addr - sh_addr + size]
            return dict(zip(FW_CAPACITIES, struct.unpack(f"<{len(FW_CAPACITIES)}H", raw)))
    raise FirmwareMissing(f"{elf}: fw_capacities at {addr:#x} is in no section with contents")


_PTY = re.compile(r"char device redirected to (/dev/pts/\d+)")


class QemuBoard:
    """qemu-system-arm running the firmware, UART0 on a fresh pty (`.pty`). Stopped by close() (or the
    context manager) on success, failure and Ctrl-C. Not killable as a bus member by a launcher: it is
    whatever the user started, seen through its UART."""

    def __init__(self, elf: str | Path, *, machine: str = MACHINE, timeout: float = 10.0,
                 extra_args: list[str] | None = None) -> None:
        why = qemu_missing()
        if why:
            raise FirmwareMissing(why)
        self.elf = Path(elf)
        self.argv = [QEMU, "-machine", machine, "-nographic", "-monitor", "none", "-kernel", str(self.elf),
                     "-serial", "pty", *(extra_args or [])]
        self.output: list[str] = []
        self.proc = subprocess.Popen(self.argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, start_new_session=True)
        self.pty = self._wait_pty(timeout)
        # QEMU's pty backend drops what the board sends while no one holds the pty open, and notices a new
        # opener only by polling (once a second): a node that closes and reopens the device (a ground station
        # killed and restarted) could find the board's output cut off for good. Holding a descriptor of our
        # own keeps the line "connected" whoever comes and goes; it is never read, so it takes no bytes.
        self._hold = os.open(self.pty, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self._hold, termios.TCSANOW)
        self.started = time.monotonic()
        # Keep draining QEMU's output so it never blocks on a full pipe (guest errors, warnings).
        self._reader = threading.Thread(target=self._drain, daemon=True)
        self._reader.start()

    def _wait_pty(self, timeout: float) -> str:
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.output.append(line.rstrip())
            m = _PTY.search(line)
            if m:
                return m.group(1)
        self.close()
        raise FirmwareMissing(f"{' '.join(self.argv)}: no pty announced (exit {self.proc.returncode}); "
                              f"output: {' | '.join(self.output[-5:]) or 'none'}")

    def _drain(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.output.append(line.rstrip())

    def running(self) -> bool:
        return self.proc.poll() is None

    def close(self) -> int | None:
        if getattr(self, "_hold", None) is not None:
            os.close(self._hold)
            self._hold = None
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        return self.proc.returncode

    def __enter__(self) -> QemuBoard:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"QemuBoard({self.elf.name} on {MACHINE}, UART0 {self.pty})"
