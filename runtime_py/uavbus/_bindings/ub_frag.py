"""Wrappers for ub_frag.h and the node's fragment calls (ub_node.h "Wire"): large directories in fragments."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import ensure
from uavbus._ub import ffi, lib

STATS_FIELDS = ("tx_transfers", "tx_fragments", "tx_busy", "tx_paused", "tx_abandoned", "rx_started", "rx_fragments",
                "rx_duplicates", "rx_complete", "rx_timeouts", "rx_evicted", "rx_refused", "rx_source_limit",
                "rx_restarted", "rx_bad")


def ub_frag_new(first_transfer: int) -> Any:
    """Fresh fragment state with the default parameters, numbering transfers from `first_transfer` (16 bits).
    Large (about UB_FRAG_SLOTS + UB_FRAG_TX_SLOTS times UB_MAX_DIRECTORY bytes); freed with the cdata."""
    frag = ffi.new("ub_frag_t *")
    lib.ub_frag_init(frag, ffi.NULL, first_transfer & 0xFFFF)
    return frag


def ub_node_set_frag(node: Any, frag: Any) -> None:
    """Attaches `frag` (which must outlive the attachment) to `node`; None detaches it."""
    ensure(lib.ub_node_set_frag(node, ffi.NULL if frag is None else frag), "ub_node_set_frag")


def ub_node_frag_stats(node: Any) -> dict[str, int]:
    """The counters of the node's fragment state; all zero when none is attached."""
    s = lib.ub_node_frag_stats(node)
    return {k: 0 if s == ffi.NULL else int(getattr(s, k)) for k in STATS_FIELDS}
