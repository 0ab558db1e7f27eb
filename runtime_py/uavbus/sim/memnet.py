"""A whole configuration in one process: one Python `uavbus.Node` per entity, links as MemLinks.

This is the paper's "memory within a single executable" (design requirement 2) for the Table 1 /
figure 9 example: three routers (the config's "nodes": A hosts entity0 and entity1, B entity2, C
entity3), links paired by name, every router driven by one injected clock so the run is deterministic
and faster than real time. The link between entity0 and entity1, both on router A, is a MemLink from A
to itself: a frame for entity1 leaves entity0 on e0Toe1 and comes back in on e1Toe0, as in figure 9.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

__all__ = ["MemNet", "TABLE1_PAIRS"]

# figure 9: which link of which entity faces which (entity 0 and 3 have two links between them)
TABLE1_PAIRS = (
    (("entity0", "e0Toe1"), ("entity1", "e1Toe0")),
    (("entity0", "e0Toe3a"), ("entity3", "e3Toe0a")),
    (("entity0", "e0Toe3b"), ("entity3", "e3Toe0b")),
    (("entity1", "e1Toe2"), ("entity2", "e2Toe1")),
)


class MemNet:
    def __init__(self, catalogue: Any, config: str | Path,
                 pairs: Iterable[tuple[tuple[str, str], tuple[str, str]]] = TABLE1_PAIRS) -> None:
        from uavbus import MemLink, Node

        self.now_ms = 1
        doc = json.loads(Path(config).read_text())
        self.host_of = {e: n for n, hosted in doc["nodes"].items() for e in hosted}
        clock: Callable[[], int] = lambda: self.now_ms  # noqa: E731 - the injected clock of every node
        self.nodes: dict[str, Any] = {n: Node(catalogue, config=str(config), node=n, clock=clock)
                                      for n in doc["nodes"]}
        self.links = [MemLink(self.of(a), la, self.of(b), lb) for (a, la), (b, lb) in pairs]

    def of(self, entity: str) -> Any:
        """The router hosting `entity`."""
        return self.nodes[self.host_of[entity]]

    def step(self, ms: int = 1) -> None:
        self.now_ms += ms
        for n in self.nodes.values():
            n.poll(timeout=0)

    def run(self, ms: int, step_ms: int = 1, each: Callable[[int], None] | None = None) -> None:
        end = self.now_ms + ms
        while self.now_ms < end:
            if each is not None:
                each(self.now_ms)
            self.step(step_ms)

    def close(self) -> None:
        for n in self.nodes.values():
            n.close()
        self.nodes.clear()

    def __enter__(self) -> MemNet:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
