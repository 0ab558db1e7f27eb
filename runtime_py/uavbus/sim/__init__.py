"""Multi-process simulation harness: node processes, pty null-modems, free ports, topologies, metrics.

Used by the system tests (tests/system/) and by `make demo` (examples/demo/hitl_demo.py).
"""

from uavbus.sim.nullmodem import NullModem, RelayFaults
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeError, NodeProcess, ProcessGroup, is_addr_in_use
from uavbus.sim.topology import TABLE2_NODES, Connection, Topology, table2

__all__ = [
    "TABLE2_NODES", "Connection", "NodeError", "NodeProcess", "NullModem", "PortAllocator", "ProcessGroup",
    "RelayFaults", "Topology", "is_addr_in_use", "table2",
]
