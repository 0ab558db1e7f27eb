"""Wrappers for ub_link.h: a transport implemented in Python behind a node's link slot.

The slot's `ops.send` is the `extern "Python"` ub_py_link_send; `impl` is an `ffi.new_handle()` of a
Python object whose `send(frame: bytes, now_ms: int) -> int` returns a ub_error code (UB_OK, or
UB_ERR_AGAIN to refuse: counted as backpressure by the node). It runs inside the C send, so it must
not call back into the node: it queues. An exception in it is handed to its `send_failed(exc)` and
becomes UB_ERR_IO (counted tx_error): it never unwinds through C.
"""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import ensure
from uavbus._ub import ffi, lib


def new_ops(kind: bytes) -> tuple[Any, Any]:
    """A ub_link_ops_t whose send is ub_py_link_send, and the kind string it points to (keep both alive)."""
    ops = ffi.new("ub_link_ops_t *")
    kind_c = ffi.new("char[]", kind)
    ops.kind = kind_c
    ops.send = lib.ub_py_link_send
    ops.fileno = ffi.NULL
    return ops, kind_c


ERR_AGAIN: int = lib.UB_ERR_AGAIN


def ub_link_mask_parse(text: str) -> int:
    """A mask in the paper's notation ("0x00000110" -> 0x06); InvalidArgumentError/RangeError if malformed."""
    out = ffi.new("uint8_t *")
    ensure(lib.ub_link_mask_parse(text.encode("ascii", "replace"), out), f"mask {text!r}")
    return int(out[0])


def new_handle(transport: Any) -> Any:
    """The `impl` handle of a Python transport for ub_node_link_attach() (keep it alive while attached)."""
    return ffi.new_handle(transport)


def ub_node_link_attach(node: Any, link_id: int, ops: Any, handle: Any) -> None:
    ensure(lib.ub_node_link_attach(node, link_id, ops, handle), f"attaching a transport to link {link_id}")


def ub_node_link_detach(node: Any, link_id: int) -> None:
    ensure(lib.ub_node_link_detach(node, link_id), f"detaching link {link_id}")


@ffi.def_extern(error=lib.UB_ERR_IO)
def ub_py_link_send(impl: Any, frame: Any, length: int, now_ms: int) -> int:
    transport = ffi.from_handle(impl)
    try:
        # `frame` is valid only during the call: copy it.
        return int(transport.send(bytes(ffi.buffer(frame, length)), now_ms))
    except Exception as exc:  # noqa: BLE001 (reported to the transport, counted by the node)
        transport.send_failed(exc)
        return int(lib.UB_ERR_IO)
