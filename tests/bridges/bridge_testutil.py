"""Helpers shared by the bridge tests and bench/bridges_bench.py."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

HERE = Path(__file__).resolve().parent
AUTOPILOT = HERE / "mav_autopilot.py"


def autopilot_argv(port: int, key: Path | None = None, duration: float = 60.0, sysid: int = 1) -> list[str]:
    """The pymavlink autopilot (mav_autopilot.py) on udp 127.0.0.1:`port` as system `sysid`, signing with
    `key` if given."""
    argv = [sys.executable, str(AUTOPILOT), "--port", str(port), "--duration", str(duration), "--sysid", str(sysid)]
    if key is not None:
        argv += ["--key", str(key)]
    return argv


def two_bridges_config(system: str, a: Mapping[str, int], host: str = "127.0.0.1", batch: bool = False,
                       rcvbuf: int = 0) -> dict:
    """A node configuration of two sites joined by two gateways: srcA (node A) reaches dstB (node B) through
    gwA and gwB, whose "zenoh" links are the bridge's; every site link is UDP on `host`, node k's port a[k]
    for k in A, B, gwA, gwB (the Zenoh bridge test and bench/bridges_bench.py); `batch`: every site port
    packs several frames per datagram ("batch": true), `rcvbuf`: and asks for that receive buffer
    (docs/config-format.md)."""

    def udp(bind: str, peer: str) -> dict:
        port = {"transport": "udp", "bind": f"{host}:{a[bind]}", "peer": f"{host}:{a[peer]}"}
        return {**port, **({"batch": True} if batch else {}), **({"rcvbuf": rcvbuf} if rcvbuf else {})}

    return {"system": system,
            "entities": [{"name": "srcA", "links": ["l"], "linktoentity": {"dstB": [0], "gwA": [0], "gwB": [0]}},
                         {"name": "gwA", "links": ["site", "zenoh"],
                          "linktoentity": {"srcA": ["site"], "dstB": ["zenoh"], "gwB": ["zenoh"]}},
                         {"name": "gwB", "links": ["site", "zenoh"],
                          "linktoentity": {"dstB": ["site"], "srcA": ["zenoh"], "gwA": ["zenoh"]}},
                         {"name": "dstB", "links": ["l"], "linktoentity": {"srcA": [0], "gwA": [0], "gwB": [0]}}],
            "nodes": {"A": ["srcA"], "B": ["dstB"], "gwA": ["gwA"], "gwB": ["gwB"]},
            "ports": {"srcA:l": udp("A", "gwA"), "gwA:site": udp("gwA", "A"),
                      "gwB:site": udp("gwB", "B"), "dstB:l": udp("B", "gwB")}}


def close_all(closers: Iterable[Callable[[], object]]) -> None:
    """Calls each closer, last opened first, each even when an earlier one raised (a test's or bench's
    finally: what it opened is closed whatever failed)."""
    for close in reversed(list(closers)):
        try:
            close()
        except Exception:  # noqa: BLE001 (closing anyway)
            pass
