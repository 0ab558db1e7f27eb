"""Port specs for multi-process topologies (Contract 1 spec strings, one set per process).

A `Topology` is a list of point-to-point connections between (node, link) ends, each over UDP, TCP or a
pty serial null-modem. `specs(node)` gives the ``{link: spec}`` a process needs (the C node takes them as
``--port link=spec``; the Python GCS passes them to ``Node.open_port``). `table2()` builds the paper's
HITL set-up (Table 2, figure 11) from examples/configs/table2.json:

    gcs1  gcsPortDatalink1 --UDP-----------  onboardPortDatalink1 rmax1ob1   (mask 0x11: both datalinks)
    gcs1  gcsPortDatalink2 --pty serial----  onboardPortDatalink2 rmax1ob1   ("wireless serial")
    rmax1ob1 onboardPortIPC --TCP (client)-  onboard2PortIPC rmax1ob2 (server)
    rmax1ob1 onboardPortRelay --pty serial-  onboardPortDatalink1 fcs20

Links are found by their position in the entity rows of the config (the masks refer to them), so the
builder checks that every link of every entity gets exactly one end.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from uavbus.config import load_config
from uavbus.sim.nullmodem import NullModem, RelayFaults
from uavbus.sim.portalloc import PortAllocator

__all__ = ["Connection", "Topology", "table2", "TABLE2_NODES"]

# node (process) name -> the entity it hosts, as in table2.json "nodes"
TABLE2_NODES = {"gcs": "gcs1", "primary": "rmax1ob1", "secondary": "rmax1ob2", "backup": "fcs20"}


@dataclass
class Connection:
    a: tuple[str, str]          # (node, link); for TCP the client
    b: tuple[str, str]          # (node, link); for TCP the server
    transport: str              # "udp" | "tcp" | "serial"
    spec_a: str = ""
    spec_b: str = ""
    modem: NullModem | None = None


@dataclass
class Topology:
    alloc: PortAllocator = field(default_factory=PortAllocator)
    baud: int = 115200
    serial_faults: RelayFaults | None = None
    connections: list[Connection] = field(default_factory=list)

    def udp(self, a: tuple[str, str], b: tuple[str, str]) -> Connection:
        pa, pb = self.alloc.addr(), self.alloc.addr()
        c = Connection(a, b, "udp", f"udp:bind={pa},peer={pb}", f"udp:bind={pb},peer={pa}")
        self.connections.append(c)
        return c

    def tcp(self, client: tuple[str, str], server: tuple[str, str]) -> Connection:
        addr = self.alloc.addr()
        c = Connection(client, server, "tcp", f"tcp:connect={addr}", f"tcp:listen={addr}")
        self.connections.append(c)
        return c

    def serial(self, a: tuple[str, str], b: tuple[str, str], faults: RelayFaults | None = None) -> Connection:
        """A pty null-modem; started at once (the relay thread runs until close())."""
        nm = NullModem(f"{a[1]}~{b[1]}", faults or self.serial_faults)
        nm.start()
        c = Connection(a, b, "serial", f"serial:device={nm.path_a},baud={self.baud}",
                       f"serial:device={nm.path_b},baud={self.baud}", nm)
        self.connections.append(c)
        return c

    def specs(self, node: str) -> dict[str, str]:
        out: dict[str, str] = {}
        for c in self.connections:
            for (n, link), spec in ((c.a, c.spec_a), (c.b, c.spec_b)):
                if n == node:
                    if link in out:
                        raise ValueError(f"topology: link {link!r} of node {node!r} has two connections")
                    out[link] = spec
        return out

    def port_args(self, node: str) -> list[str]:
        """``--port link=spec`` arguments for a uavbus_node process."""
        args: list[str] = []
        for link, spec in self.specs(node).items():
            args += ["--port", f"{link}={spec}"]
        return args

    def find(self, node: str, link: str) -> Connection:
        for c in self.connections:
            if (node, link) in (c.a, c.b):
                return c
        raise KeyError(f"topology: no connection for {node}:{link}")

    def hops(self, a: str, b: str) -> int:
        """Links on the shortest path between nodes a and b (what a frame crosses, forwarding included)."""
        seen, frontier, n = {a}, {a}, 0
        while frontier and b not in frontier:
            n += 1
            frontier = {y for c in self.connections for x, y in ((c.a[0], c.b[0]), (c.b[0], c.a[0]))
                        if x in frontier and y not in seen}
            seen |= frontier
        if b not in frontier:
            raise KeyError(f"topology: no path between {a!r} and {b!r}")
        return n

    def external(self, node: str, link: str, device: str) -> Connection:
        """Node `node` is not started by the harness (an emulated board, a real flight computer): its end
        of the serial connection at `link` is `device` (e.g. QEMU's pty of the board's UART), which the
        other end opens directly; the null-modem planned there is closed."""
        c = self.find(node, link)
        if c.transport != "serial":
            raise ValueError(f"topology: {node}:{link} is {c.transport}; an external member is reached over a "
                             f"serial device here (give the {c.transport} address to the other end instead)")
        if c.modem is not None:
            c.modem.close()
            c.modem = None
        far = f"serial:device={device},baud={self.baud}"
        if c.a == (node, link):
            c.spec_a, c.spec_b = f"external:{device}", far
        else:
            c.spec_a, c.spec_b = far, f"external:{device}"
        return c

    def modems(self) -> list[NullModem]:
        return [c.modem for c in self.connections if c.modem is not None]

    def close(self) -> None:
        for nm in self.modems():
            nm.close()

    def check_complete(self, config: str | Path, nodes: dict[str, str]) -> None:
        """Every link of every hosted entity has exactly one connection (a typo would leave one dark)."""
        cfg = load_config(str(config))
        for node, entity in nodes.items():
            links = set(cfg.entity(entity).links)
            have = set(self.specs(node))
            if links != have:
                raise ValueError(f"topology: node {node!r} ({entity}) links {sorted(links)} but connections "
                                 f"for {sorted(have)}; add the missing ones")


def table2(config: str | Path, alloc: PortAllocator | None = None, *, serial_faults: RelayFaults | None = None,
           baud: int = 115200) -> Topology:
    """The paper's Table 2 HITL links (see the module text). Node names as in table2.json "nodes"."""
    topo = Topology(alloc or PortAllocator(), baud, serial_faults)
    topo.udp(("gcs", "gcsPortDatalink1"), ("primary", "onboardPortDatalink1"))
    topo.serial(("gcs", "gcsPortDatalink2"), ("primary", "onboardPortDatalink2"))
    topo.tcp(("primary", "onboardPortIPC"), ("secondary", "onboard2PortIPC"))
    topo.serial(("primary", "onboardPortRelay"), ("backup", "onboardPortDatalink1"))
    try:
        topo.check_complete(config, TABLE2_NODES)
    except BaseException:
        topo.close()
        raise
    return topo
