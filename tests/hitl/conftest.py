"""Hardware in the loop (issue 25): the flight-controller firmware (examples/mcu) booted in QEMU's Cortex-M4
board, a bus entity on its emulated UART.

The firmware is <repo>/build-mcu/firmware.elf (or $UAVBUS_FIRMWARE), which `make test` builds (target
`firmware`) before pytest runs. A missing firmware fails the tests with how to build it; a missing QEMU
skips them with the reason (the only skip: `make setup` installs qemu-system-arm).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from uavbus import Node
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


@pytest.fixture(scope="module")
def open_host(firmware: Path) -> Iterator[Callable[..., Node]]:
    """Opens a host node on a board's UART pty, with the catalogue generated for the firmware
    (build-mcu/uavbus/fcs/fcs.catalogue.json) and an `inbox` of (name, source, value) for every DATA delivered.
    `setup(node)` runs before imuOut is bound and the port opened; every node opened is closed with the module."""
    opened: list[Node] = []

    def open_(pty: str, config: Path | None = None, setup: Callable[[Node], None] | None = None) -> Node:
        catalogue = firmware.parent / "uavbus" / "fcs" / "fcs.catalogue.json"
        node = Node(catalogue, node="gcs") if config is None else Node(catalogue, config=config, node="gcs")
        opened.append(node)
        if setup is not None:
            setup(node)
        node.bind("imuOut")
        node.inbox = []
        node.on_data(lambda msg: node.inbox.append((msg.name, msg.source, msg.value)))
        node.open_port("uart", f"serial:device={pty},baud=115200")
        return node

    yield open_
    for node in opened:
        node.close()


def pump_for(node: Node, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        node.poll(0.02)


@pytest.fixture(scope="session")
def pump() -> Callable[[Node, float], None]:
    """pump(node, seconds): polls the node for that long."""
    return pump_for


@pytest.fixture(scope="session")
def collect() -> Callable[[Node, str, float], list[dict[str, Any]]]:
    """collect(node, content, seconds): what the board (fcs20) sent of `content` during the next `seconds`."""
    def collect_(node: Any, content: str, seconds: float) -> list[dict[str, Any]]:
        start = len(node.inbox)
        pump_for(node, seconds)
        return [value for name, source, value in node.inbox[start:] if name == content and source == "fcs20"]
    return collect_
