"""Wrappers for ub_origin.h: origin authentication (docs/security.md, "Origin authentication").

The C context (ub_origin_t) does every key agreement, tag and check; Python supplies only the identity
store's lookup (an `extern "Python"` callback) and keeps the context and the callback alive with its node.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._bindings.ub_frame import FrameHeader, _header_to_c
from uavbus._ub import ffi, lib

SK_LEN: int = lib.UB_ORIGIN_SK_LEN
PK_LEN: int = lib.UB_ORIGIN_PK_LEN
KEY_LEN: int = lib.UB_ORIGIN_KEY_LEN
PEERS: int = lib.UB_ORIGIN_PEERS
STATS_FIELDS = ("sealed", "opened", "bad_origin", "no_origin", "no_identity", "derivations", "lookups",
                "evictions", "rekeys")

# lookup(entity_id: 12 bytes, now_s) -> the X25519 public key (32 bytes), or None: unknown, revoked, expired.
Lookup = Callable[[bytes, int], "bytes | None"]


def _bytes(value: bytes, n: int, what: str) -> bytes:
    if not isinstance(value, (bytes, bytearray)) or len(value) != n:
        raise InvalidArgumentError(f"{what} must be {n} bytes")
    return bytes(value)


def ub_origin_public_key(sk: bytes) -> bytes:
    """The X25519 public key of secret key `sk`."""
    pk = ffi.new("uint8_t[]", PK_LEN)
    ensure(lib.ub_origin_public_key(_bytes(sk, SK_LEN, "x25519 secret key"), pk), "ub_origin_public_key")
    return bytes(pk)


def ub_origin_pair_keys(self_id: bytes, self_sk: bytes, peer_id: bytes, peer_pk: bytes) -> tuple[bytes, bytes]:
    """(key self -> peer, key peer -> self) of the static-static agreement."""
    tx, rx = ffi.new("uint8_t[]", KEY_LEN), ffi.new("uint8_t[]", KEY_LEN)
    ensure(lib.ub_origin_pair_keys(_bytes(self_id, 12, "entity id"), _bytes(self_sk, SK_LEN, "secret key"),
                                   _bytes(peer_id, 12, "entity id"), _bytes(peer_pk, PK_LEN, "public key"), tx, rx),
           "ub_origin_pair_keys")
    return bytes(tx), bytes(rx)


def ub_origin_tag(key: bytes, header: FrameHeader, payload: bytes) -> bytes:
    """The origin tag of a frame (header fields, `header.origin_hop0`) and its plaintext payload."""
    c = _header_to_c(header)
    c.payload_size = len(payload)
    tag = ffi.new("uint8_t[]", 8)
    ensure(lib.ub_origin_tag(_bytes(key, KEY_LEN, "pairwise key"), c, payload, tag), "ub_origin_tag")
    return bytes(tag)


_NO_STORE = object()   # OriginContext(store=_NO_STORE): no lookup at all (provisioned pairs only)


class OriginContext:
    """A ub_origin_t with its lookup; keep it as long as the node it is attached to. The lookup is a Python
    callback (`lookup`), or an identity store's C lookup (from_store(): no Python on the frame path)."""

    def __init__(self, lookup: Lookup | None, recheck_ms: int = 0, optional: bool = False, *,
                 store: Any = None) -> None:
        self._lookup = lookup
        self._store = store  # kept alive: the C lookup reads it
        self._handle = ffi.new_handle(self)
        self.c = ffi.new("ub_origin_t *")
        opt = ffi.new("ub_origin_options_t *")
        if store is _NO_STORE:
            opt.lookup = ffi.NULL                                    # provisioned pairs only
        elif store is not None:
            opt.lookup = ffi.addressof(lib, "ub_ident_peer_kx_key")  # valid, unrevoked certificates only
            opt.lookup_user = store
            opt.clock_s = ffi.addressof(lib, "ub_identfile_unix_s")  # validity periods: the wall clock
        else:
            opt.lookup = lib.ub_py_origin_lookup
            opt.lookup_user = self._handle
        opt.recheck_ms = recheck_ms
        opt.optional = optional
        ensure(lib.ub_origin_init(self.c, opt), "ub_origin_init")
        self.error: BaseException | None = None  # an exception the lookup raised (the frame was refused)

    @classmethod
    def from_store(cls, store: Any, entity_ids: list[bytes], recheck_ms: int = 0) -> tuple[OriginContext, list[bytes]]:
        """A context over identity store `store` (a ub_ident_store_t *): each of `entity_ids` that has an
        identity there gets its X25519 secret key straight from the store (the key never becomes a Python
        object). Returns the context and the entity IDs that had no identity."""
        ctx = cls(None, recheck_ms, False, store=store)
        missing = []
        for eid in entity_ids:
            sk = lib.ub_ident_self_kx_sk_for(store, _bytes(eid, 12, "entity id"))
            if sk == ffi.NULL:
                missing.append(eid)
                continue
            ensure(lib.ub_origin_add_identity(ctx.c, eid, sk), "ub_origin_add_identity")
        return ctx, missing

    @classmethod
    def provisioned(cls, table: bytes) -> tuple[OriginContext, dict[str, Any]]:
        """A context holding only the pairs of provisioning table `table` (`uavbus keys pairwise`), as the
        microcontroller firmware loads it (ub_origin_load_pairs: no store, no key agreement). Returns the
        context and the table's entity, group key id and key, and number of pairs."""
        ctx = cls(None, 0, False, store=_NO_STORE)
        prov = ffi.new("ub_origin_provision_t *")
        n = ensure(lib.ub_origin_load_pairs(ctx.c, table, len(table), prov),
                   "not a provisioning table (magic, version, length or CRC): write it with uavbus keys pairwise")
        info = {"entity": bytes(prov.entity_id), "pairs": n, "group_key_id": int(prov.group_key_id),
                "group_key": bytes(prov.group_key) if prov.has_group_key else None}
        ffi.memmove(prov, bytes(ffi.sizeof("ub_origin_provision_t")), ffi.sizeof("ub_origin_provision_t"))
        return ctx, info

    def add_pair(self, entity_id: bytes, peer_id: bytes, k_tx: bytes, k_rx: bytes) -> None:
        """A provisioned pair (ub_origin_add_pair): pinned, never asked of the store."""
        ensure(lib.ub_origin_add_pair(self.c, _bytes(entity_id, 12, "entity id"), _bytes(peer_id, 12, "entity id"),
                                      _bytes(k_tx, KEY_LEN, "key"), _bytes(k_rx, KEY_LEN, "key")), "ub_origin_add_pair")

    def add_identity(self, entity_id: bytes, sk: bytes) -> None:
        ensure(lib.ub_origin_add_identity(self.c, _bytes(entity_id, 12, "entity id"), _bytes(sk, SK_LEN, "secret key")),
               "ub_origin_add_identity")

    def attach(self, node: Any) -> None:
        ensure(lib.ub_origin_attach(self.c, node), "ub_origin_attach")

    def detach(self, node: Any) -> None:
        ensure(lib.ub_origin_detach(self.c, node), "ub_origin_detach")

    def forget(self, peer_id: bytes) -> int:
        return int(lib.ub_origin_forget(self.c, _bytes(peer_id, 12, "entity id")))

    def cached(self) -> int:
        return int(lib.ub_origin_cached(self.c))

    def stats(self) -> dict[str, int]:
        s = lib.ub_origin_stats(self.c)
        return {name: int(getattr(s, name)) for name in STATS_FIELDS}

    def _call(self, entity_id: bytes, now_s: int) -> bytes | None:
        try:
            pk = self._lookup(entity_id, now_s)
        except Exception as exc:  # noqa: BLE001 - a failing store refuses the peer (fail closed), reported later
            self.error = exc
            return None
        if pk is None:
            return None
        if len(pk) != PK_LEN:
            self.error = InvalidArgumentError(f"lookup returned {len(pk)} bytes for an X25519 public key, not 32")
            return None
        return bytes(pk)


@ffi.def_extern()
def ub_py_origin_lookup(user: Any, entity_id: Any, now_s: int, pk_out: Any) -> int:
    ctx: OriginContext = ffi.from_handle(user)
    pk = ctx._call(bytes(ffi.buffer(entity_id, 12)), now_s)
    if pk is None:
        return int(lib.UB_ERR_NOTFOUND)
    ffi.memmove(pk_out, pk, PK_LEN)
    return 0
