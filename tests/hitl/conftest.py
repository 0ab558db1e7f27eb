"""Hardware in the loop (issue 25): the flight-controller firmware (examples/mcu) booted in QEMU's Cortex-M4
board, a bus entity on its emulated UART.

The firmware is <repo>/build-mcu/firmware.elf (or $UAVBUS_FIRMWARE), which `make test` builds (target
`firmware`) before pytest runs. A missing firmware fails the tests with how to build it; a missing QEMU
skips them with the reason (the only skip: `make setup` installs qemu-system-arm).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from uavbus.sim.qemu import FirmwareMissing, QemuBoard, firmware_elf, qemu_missing


@pytest.fixture(scope="session")
def firmware() -> Path:
    try:
        return firmware_elf()
    except FirmwareMissing as e:
        pytest.fail(f"firmware not available: {e}")


@pytest.fixture(scope="module")
def board(firmware: Path) -> Iterator[QemuBoard]:
    why = qemu_missing()
    if why:
        pytest.skip(why)
    with QemuBoard(firmware) as b:
        yield b


@pytest.fixture(scope="session")
def program() -> Path:
    """uavbus_node (the simulated members of a scenario), as tests/system finds it: built by `make test`."""
    from uavbus.sim.build import NodeProgramMissing, node_program

    try:
        return node_program(build=False)
    except NodeProgramMissing as e:
        pytest.fail(f"uavbus_node not available: {e}")
