"""Wrappers for ub_ports.h (with ub_impair.h): the transports behind a node's links, by spec text."""

from __future__ import annotations

import json

from typing import Any

from uavbus._bindings.ub_catalogue import _c_name
from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._ub import ffi, lib

ERR_LEN: int = lib.UB_PORTS_ERR_LEN
POLLFD_CAP: int = 2 * lib.UB_PORTS_MAX
PPM: int = lib.UB_IMPAIR_PPM_MAX


def _err() -> Any:
    return ffi.new("char[]", ERR_LEN)


def _text(err: Any) -> str:
    return ffi.string(err).decode("utf-8", "replace")


def ub_ports_new(node: Any) -> Any:
    # ~1.3 MB: allocated once per Node by cffi (zeroed), freed with the cdata.
    ports = ffi.new("ub_ports_t *")
    ensure(lib.ub_ports_init(ports, node), "ub_ports_init")
    return ports


def ub_ports_open_text(ports: Any, link: str, spec: str, now_ms: int) -> None:
    err = _err()
    ensure(lib.ub_ports_open_text(ports, _c_name(link), _c_name(spec), now_ms, err, ERR_LEN),
           f"port {link}={spec}: {_text(err)}")


def ub_ports_open_config(ports: Any, cfg: Any, now_ms: int) -> int:
    err = _err()
    return ensure(lib.ub_ports_open_config(ports, cfg, now_ms, err, ERR_LEN), _text(err) or "ports section")


@ffi.def_extern()
def ub_py_foreign(user: Any, run: Any, length: int) -> int:
    # `run` is valid only during the call: the handler gets a copy. It returns how many bytes it took
    # (None: all); an exception refuses the run (cffi returns 0, and C counts it in foreign_refused).
    fn = ffi.from_handle(user)
    took = fn(bytes(ffi.buffer(run, length)))
    return length if took is None else max(0, min(int(took), length))


def ub_ports_set_foreign(ports: Any, link: str, fn: Any) -> Any:
    """Gives `link`'s port the foreign-traffic handler `fn(bytes) -> int | None`; None removes it. Returns the
    handle the caller must keep alive while the handler is set."""
    handle = ffi.new_handle(fn) if fn is not None else ffi.NULL
    ensure(lib.ub_ports_set_foreign(ports, _c_name(link), lib.ub_py_foreign if fn is not None else ffi.NULL, handle),
           f"port {link!r}: no open port, or its transport takes no foreign-traffic handler")
    return handle


def ub_ports_write_foreign(ports: Any, link: str, data: bytes, now_ms: int) -> None:
    """Writes `data` (not a uavbus frame: a legacy datalink message) onto `link`'s port, whole or not at all."""
    ensure(lib.ub_ports_write_foreign(ports, _c_name(link), data, len(data), now_ms),
           f"port {link!r}: cannot write foreign bytes (no open port, a transport without it, full or down)")


def ub_ports_close(ports: Any, link: str) -> None:
    ensure(lib.ub_ports_close(ports, _c_name(link)), f"port {link!r} is not open")


def ub_ports_close_all(ports: Any) -> None:
    lib.ub_ports_close_all(ports)


def ub_ports_service(ports: Any, now_ms: int) -> int:
    return int(lib.ub_ports_service(ports, now_ms))


def ub_ports_flush(ports: Any) -> int:
    """Sends what batching ports (udp batch=1) queued; returns the frames a full socket still holds back."""
    return ensure(lib.ub_ports_flush(ports), "ub_ports_flush")


def ub_ports_batching(ports: Any, links: Any) -> bool:
    """True when the open port of one of `links` (names) packs several frames per datagram (udp batch=1)."""
    for link in links:
        p = lib.ub_ports_find(ports, _c_name(link))
        if p != ffi.NULL and p.spec.batch:
            return True
    return False


def pollfd_array() -> Any:
    """Room for ub_ports_pollfds(): POLLFD_CAP `struct pollfd` (allocate once per set of ports)."""
    return ffi.new("struct pollfd[]", POLLFD_CAP)


def ub_ports_pollfds(ports: Any, fds: Any) -> list[tuple[int, int]]:
    """(fd, poll events) pairs, using the caller's `struct pollfd[POLLFD_CAP]` scratch array."""
    n = ensure(lib.ub_ports_pollfds(ports, fds, POLLFD_CAP), "ub_ports_pollfds")
    return [(int(fds[k].fd), int(fds[k].events)) for k in range(n)]


def new_drain(wake_fd: int, idle_us: int, max_us: int, pending: Any, flush_at: int) -> Any:
    """A `ub_ports_drain_t` for ub_ports_drain(): `pending` is a `size_t *` into the caller's output (kept
    alive by the caller), `flush_at` the bytes that end a drain."""
    how = ffi.new("ub_ports_drain_t *")
    how.wake_fd, how.idle_us, how.max_us, how.pending, how.flush_at = wake_fd, idle_us, max_us, pending, flush_at
    return how


def ub_ports_drain(ports: Any, how: Any, now_ms: int) -> int:
    """One drain (ub_ports.h): the ports serviced until their input goes idle or a bound is reached; returns
    the ub_drain_end_t (UB_DRAIN_EMPTY: nothing pending)."""
    rc = lib.ub_ports_drain(ports, how, now_ms)
    if rc < 0:
        ensure(rc, "ub_ports_drain")
    return rc


DRAIN_ENDS = {"flush_idle": lib.UB_DRAIN_IDLE, "flush_full": lib.UB_DRAIN_FULL, "flush_aged": lib.UB_DRAIN_AGED,
              "flush_woken": lib.UB_DRAIN_WOKEN}


def drain_ends(how: Any) -> dict[str, int]:
    """Drains that ended with something to send, by why (ub_drain_end_t)."""
    return {name: int(how.ends[end]) for name, end in DRAIN_ENDS.items()}


def drain_fds(how: Any) -> list[tuple[int, int]]:
    """(fd, poll events) of the ports as the last drain saw them."""
    return [(how.fds[i].fd, how.fds[i].events) for i in range(how.nfds)]


def ub_ports_poll_timeout(ports: Any, now_ms: int, max_ms: int) -> int:
    return int(lib.ub_ports_poll_timeout(ports, now_ms, max_ms))


def ub_ports_local_port(ports: Any, link: str) -> int:
    port = ffi.new("uint16_t *")
    ensure(lib.ub_ports_local_port(ports, _c_name(link), port), f"local port of {link!r}")
    return int(port[0])


def ub_ports_describe(ports: Any, link: str) -> dict[str, Any] | None:
    p = lib.ub_ports_find(ports, _c_name(link))
    if p == ffi.NULL:
        return None
    text = ffi.new("char[]", 256)
    lib.ub_port_spec_format(ffi.addressof(p.spec), text, 256)
    out: dict[str, Any] = {"spec": ffi.string(text).decode("utf-8"),
                           "transport": ffi.string(lib.ub_port_kind_transport(p.spec.kind)).decode("ascii"),
                           "rebinds": int(p.rebinds), "service_errors": int(p.service_errors),
                           "impaired": bool(p.impaired)}
    udp = lib.ub_ports_udp(ports, _c_name(link))
    if udp != ffi.NULL:
        out["udp"] = udp_info(udp)
    else:  # any other driver: its state and counters as the stats event carries them ("tcp": {...})
        text = ffi.new("char[]", 4096)
        if 0 < lib.ub_ports_describe(ports, _c_name(link), text, 4096) < 4096:
            out.update(json.loads("{" + ffi.string(text).decode("utf-8") + "}"))
    if p.impaired:
        s = lib.ub_impair_stats(ffi.addressof(p.impair))
        out["impair"] = {k: int(getattr(s, k)) for k in ("offered", "lost", "duplicated", "reordered", "delayed",
                                                        "queue_full", "passed", "inner_again", "inner_errors",
                                                        "too_big", "rate_waits", "bytes", "shed", "overtaken")}
    return out


UDP_STATS = ("datagrams_in", "rejected", "foreign", "datagrams_out", "again", "send_errors", "frames_in",
             "frames_out", "peers_learned", "peers_forgotten", "no_peer", "copy_errors", "foreign_datagrams", "foreign_refused")
ACCEPT_NAMES = ("peer", "learn", "any")


def udp_info(udp: Any) -> dict[str, Any]:
    """A UDP driver's counters, its accept mode and its peers ("HOST:PORT", in sending order)."""
    out: dict[str, Any] = {k: int(getattr(udp.stats, k)) for k in UDP_STATS}
    out["accept"] = ACCEPT_NAMES[udp.accept] if udp.accept < len(ACCEPT_NAMES) else str(udp.accept)
    host, port, peers = ffi.new("char[16]"), ffi.new("uint16_t *"), []
    while lib.ub_udp_peer_at(udp, len(peers), host, port) == 0:
        peers.append(f"{ffi.string(host).decode('ascii')}:{port[0]}")
    out["peers"] = peers
    return out


def ub_ports_notices(ports: Any) -> list[str]:
    """The one-time notices the ports have for the user (e.g. the first refused UDP sender)."""
    out, text = [], ffi.new("char[]", 512)
    while lib.ub_ports_notice(ports, text, 512) > 0:
        out.append(ffi.string(text).decode("utf-8", "replace"))
    return out


def _impair_params(loss: float, dup: float, reorder: float, delay_ms: int, jitter_ms: int, hold_ms: int,
                   rate: int = 0, mtu: int = 0, prio: bool = False) -> Any:
    params = ffi.new("ub_impair_params_t *")
    for name, p in (("loss", loss), ("dup", dup), ("reorder", reorder)):
        if not 0.0 <= p <= 1.0:
            raise InvalidArgumentError(f"impairment {name}={p}: give a probability between 0 and 1")
    if not 0 <= rate <= 1_000_000_000 or not 0 <= mtu <= 65535:
        raise InvalidArgumentError(f"impairment rate={rate}, mtu={mtu}: give bytes per second (0..10^9) and bytes "
                                   "(0..65535); 0 is no limit")
    params.loss_ppm, params.dup_ppm = round(loss * PPM), round(dup * PPM)
    params.reorder_ppm, params.delay_ms, params.jitter_ms = round(reorder * PPM), delay_ms, jitter_ms
    params.reorder_hold_ms, params.rate_Bps, params.mtu = hold_ms, rate, mtu
    params.prio = 1 if prio else 0
    return params


def ub_ports_set_impairment(ports: Any, loss: float = 0.0, dup: float = 0.0, reorder: float = 0.0,
                            delay_ms: int = 0, jitter_ms: int = 0, hold_ms: int = 0, seed: int = 0,
                            rate: int = 0, mtu: int = 0, prio: bool = False) -> None:
    """Probabilities in 0..1 (converted to parts per million), rate in bytes/s, mtu in bytes, prio: send by
    priority class on the byte budget (ub_prio.h); all zero removes the impairment."""
    params = _impair_params(loss, dup, reorder, delay_ms, jitter_ms, hold_ms, rate, mtu, prio)
    ensure(lib.ub_ports_set_impairment(ports, params, seed), "ub_ports_set_impairment")


def ub_ports_set_link_impairment(ports: Any, link: str, loss: float = 0.0, dup: float = 0.0, reorder: float = 0.0,
                                 delay_ms: int = 0, jitter_ms: int = 0, hold_ms: int = 0, seed: int = 0,
                                 rate: int = 0, mtu: int = 0, prio: bool = False) -> None:
    """One open port's own impairment, over the node-wide one; all zero removes it."""
    params = _impair_params(loss, dup, reorder, delay_ms, jitter_ms, hold_ms, rate, mtu, prio)
    ensure(lib.ub_ports_set_link_impairment(ports, link.encode("utf-8"), params, seed),
           f"port {link!r} is not open")
