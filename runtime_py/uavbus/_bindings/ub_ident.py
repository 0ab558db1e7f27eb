"""Wrappers for ub_ident.h and ub_identfile.h: certificates, revocation records, the identity store and
identity files. All encoding, signing and verification is the C runtime's (libsodium); Python only moves
bytes, so certificates have one implementation (issue 23)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._ub import ffi, lib

CERT_LEN: int = lib.UB_CERT_LEN
REVOCATION_LEN: int = lib.UB_REVOCATION_LEN
SEED_LEN: int = lib.UB_IDENT_SEED_LEN
ERR_LEN: int = lib.UB_IDENTFILE_ERR_LEN
ROLES: dict[str, int] = {"admin": lib.UB_ROLE_ADMIN, "vehicle": lib.UB_ROLE_VEHICLE, "relay": lib.UB_ROLE_RELAY,
                         "bridge": lib.UB_ROLE_BRIDGE, "observer": lib.UB_ROLE_OBSERVER}


@dataclass(frozen=True)
class Certificate:
    """A decoded certificate (ub_cert_t)."""

    roles: int
    serial: int
    entity: bytes  # 12 bytes
    sign_pk: bytes
    kx_pk: bytes
    not_before: int
    not_after: int
    authority: bytes  # 8-byte key id
    signature: bytes
    version: int = 1

    @property
    def entity_name(self) -> str:
        return self.entity.rstrip(b"\0").decode("ascii", "replace")

    @property
    def role_names(self) -> list[str]:
        return [name for name, bit in ROLES.items() if self.roles & bit]


@dataclass(frozen=True)
class Revocation:
    """A decoded revocation record (ub_revocation_t)."""

    serial: int
    entity: bytes
    time_s: int
    authority: bytes
    signature: bytes

    @property
    def entity_name(self) -> str:
        return self.entity.rstrip(b"\0").decode("ascii", "replace")


def _text(err: Any) -> str:
    return ffi.string(err).decode("utf-8", "replace")


def _path(path: Any) -> bytes:
    raw = str(path).encode("utf-8")
    if b"\0" in raw:
        raise InvalidArgumentError(f"path {path!r} contains a NUL byte")
    return raw


def _cert_from_c(c: Any) -> Certificate:
    return Certificate(roles=int(c.roles), serial=int(c.serial), entity=bytes(c.entity), sign_pk=bytes(c.sign_pk),
                       kx_pk=bytes(c.kx_pk), not_before=int(c.not_before), not_after=int(c.not_after),
                       authority=bytes(c.authority), signature=bytes(c.sig), version=int(c.version))


def _cert_to_c(cert: Certificate) -> Any:
    c = ffi.new("ub_cert_t *")
    c.version = cert.version
    c.roles = cert.roles
    c.serial = cert.serial
    c.entity = cert.entity
    c.sign_pk = cert.sign_pk
    c.kx_pk = cert.kx_pk
    c.not_before = cert.not_before
    c.not_after = cert.not_after
    c.authority = cert.authority
    c.sig = cert.signature
    return c


def status_name(status: int) -> str:
    return ffi.string(lib.ub_ident_status_name(status)).decode()


def entity_id(name: str) -> bytes:
    raw = name.encode("ascii")
    if not 1 <= len(raw) <= 12:
        raise InvalidArgumentError(f"entity name {name!r}: 1 to 12 characters")
    return raw + bytes(12 - len(raw))


def random_seed() -> bytes:
    out = ffi.new("uint8_t[]", SEED_LEN)
    ensure(lib.ub_ident_random(out, SEED_LEN), "random")
    return bytes(out)


def sign_keypair(seed: bytes) -> tuple[bytes, bytes]:
    """(public key, libsodium's 64-byte secret key) of an Ed25519 seed."""
    pk, sk = ffi.new("uint8_t[]", 32), ffi.new("uint8_t[]", 64)
    ensure(lib.ub_ident_sign_keypair(seed, pk, sk), "Ed25519 key pair")
    return bytes(pk), bytes(sk)


def kx_keypair(seed: bytes) -> tuple[bytes, bytes]:
    """(public, secret) X25519 key pair of a seed (crypto_kx_seed_keypair)."""
    pk, sk = ffi.new("uint8_t[]", 32), ffi.new("uint8_t[]", 32)
    ensure(lib.ub_ident_kx_keypair(seed, pk, sk), "X25519 key pair")
    return bytes(pk), bytes(sk)


def authority_kid(pk: bytes) -> bytes:
    out = ffi.new("uint8_t[]", 8)
    ensure(lib.ub_ident_authority_kid(pk, out), "authority key id")
    return bytes(out)


def cert_sign(cert: Certificate, authority_sk: bytes) -> tuple[Certificate, bytes]:
    """Signs `cert` (its authority key id set from the key): (the signed certificate, its 176 bytes)."""
    c = _cert_to_c(cert)
    ensure(lib.ub_cert_sign(c, authority_sk), "certificate fields out of their domain (roles, serial, entity, period)")
    out = ffi.new("uint8_t[]", CERT_LEN)
    ensure(lib.ub_cert_encode(c, out), "encode")
    return _cert_from_c(c), bytes(out)


def cert_decode(data: bytes) -> Certificate:
    c = ffi.new("ub_cert_t *")
    ensure(lib.ub_cert_decode(c, data, len(data)), "not a version-1 certificate")
    return _cert_from_c(c)


def cert_verify(cert: Certificate, authority_pk: bytes) -> str:
    """'valid', 'wrong_authority', 'bad_signature' or 'malformed'."""
    return status_name(lib.ub_cert_verify(_cert_to_c(cert), authority_pk))


def revocation_sign(entity: bytes, serial: int, time_s: int, authority_sk: bytes) -> bytes:
    r = ffi.new("ub_revocation_t *")
    r.entity = entity
    r.serial = serial
    r.time_s = time_s
    ensure(lib.ub_revocation_sign(r, authority_sk), "revocation fields out of their domain")
    out = ffi.new("uint8_t[]", REVOCATION_LEN)
    ensure(lib.ub_revocation_encode(r, out), "encode")
    return bytes(out)


def revocation_decode(data: bytes) -> Revocation:
    r = ffi.new("ub_revocation_t *")
    ensure(lib.ub_revocation_decode(r, data, len(data)), "not a version-1 revocation record")
    return Revocation(serial=int(r.serial), entity=bytes(r.entity), time_s=int(r.time_s),
                      authority=bytes(r.authority), signature=bytes(r.sig))


# ---- files ----

def identfile_write(path: Any, cert: Certificate, sign_seed: bytes, kx_sk: bytes, force: bool = False) -> None:
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_identfile_write(_path(path), _cert_to_c(cert), sign_seed, kx_sk, force, err, ERR_LEN),
           _text(err) or str(path))


def identfile_load(path: Any) -> tuple[Certificate, bytes, bytes]:
    """(certificate, Ed25519 secret key, X25519 secret key); refused when group/other-accessible or damaged."""
    c = ffi.new("ub_cert_t *")
    sk, kx = ffi.new("uint8_t[]", 64), ffi.new("uint8_t[]", 32)
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_identfile_load(_path(path), c, sk, kx, err, ERR_LEN), _text(err) or str(path))
    return _cert_from_c(c), bytes(sk), bytes(kx)


def authfile_write_secret(path: Any, seed: bytes) -> None:
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_authfile_write_secret(_path(path), seed, err, ERR_LEN), _text(err) or str(path))


def authfile_write_public(path: Any, pk: bytes, force: bool = False) -> None:
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_authfile_write_public(_path(path), pk, force, err, ERR_LEN), _text(err) or str(path))


def authfile_load_secret(path: Any) -> bytes:
    sk = ffi.new("uint8_t[]", 64)
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_authfile_load_secret(_path(path), sk, err, ERR_LEN), _text(err) or str(path))
    return bytes(sk)


def authfile_load_public(path: Any) -> bytes:
    pk = ffi.new("uint8_t[]", 32)
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_authfile_load_public(_path(path), pk, err, ERR_LEN), _text(err) or str(path))
    return bytes(pk)


def certfile_put(path: Any, cert: bytes) -> None:
    """Puts a certificate into the fleet's certificates file (replacing the entity's older one)."""
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_certfile_put(_path(path), cert, len(cert), err, ERR_LEN), _text(err) or str(path))


class Store:
    """An identity store (ub_ident_store_t, about 19 kB, owned by this object)."""

    def __init__(self, authority_pk: bytes | None = None) -> None:
        self._s = ffi.new("ub_ident_store_t *")
        lib.ub_ident_store_init(self._s)
        if authority_pk is not None:
            ensure(lib.ub_ident_set_authority(self._s, authority_pk), "authority")

    @classmethod
    def load(cls, authority: Any, identity: Any = None, revocations: Any = None, now_s: int = 0) -> Store:
        """A node's set-up from its files (ub_identfile_load_store): refusals say what to do."""
        s = cls()
        err = ffi.new("char[]", ERR_LEN)
        ensure(lib.ub_identfile_load_store(s._s, _path(identity) if identity is not None else ffi.NULL,
                                           _path(authority), _path(revocations) if revocations is not None else ffi.NULL,
                                           now_s, err, ERR_LEN), _text(err) or str(authority))
        return s

    @property
    def c(self) -> Any:
        return self._s

    def add_peer(self, cert: bytes, now_s: int) -> str:
        """'valid' when taken, else why not (the store counts it)."""
        why = ffi.new("ub_ident_status_t *")
        rc = lib.ub_ident_add_peer(self._s, cert, len(cert), now_s, why)
        if rc == lib.UB_ERR_FULL:
            return "full"
        return "valid" if rc == 0 else status_name(why[0])

    def add_revocation(self, record: bytes) -> str:
        """'added', 'known' (already covered), 'full', or why it was refused."""
        why = ffi.new("ub_ident_status_t *")
        rc = lib.ub_ident_add_revocation(self._s, record, len(record), why)
        if rc >= 0:
            return "added"
        if rc == lib.UB_ERR_EXISTS:
            return "known"
        if rc == lib.UB_ERR_FULL:
            return "full"
        return status_name(why[0])

    def revocations(self) -> list[bytes]:
        out = []
        buf = ffi.new("uint8_t[]", REVOCATION_LEN)
        for i in range(lib.ub_ident_revocation_count(self._s)):
            ensure(lib.ub_ident_revocation_at(self._s, i, buf), "revocation")
            out.append(bytes(buf))
        return out

    def load_revocations(self, path: Any) -> int:
        err = ffi.new("char[]", ERR_LEN)
        return ensure(lib.ub_revfile_load(_path(path), self._s, err, ERR_LEN), _text(err) or str(path))

    def load_certificates(self, path: Any, now_s: int) -> int:
        err = ffi.new("char[]", ERR_LEN)
        return ensure(lib.ub_certfile_load(_path(path), self._s, now_s, err, ERR_LEN), _text(err) or str(path))

    def save_revocations(self, path: Any) -> None:
        err = ffi.new("char[]", ERR_LEN)
        ensure(lib.ub_revfile_save(_path(path), self._s, err, ERR_LEN), _text(err) or str(path))

    def status(self, entity: bytes, now_s: int) -> str:
        return status_name(lib.ub_ident_peer_status(self._s, entity, now_s))

    def kx_key(self, entity: bytes, now_s: int) -> bytes:
        pk = ffi.new("uint8_t[]", 32)
        ensure(lib.ub_ident_peer_kx_key(self._s, entity, now_s, pk), f"no valid identity for {entity!r}")
        return bytes(pk)

    def roles(self, entity: bytes, now_s: int) -> int:
        out = ffi.new("uint16_t *")
        ensure(lib.ub_ident_peer_roles(self._s, entity, now_s, out), f"no valid identity for {entity!r}")
        return int(out[0])

    def self_cert(self) -> Certificate | None:
        c = lib.ub_ident_self(self._s)
        return None if c == ffi.NULL else _cert_from_c(c)


class NodeIdentity:
    """A node's identity from its configuration (ub_nodecfg_apply_identity): the store, authorization by
    certified role, and the revocation service (ub_revoke.h) registered with the node. Keeps every C
    object the node points to alive as long as itself."""

    def __init__(self, cfg: Any, node: Any, now_s: int) -> None:
        self.store = Store()
        self._path = ffi.new("char[]", 512)
        cap = 2 * ERR_LEN
        err = ffi.new("char[]", cap)
        ensure(lib.ub_nodecfg_apply_identity(cfg, node, self.store.c, now_s, self._path, 512, err, cap),
               _text(err) or "ub_nodecfg_apply_identity")
        self._rv = ffi.new("ub_revoke_t *")
        self._opt = ffi.new("ub_revoke_options_t *")
        self._opt.clock_s = ffi.addressof(lib, "ub_identfile_unix_s")  # certificates' validity: the wall clock
        persist = ffi.addressof(lib, "ub_revfile_persist") if self._path[0] != b"\0" else ffi.NULL
        ensure(lib.ub_revoke_init(self._rv, node, self.store.c, self._opt, persist,
                                  self._path if persist != ffi.NULL else ffi.NULL), "revocation service")
        # certificates spread too: its own are announced, new ones learned go to the certificates file
        self._certs = ffi.new("char[]", 512)
        ensure(lib.ub_nodecfg_certificates_path(cfg, self._certs, 512), "security.certificates: path too long")
        persist_cert = ffi.addressof(lib, "ub_certfile_persist") if self._certs[0] != b"\0" else ffi.NULL
        ensure(lib.ub_revoke_spread_certificates(self._rv, persist_cert,
                                                 self._certs if persist_cert != ffi.NULL else ffi.NULL, 0),
               "certificates")

    def forget_on_revocation(self, origin: Any) -> None:
        """Hands every accepted revocation (or new certificate) to origin context `origin` (a ub_origin_t *):
        the peer's cached pairwise keys go at once (ub_origin_forget_hook, all in C)."""
        ensure(lib.ub_revoke_set_peer_hook(self._rv, ffi.addressof(lib, "ub_origin_forget_hook"), origin),
               "ub_revoke_set_peer_hook")
        self._origin = origin

    def submit(self, record: bytes, now_ms: int) -> str:
        """A revocation record from the operator: 'accepted', 'known', or why it was refused."""
        rc = lib.ub_revoke_submit(self._rv, record, len(record), now_ms)
        if rc == 0:
            return "accepted"
        if rc == lib.UB_ERR_EXISTS:
            return "known"
        return "full" if rc == lib.UB_ERR_FULL else "refused"

    def stats(self) -> dict[str, int]:
        st = lib.ub_revoke_stats(self._rv)
        return {name: int(getattr(st, name)) for name in ("received", "accepted", "known", "refused", "full",
                                                           "over_budget", "sent", "unsent", "persisted",
                                                           "persist_failures", "certs_received", "certs_accepted",
                                                           "certs_known", "certs_refused", "certs_sent",
                                                           "certs_dropped")}

    def submit_certificate(self, cert: bytes, now_ms: int) -> str:
        """A certificate from the operator (a new entity, a replacement): 'accepted', 'known' or 'refused'."""
        rc = lib.ub_revoke_submit_certificate(self._rv, cert, len(cert), now_ms)
        return "accepted" if rc == 0 else "known" if rc == lib.UB_ERR_EXISTS else "refused"


def cfg_has_identity(cfg: Any) -> bool:
    return bool(cfg.identity.present)
