"""PyLink: a node's link whose transport is Python code (the Zenoh bridge's, or a test's).

One router, whatever carries the frames: the C node routes onto the link as onto any other
(masks, forwarding, hop limit, counters), and a PyLink only moves whole frames in and out:

    link = PyLink(node, "zenoh")              # put it behind the node's link slot "zenoh"
    for frame in link.drain():                # frames the router sent on the link, oldest first
        carry(frame)
    link.receive(frame_from_elsewhere)        # into the router: verified, deduplicated, routed

`send` (called by the router through `extern "Python"` while it routes) only queues; the outbox is
bounded (`capacity` frames) and a full one refuses the frame with UB_ERR_AGAIN, which the node counts
as `backpressure` on the link. Use it from the thread that polls the node.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

from uavbus._bindings import ub_link, ub_node
from uavbus._bindings.ub_error import UbError

if TYPE_CHECKING:
    from uavbus.node import Node

DEFAULT_CAPACITY = 4096


class PyLink:
    """The transport of link `link` of `node`, in Python: an outbox of sent frames and receive()."""

    def __init__(self, node: "Node", link: str, capacity: int = DEFAULT_CAPACITY, kind: str = "py") -> None:
        self.node = node
        self.link = link
        self.link_id = node.link_id(link)
        self.capacity = capacity
        self.outbox: deque[bytes] = deque()
        self.refused = 0          # frames refused because the outbox was full (the node counts backpressure)
        self.rejected = 0         # received frames the router refused as invalid (counted by the node too)
        self.send_errors = 0      # send() raised: the node counts tx_error; the last error is kept
        self.last_error: Exception | None = None
        self._handle = ub_link.new_handle(self)
        self._ops, self._kind = ub_link.new_ops(kind.encode("ascii"))
        ub_link.ub_node_link_attach(node._c, self.link_id, self._ops, self._handle)
        node._keep_alive(self)    # C holds pointers to our handle and ops until the node is closed

    def send(self, frame: bytes, now_ms: int) -> int:
        """Called by the router (through C) with one whole, verified frame: queue it."""
        if len(self.outbox) >= self.capacity:
            self.refused += 1
            return ub_link.ERR_AGAIN
        self.outbox.append(frame)
        return 0

    def send_failed(self, exc: Exception) -> None:
        """send() raised `exc` (the router counts the frame as tx_error)."""
        self.send_errors += 1
        self.last_error = exc

    def drain(self, limit: int | None = None) -> list[bytes]:
        """The frames sent on the link since the last drain (at most `limit`), oldest first."""
        n = len(self.outbox) if limit is None else min(limit, len(self.outbox))
        return [self.outbox.popleft() for _ in range(n)]

    def receive(self, frame: bytes, now_ms: int | None = None) -> bool:
        """Hands one frame received from outside to the router, as a datagram transport does. Returns
        False when the router refused it as invalid (counted on the link by decoder reason)."""
        now = self.node.now() if now_ms is None else now_ms
        try:
            ub_node.ub_node_rx_frame(self.node._c, self.link_id, frame, now)
        except UbError:
            self.rejected += 1
            return False
        return True

    def detach(self) -> None:
        try:
            ub_link.ub_node_link_detach(self.node._c, self.link_id)
        except UbError:
            pass
