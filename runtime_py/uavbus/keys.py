"""`uavbus keys`: key files for signed frames, and identities per entity (docs/security.md).

    uavbus keys new FILE [--id N]    a new random group key, written mode 0600 (never over an existing file);
                                     prints its id
    uavbus keys show FILE            what a key, identity, authority or revocations file holds (checked as a
                                     node reads it; never a secret)

    uavbus keys authority create [--dir DIR]
                                     the fleet authority: DIR/authority.key (secret, 0600: keep it offline),
                                     DIR/authority.pub (every node's copy), DIR/authority.issued (the ledger
                                     of issued serials)
    uavbus keys issue ENTITY --roles admin,vehicle,... [--days N] [--out FILE] [--force]
                                     the entity's identity (certificate + secret keys, mode 0600), default
                                     DIR/ENTITY.id, with the next serial; refuses to overwrite without --force;
                                     its certificate goes into DIR/fleet.certs (the nodes' "certificates")
    uavbus keys revoke ENTITY [--serial N] [--out FILE]
                                     a signed revocation record of ENTITY's serials up to its last one (or N),
                                     added to the revocations file (default DIR/revocations.ubr)

    uavbus keys fleet CONFIG --out DIR [--admins gcs1,...] [--roles ENTITY=ROLES]... [--days N] [--force]
                                     every entity of a configuration at once: the authority (made if DIR has
                                     none), one identity per entity (DIR/ENTITY.id, 0600), DIR/fleet.certs and
                                     each node's own copy DIR/ENTITY.certs, the group key DIR/fleet-1.key (made
                                     if absent: origin tags ride on signed frames), and DIR/STEM.identity.json:
                                     the configuration with a "security" section naming all of them.
                                     Roles: --admins (default: the config's security.administrators, else every
                                     entity whose name starts with "gcs": the ground stations) get `admin`;
                                     every other entity `vehicle`, plus `relay` when it has more than one link
                                     (it can forward between them); --roles ENTITY=ROLES overrides one entity;
                                     --mcu ENTITY also writes ENTITY's pairwise table (below).

    uavbus keys pairwise ENTITY [--dir DIR] [--out FILE] [--peers a,b,...]
                                     for a microcontroller entity (no X25519 on board): the table of its
                                     directional origin keys with each valid, unrevoked peer of DIR/fleet.certs
                                     (the keys those peers derive from ENTITY's certificate) and the group key
                                     DIR/fleet-1.key, default DIR/ENTITY.pairs (mode 0600): the firmware's
                                     PROVISION flash sector (docs/security.md, "Microcontrollers"). Run it again
                                     after a revocation or a new peer: the board's revocation is its new table.

Re-keying a lost vehicle's replacement: `uavbus keys revoke rmax1ob1` then
`uavbus keys issue rmax1ob1 --roles vehicle --force` (a new serial; the old one stays refused).

Every key and certificate is made, signed and written by the C runtime (ub_secfile.h, ub_ident.h,
ub_identfile.h through cffi), the same code uavbus_node and Node use to read them.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time
from pathlib import Path

from uavbus._bindings import ub_ident, ub_sec
from uavbus._bindings.ub_error import UbError

DEFAULT_DIR = "keys"
CERTS_NAME = "fleet.certs"  # next to the authority key: every issued certificate, the nodes' "certificates"
LEDGER_HEADER = "# uavbus authority ledger: serial entity not_after (one line per issued identity; append-only)\n"


class KeysError(Exception):
    """A refusal of the CLI itself (one line: what is wrong and what to do)."""


def _authority_paths(authority: str | None, directory: str) -> tuple[Path, Path, Path]:
    key = Path(authority) if authority else Path(directory) / "authority.key"
    return key, key.with_suffix(".pub"), key.with_suffix(".issued")


def _ledger(path: Path) -> list[tuple[int, str, int]]:
    rows = []
    if not path.exists():
        return rows
    for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) != 3 or not parts[0].isdigit() or not parts[2].isdigit():
            raise KeysError(f"{path}:{lineno}: not a ledger line 'serial entity not_after' (restore the ledger from "
                            "its backup)")
        rows.append((int(parts[0]), parts[1], int(parts[2])))
    return rows


def _entity(name: str) -> bytes:
    if not re.fullmatch(r"[A-Za-z0-9_.-]{1,12}", name):
        raise KeysError(f"'{name}': an entity name is 1 to 12 characters of A-Z a-z 0-9 _ . - (as in the config)")
    return ub_ident.entity_id(name)


def _roles(text: str) -> int:
    bits = 0
    for name in filter(None, (n.strip() for n in text.split(","))):
        if name not in ub_ident.ROLES:
            raise KeysError(f"--roles: unknown role '{name}' (roles: {', '.join(ub_ident.ROLES)})")
        bits |= ub_ident.ROLES[name]
    return bits


def authority_create(directory: str) -> str:
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    key, pub, ledger = _authority_paths(None, directory)
    seed = ub_ident.random_seed()
    ub_ident.authfile_write_secret(key, seed)
    pk, _ = ub_ident.sign_keypair(seed)
    ub_ident.authfile_write_public(pub, pk, force=True)
    if not ledger.exists():
        fd = os.open(ledger, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(LEDGER_HEADER)
    return f"{key} (keep it offline), {pub} (copy to every node); key id {ub_ident.authority_kid(pk).hex()}"


def issue(entity: str, roles: str, days: int, authority: str | None, directory: str, out: str | None,
          force: bool, now: int | None = None) -> str:
    key, _, ledger_path = _authority_paths(authority, directory)
    if days < 1:
        raise KeysError(f"--days {days}: an identity is valid for at least 1 day")
    eid = _entity(entity)
    bits = _roles(roles)
    sk = ub_ident.authfile_load_secret(key)
    rows = _ledger(ledger_path)
    serial = max((r[0] for r in rows), default=0) + 1
    now = int(time.time()) if now is None else now
    sign_seed, kx_seed = ub_ident.random_seed(), ub_ident.random_seed()
    sign_pk, _ = ub_ident.sign_keypair(sign_seed)
    kx_pk, kx_sk = ub_ident.kx_keypair(kx_seed)
    cert = ub_ident.Certificate(roles=bits, serial=serial, entity=eid, sign_pk=sign_pk, kx_pk=kx_pk, not_before=now,
                                not_after=now + days * 86400, authority=bytes(8), signature=bytes(64))
    signed, cert_bytes = ub_ident.cert_sign(cert, sk)
    path = Path(out) if out else Path(directory) / f"{entity}.id"
    ub_ident.identfile_write(path, signed, sign_seed, kx_sk, force=force)
    ub_ident.certfile_put(key.with_name(CERTS_NAME), cert_bytes)
    # The ledger is written after the file: a refused overwrite uses no serial.
    fd = os.open(ledger_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600)
    with os.fdopen(fd, "a", encoding="utf-8") as f:
        if not rows and f.tell() == 0:
            f.write(LEDGER_HEADER)
        f.write(f"{serial} {entity} {signed.not_after}\n")
        f.flush()
        os.fsync(f.fileno())
    return (f"{path}: {entity} serial {serial}, roles {','.join(signed.role_names) or '-'}, valid {days} days; "
            f"certificate added to {key.with_name(CERTS_NAME)}")


def revoke(entity: str, serial: int | None, authority: str | None, directory: str, out: str | None,
           now: int | None = None) -> str:
    key, _, ledger_path = _authority_paths(authority, directory)
    eid = _entity(entity)
    if serial is None:
        issued = [r[0] for r in _ledger(ledger_path) if r[1] == entity]
        if not issued:
            raise KeysError(f"{ledger_path}: no identity issued to '{entity}' (give the serial: --serial N)")
        serial = max(issued)
    sk = ub_ident.authfile_load_secret(key)
    record = ub_ident.revocation_sign(eid, serial, int(time.time()) if now is None else now, sk)
    path = Path(out) if out else Path(directory) / "revocations.ubr"
    store = ub_ident.Store(sk[32:])
    if path.exists():
        store.load_revocations(path)
    outcome = store.add_revocation(record)
    if outcome not in ("added", "known"):
        raise KeysError(f"{path}: the record was refused ({outcome})")
    store.save_revocations(path)
    return (f"{path}: {entity} revoked up to serial {serial}" + (" (already)" if outcome == "known" else "")
            + f"; send it to the fleet: revoke {path} on any node's stdin")


def _when(t: int) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%SZ", time.gmtime(t)) if t < 2**40 else str(t)


def show(path: str) -> str:
    p = Path(path)
    try:
        with open(p, "rb") as f:
            head = f.read(8)  # the magic only: a secret file is read (and its mode checked) by the C loader
    except OSError as e:
        raise KeysError(f"{path}: cannot read: {e.strerror}") from None
    magic = head[:4]
    if magic == b"UBID":
        cert, _, _ = ub_ident.identfile_load(path)
        return _describe(cert, path)
    if magic == b"UBAK":
        sk = ub_ident.authfile_load_secret(path)
        return f"{path}: authority secret key, key id {ub_ident.authority_kid(sk[32:]).hex()}"
    if magic == b"UBAP":
        pk = ub_ident.authfile_load_public(path)
        return f"{path}: authority public key, key id {ub_ident.authority_kid(pk).hex()}"
    if magic == b"UBCS":
        data = p.read_bytes()[8:]
        lines = [f"{path}: certificates, {len(data) // ub_ident.CERT_LEN}"]
        for i in range(0, len(data) - ub_ident.CERT_LEN + 1, ub_ident.CERT_LEN):
            c = ub_ident.cert_decode(data[i:i + ub_ident.CERT_LEN])
            lines.append(f"  {c.entity_name}: serial {c.serial}, roles {','.join(c.role_names) or '-'}, "
                         f"{_when(c.not_before)} .. {_when(c.not_after)}")
        return "\n".join(lines)
    if magic == b"UBRV":
        data = p.read_bytes()[8:]
        lines = [f"{path}: revocations, {len(data) // ub_ident.REVOCATION_LEN} record(s)"]
        for i in range(0, len(data) - ub_ident.REVOCATION_LEN + 1, ub_ident.REVOCATION_LEN):
            r = ub_ident.revocation_decode(data[i:i + ub_ident.REVOCATION_LEN])
            lines.append(f"  {r.entity_name}: serials up to {r.serial} revoked at {_when(r.time_s)} by authority "
                         f"{r.authority.hex()}")
        return "\n".join(lines)
    key_id, _ = ub_sec.ub_keyfile_load(path)
    return str(key_id)


def _describe(cert: ub_ident.Certificate, path: str) -> str:
    now = int(time.time())
    state = "expired" if now > cert.not_after else "not yet valid" if now < cert.not_before else "valid"
    return (f"{path}: identity of {cert.entity_name}, serial {cert.serial}, roles "
            f"{','.join(cert.role_names) or '-'}, {state} {_when(cert.not_before)} .. {_when(cert.not_after)}, "
            f"authority {cert.authority.hex()}, Ed25519 {cert.sign_pk.hex()[:16]}..., X25519 {cert.kx_pk.hex()[:16]}...")


def fleet_roles(doc: dict, admins: list[str] | None = None,
                overrides: dict[str, str] | None = None) -> dict[str, str]:
    """Each entity of configuration `doc` and its roles (the rule in this module's docstring)."""
    names = [e["name"] for e in doc.get("entities", []) if isinstance(e, dict) and "name" in e]
    if admins is None:
        admins = list(doc.get("security", {}).get("administrators", [])) or [n for n in names if n.startswith("gcs")]
    unknown = [a for a in admins if a not in names] + [e for e in (overrides or {}) if e not in names]
    if unknown:
        raise KeysError(f"{', '.join(unknown)}: not an entity of the configuration (its entities: {', '.join(names)})")
    roles = {}
    for e in doc.get("entities", []):
        name = e["name"]
        if name in admins:
            roles[name] = "admin"
        else:
            roles[name] = "vehicle,relay" if len(e.get("links", [])) > 1 else "vehicle"
    for name, r in (overrides or {}).items():
        _roles(r)  # refuses an unknown role
        roles[name] = r
    return roles


def fleet(config: str, out: str, admins: list[str] | None = None, overrides: dict[str, str] | None = None,
          days: int = 365, force: bool = False, now: int | None = None) -> tuple[Path, dict[str, str]]:
    """`uavbus keys fleet`: identities for every entity of `config` under `out`; returns the identity
    configuration written (DIR/STEM.identity.json) and each entity's roles."""
    import json

    src = Path(config)
    try:
        doc = json.loads(src.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise KeysError(f"{src}: {exc} (give a uavbus configuration file)") from None
    roles = fleet_roles(doc, admins, overrides)
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    (d / "state").mkdir(exist_ok=True)
    if not (d / "authority.key").exists():
        authority_create(str(d))
    for entity, r in roles.items():
        issue(entity, r, days, None, str(d), None, force, now)
    certs = (d / CERTS_NAME).read_bytes()
    for entity in roles:  # each node its own copy: a node rewrites its copy when it learns a certificate
        (d / f"{entity}.certs").write_bytes(certs)
    group = d / "fleet-1.key"
    if not group.exists():
        ub_sec.ub_keyfile_new(str(group), 1)
    security = dict(doc.get("security", {}))
    security.update({"keys": [group.name], "counter_file": "state/{entity}.counter",
                     "authority": "authority.pub", "identity": "{entity}.id", "certificates": "{entity}.certs",
                     "revocations": "state/{entity}.revocations.ubr"})
    security.pop("tx_key", None)
    doc["security"] = security
    target = d / f"{src.stem}.identity.json"
    target.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return target, roles


def pairwise(entity: str, directory: str, out: str | None = None, peers: list[str] | None = None,
             now: int | None = None) -> tuple[Path, list[str]]:
    """`uavbus keys pairwise`: ENTITY's provisioning table (ub_origin.h, UB_ORIGIN_PAIRS_MAGIC); returns its path
    and the peers in it. Every key in it is computed by the C runtime (ub_origin_pair_keys: X25519, BLAKE2b,
    KDF) from ENTITY's X25519 secret key and each peer's certified public key: what the peers derive."""
    import struct

    from uavbus._bindings import ub_frame, ub_origin

    d = Path(directory)
    now_s = int(time.time()) if now is None else now
    ident = d / f"{entity}.id"
    if not ident.exists():
        raise KeysError(f"{ident}: no identity for {entity}; issue it first (uavbus keys issue {entity} --roles "
                        "vehicle --dir " + str(d) + ")")
    cert, _sign, kx_sk = ub_ident.identfile_load(ident)
    store = ub_ident.Store.load(d / "authority.pub", None,
                                d / "revocations.ubr" if (d / "revocations.ubr").exists() else None, now_s)
    data = (d / CERTS_NAME).read_bytes() if (d / CERTS_NAME).exists() else b""
    header = 8
    if len(data) < header or (len(data) - header) % ub_ident.CERT_LEN:
        raise KeysError(f"{d / CERTS_NAME}: not a certificates file (uavbus keys issue writes it)")
    rows: list[tuple[bytes, bytes, bytes]] = []
    names: list[str] = []
    for k in range(header, len(data), ub_ident.CERT_LEN):
        raw = data[k:k + ub_ident.CERT_LEN]
        c = ub_ident.cert_decode(raw)
        if c.entity == cert.entity or (peers is not None and c.entity_name not in peers):
            continue
        if store.add_peer(raw, now_s) != "valid":      # expired, revoked, another authority's: no pair
            continue
        k_tx, k_rx = ub_origin.ub_origin_pair_keys(cert.entity, kx_sk, c.entity, c.kx_pk)
        rows.append((c.entity, k_tx, k_rx))
        names.append(c.entity_name)
    if len(rows) > 255:
        raise KeysError(f"{entity}: {len(rows)} peers; a table holds 255 (name them with --peers)")
    missing = sorted(set(peers or []) - set(names))
    if missing:
        raise KeysError(f"--peers: no valid certificate in {d / CERTS_NAME} for {', '.join(missing)}")
    group = d / "fleet-1.key"
    key_id, key = ub_sec.ub_keyfile_load(str(group)) if group.exists() else (0, bytes(32))
    body = (b"UBPR" + bytes([1, len(rows), 0, 0]) + cert.entity + bytes([key_id, 1 if group.exists() else 0, 0, 0])
            + key + b"".join(p + t + r for p, t, r in rows))
    table = body + struct.pack("<I", ub_frame.ub_crc32c(body))
    target = Path(out) if out else d / f"{entity}.pairs"
    tmp = target.with_name(target.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(table)
    os.chmod(tmp, 0o600)
    os.replace(tmp, target)
    return target, names


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="uavbus keys",
                                     description="group keys and per-entity identities (docs/security.md)")
    sub = parser.add_subparsers(dest="cmd", required=True)
    new = sub.add_parser("new", help="write a new random group key to FILE (mode 0600) and print its id")
    new.add_argument("file")
    new.add_argument("--id", type=int, default=0, metavar="N",
                     help="key id 1..255 (default: random); receivers tell keys apart by it")
    show_p = sub.add_parser("show", help="what a key, identity, authority or revocations file holds")
    show_p.add_argument("file")
    auth = sub.add_parser("authority", help="the fleet authority")
    auth_sub = auth.add_subparsers(dest="auth_cmd", required=True)
    create = auth_sub.add_parser("create", help="make the authority's key pair (never over an existing one)")
    create.add_argument("--dir", default=DEFAULT_DIR)
    iss = sub.add_parser("issue", help="issue ENTITY an identity (certificate + secret keys, mode 0600)")
    iss.add_argument("entity")
    iss.add_argument("--roles", required=True, help=f"comma-separated: {', '.join(ub_ident.ROLES)}")
    iss.add_argument("--days", type=int, default=365)
    iss.add_argument("--dir", default=DEFAULT_DIR)
    iss.add_argument("--authority", help="the authority's secret key file (default DIR/authority.key)")
    iss.add_argument("--out", help="the identity file (default DIR/ENTITY.id)")
    iss.add_argument("--force", action="store_true", help="replace an existing identity file (after a revocation)")
    rev = sub.add_parser("revoke", help="revoke ENTITY's identities (a signed record in the revocations file)")
    rev.add_argument("entity")
    rev.add_argument("--serial", type=int, help="revoke serials up to N (default: the last one issued to ENTITY)")
    rev.add_argument("--dir", default=DEFAULT_DIR)
    rev.add_argument("--authority", help="the authority's secret key file (default DIR/authority.key)")
    rev.add_argument("--out", help="the revocations file (default DIR/revocations.ubr)")
    fl = sub.add_parser("fleet", help="identities for every entity of a configuration, and the config naming them")
    fl.add_argument("config")
    fl.add_argument("--out", required=True, metavar="DIR", help="where the authority, identities and config go")
    fl.add_argument("--admins", help="comma-separated administrators (default: the config's security.administrators,"
                                     " else entities named gcs*)")
    fl.add_argument("--roles", action="append", default=[], metavar="ENTITY=ROLES",
                    help="one entity's roles, e.g. fcs20=vehicle,observer (repeatable)")
    fl.add_argument("--days", type=int, default=365)
    fl.add_argument("--force", action="store_true", help="replace existing identity files (new keys and serials)")
    fl.add_argument("--mcu", action="append", default=[], metavar="ENTITY",
                    help="also write ENTITY's pairwise table DIR/ENTITY.pairs (a microcontroller: uavbus keys "
                         "pairwise); repeatable")
    pw = sub.add_parser("pairwise", help="a microcontroller entity's table of pairwise origin keys (no X25519 on board)")
    pw.add_argument("entity")
    pw.add_argument("--dir", default=DEFAULT_DIR)
    pw.add_argument("--out", help="the table (default DIR/ENTITY.pairs, mode 0600)")
    pw.add_argument("--peers", help="comma-separated peers (default: every valid certificate of DIR/fleet.certs)")
    args = parser.parse_args(argv)
    try:
        if args.cmd == "new":
            if not 1 <= args.id <= 255 and args.id != 0:
                print(f"uavbus keys: --id {args.id}: a key id is 1..255", file=sys.stderr)
                return 2
            print(ub_sec.ub_keyfile_new(args.file, args.id))
        elif args.cmd == "show":
            print(show(args.file))
        elif args.cmd == "authority":
            print(authority_create(args.dir))
        elif args.cmd == "fleet":
            overrides = {}
            for item in args.roles:
                entity, sep, r = item.partition("=")
                if not sep:
                    raise KeysError(f"--roles {item}: expected ENTITY=ROLES, e.g. fcs20=vehicle")
                overrides[entity] = r
            admins = [a for a in args.admins.split(",") if a] if args.admins is not None else None
            if args.mcu:   # refused before anything is written
                import json

                try:
                    names = [e.get("name") for e in json.loads(Path(args.config).read_text(encoding="utf-8"))["entities"]]
                except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
                    raise KeysError(f"{args.config}: {exc} (give a uavbus configuration file)") from None
                for mcu in args.mcu:
                    if mcu not in names:
                        raise KeysError(f"--mcu {mcu}: not an entity of {args.config} ({', '.join(map(str, names))})")
            target, roles = fleet(args.config, args.out, admins, overrides, args.days, args.force)
            for entity, r in roles.items():
                print(f"{entity}: {r}")
            print(f"{target}: the configuration naming them (copy {args.out} to the nodes: each needs authority.pub, "
                  "its ENTITY.id and ENTITY.certs, fleet-1.key; keep authority.key offline)")
            for mcu in args.mcu:
                table, names = pairwise(mcu, args.out)
                print(f"{table}: {mcu}'s pairwise keys with {', '.join(names)} (flash it to the board's PROVISION "
                      "sector)")
        elif args.cmd == "pairwise":
            wanted = [p for p in args.peers.split(",") if p] if args.peers else None
            target, names = pairwise(args.entity, args.dir, args.out, wanted)
            print(f"{target}: {args.entity}'s pairwise keys with {', '.join(names) or 'nobody'} and the group key "
                  "(mode 0600: the board's PROVISION sector; QEMU: -device loader,file=...,addr=0x1F000)")
        elif args.cmd == "issue":
            print(issue(args.entity, args.roles, args.days, args.authority, args.dir, args.out, args.force))
        else:
            print(revoke(args.entity, args.serial, args.authority, args.dir, args.out))
    except UbError as e:
        # the C message already names the file and says what to do; the code name adds nothing
        print(str(e).removeprefix(f"{e.name}: "), file=sys.stderr)
        return 1
    except KeysError as e:
        print(e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())


def x25519_public_key(secret: bytes) -> bytes:
    """The X25519 public key of an entity's 32-byte secret key (origin authentication, docs/security.md):
    what the identity store hands its peers. Any 32 random bytes are a secret key (a key file's, too)."""
    from uavbus._bindings import ub_origin

    return ub_origin.ub_origin_public_key(secret)
