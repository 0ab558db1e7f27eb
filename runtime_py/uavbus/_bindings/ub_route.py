"""Wrappers for ub_route.h: attach the routing engine to a node and read what it chose."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._bindings.ub_node import entity_name
from uavbus._ub import ffi, lib

INFINITY: int = lib.UB_ROUTE_INFINITY
LINK_COST: int = lib.UB_ROUTE_LINK_COST
PARALLEL = {"all": lib.UB_ROUTE_PARALLEL_ALL, "best": lib.UB_ROUTE_PARALLEL_BEST}
OPTION_FIELDS = ("hello_ms", "update_ms", "trigger_gap_ms", "source_gc_ms", "dead_misses", "initial_seqno",
                 "learn_expiry_ms", "max_dests")
_LINK_STATS = ("frames_out", "hellos_out", "triggered_out", "entries_out", "requests_out", "bytes_out", "refused_out",
               "frames_in", "entries_in", "requests_in", "bad_in", "neighbour_changes", "link_downs", "over_limit_in",
               "fast_hellos_out")
_COUNTERS = ("route_changes", "routes_found", "routes_lost", "unfeasible", "expired", "starvation_requests",
             "requests_forwarded", "requests_answered", "requests_dropped", "seqno_bumps", "learned", "learn_full",
             "learn_refused", "learn_expired", "pinned_skips", "neighbour_limit", "dest_refused",
             "link_evidence_down", "link_doubts", "lost_link_down", "lost_entry_gone", "lost_retracted",
             "lost_unfeasible", "owed_route_change", "owed_seqno_asked", "owed_request_answer", "seqno_deferred",
             "requests_suppressed", "unfeasible_held")


def ub_route_new(node: Any, now_ms: int, parallel: str = "all", learn: bool = True, certified_by: Any = None,
                 **options: int) -> Any:
    """An engine attached to `node`; the caller keeps the cdata (and the node, and `certified_by`) alive.
    `certified_by` (a ub_ident_store_t *): advertised destinations get routes only if that store certifies
    them (ub_identfile_route_certified, the filter of `uavbus_node --route certified=1`)."""
    opt = ffi.new("ub_route_options_t *")
    if certified_by is not None:
        opt.accept_dest = ffi.addressof(lib, "ub_identfile_route_certified")
        opt.accept_user = certified_by
    for key, value in options.items():
        if key not in OPTION_FIELDS:
            raise InvalidArgumentError(f"unknown routing option {key!r} (one of {', '.join(OPTION_FIELDS)}, "
                                       "parallel, learn)")
        setattr(opt, key, value)
    if parallel not in PARALLEL:
        raise InvalidArgumentError(f"parallel={parallel!r}: use 'all' or 'best'")
    opt.parallel = PARALLEL[parallel]
    opt.no_learn = 0 if learn else 1
    rt = ffi.new("ub_route_t *")
    ensure(lib.ub_route_attach(rt, node, opt, now_ms),
           "routing options out of range (hello_ms 10..65535, update_ms >= hello_ms, dead_misses <= 16)")
    return rt


def ub_route_detach(rt: Any) -> None:
    lib.ub_route_detach(rt)


def ub_route_get(rt: Any, entity: int, dest: int) -> dict[str, Any]:
    ri = ffi.new("ub_route_info_t *")
    ensure(lib.ub_route_get(rt, entity, dest, ri), f"route of entity {entity} toward {dest}")
    return {
        "local": bool(ri.local), "reachable": bool(ri.reachable), "retracting": bool(ri.retracting),
        "starving": bool(ri.starving), "pinned": bool(ri.pinned), "learned": bool(ri.learned),
        "link_id": int(ri.link_id), "next_hop": entity_name(bytes(ri.next_hop)) if ri.reachable else None,
        "metric": int(ri.metric), "seqno": int(ri.seqno), "mask": int(ri.mask), "routes": int(ri.routes),
        "feasible": int(ri.feasible),
        "fd": (int(ri.fd_seqno), int(ri.fd_metric)) if ri.fd_valid else None,
    }


def ub_route_link_info(rt: Any, link_id: int) -> dict[str, Any]:
    li = ffi.new("ub_route_link_info_t *")
    ensure(lib.ub_route_link_info(rt, link_id, li), f"link {link_id}")
    out: dict[str, Any] = {
        "neighbour": entity_name(bytes(li.neighbour_id)) if li.neighbour else None,
        "rxcost": int(li.rxcost), "txcost": int(li.txcost), "cost": int(li.cost), "history": int(li.history),
        "samples": int(li.samples), "neighbour_hello_ms": int(li.neighbour_hello_ms),
    }
    out.update({k: int(getattr(li.stats, k)) for k in _LINK_STATS})
    return out


def ub_route_counters(rt: Any) -> dict[str, int]:
    c = lib.ub_route_counters(rt)
    return {k: int(getattr(c, k)) for k in _COUNTERS}


def ub_route_seqno(rt: Any, entity: int) -> int:
    return int(lib.ub_route_seqno(rt, entity))
