"""`uavbus log play FILE --to ENTITY --into SPEC`: recorded directories delivered to the entity you choose.

The plain `log play` sends the recorded frames as they are: they reach only their original destination.
With `--to`, the player is a node of its own: each recorded source is played by an entity of the player (by
default of the same name; `--map SRC=NAME` renames one, `--as NAME` plays them all as one; over UDP up to four
identities, each with its own local port), and every selected DATA record is sent again as a new frame from
that entity to ENTITY, with the recorded payload,
at the recorded time (or scaled, `--speed`), over the port SPEC (any transport a node has: udp, tcp,
serial). The receiving node treats it as any frame from that entity: its routes, its duplicate window, its
write policy decide.

On a signed network (`--key FILE`, the operator's explicit choice) the player signs with its own identity
and counter: the recorded tags are never reused (they name the recorded source and its counter, which the
receiver has already seen). The receiver challenges the new source once; the player answers. In a fleet
with identities (origin tags required, docs/security.md) `--identity NAME.id` adds the played entity's
identity: authority.pub and fleet.certs come from its folder, as `uavbus keys fleet` lays them out.

Before the first frame the player asks ENTITY for one of the recorded directories (an INSPECT read, which
every node answers): silence means the frames would vanish too, and the player says why in one line instead
of playing into the void (no route, ENTITY does not know the player, or a wrong or missing key). After the
last frame it reads that frame's directory back: a receiver whose write policy refused every frame (dropped
without a word) still holds what it held before, and the run ends with that reason instead of a success.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

__all__ = ["PlayError", "play_to"]

PROBE_S = 3.0
SLIP_S = 0.005   # later than this behind the schedule: the schedule moves (counted), frames never bunch up


class PlayError(SystemExit):
    """One line: what went wrong and what to do (exit status 5)."""

    def __init__(self, message: str) -> None:
        super().__init__(f"uavbus log play: {message}")


MAX_IDENTITIES = 4   # UB_MAX_LOCAL_ENTITIES of the host runtime: the player's entities are one node's


def _identities(sources: list[str], as_name: str | None, mapping: dict[str, str], spec: str) -> dict[str, str]:
    """Recorded source -> the player's entity that sends its records (--as: all of them; --map: renamed)."""
    unknown = sorted(set(mapping) - set(sources))
    if unknown:
        raise PlayError(f"--map {', '.join(unknown)}: no such source in the selection (its sources: "
                        f"{', '.join(sources)})")
    out = {s: as_name or mapping.get(s, s) for s in sources}
    names = sorted(set(out.values()))
    if len(names) > 1 and not spec.startswith("udp:"):
        raise PlayError(f"{len(names)} identities ({', '.join(names)}) need one port each: over udp the player "
                        f"binds one per identity; with {spec.partition(':')[0]} give --as NAME (one identity) or "
                        "pick one source with --only")
    if len(names) > MAX_IDENTITIES:
        raise PlayError(f"{len(names)} identities ({', '.join(names)}): at most {MAX_IDENTITIES}; map several "
                        "sources to one name with --map, or play in several runs with --only")
    return out


def _config(names: list[str], to: str, spec: str, key: str | None, work: Path, identity: str | None = None) -> Path:
    """The player's node: each identity with one link toward `to`: the port `spec` for the first, the same
    with a free local port (bind HOST:0) for the others (udp); with a key, signed; with an identity file too,
    origin-tagged (authority.pub and fleet.certs from the identity's folder, as `uavbus keys fleet` lays
    them out)."""
    entities: list[dict[str, Any]] = []
    ports: dict[str, Any] = {}
    for k, name in enumerate(names):
        link = f"play{k}" if len(names) > 1 else "play"
        entities.append({"name": name, "links": [link], "linktoentity": {to: "0x00000001"}})
        port = _port(spec)
        if k > 0 and "bind" in port:
            port["bind"] = port["bind"].rsplit(":", 1)[0] + ":0"
        ports[link] = port
    doc: dict[str, Any] = {"system": "uavbus-log-play", "entities": [*entities, {"name": to}], "hosts": names,
                           "ports": ports}
    if key:
        kp = Path(key).resolve()
        state = kp.parent / "play-state"
        state.mkdir(exist_ok=True, mode=0o700)
        # Counters persist beside the key: a second replay under the same identity continues above the first,
        # so the receiver's replay window never mistakes it for a replay.
        doc["security"] = {"keys": [str(kp)], "require_signed": True,
                           "counter_file": str(state / "{entity}.counter")}
        if identity:
            ip = Path(identity).resolve()
            doc["security"].update({"authority": str(ip.parent / "authority.pub"), "identity": str(ip),
                                    "certificates": str(ip.parent / "fleet.certs")})
    path = work / "player.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return path


def _port(spec: str) -> dict[str, Any]:
    """A port spec ("udp:bind=..,peer=..") as the config's port object."""
    transport, _, rest = spec.partition(":")
    out: dict[str, Any] = {"transport": transport}
    for kv in filter(None, rest.split(",")):
        k, _, v = kv.partition("=")
        out[k] = int(v) if k in ("baud", "mtu") and v.isdigit() else v
    return out


def play_to(log: Any, contents: Any, records: list[Any], args: Any, out: IO[str],
            clock: Callable[[], float] = time.monotonic) -> int:
    """Plays `records` (the selection of `log`) to args.to; the waits poll the player's node (a signed target
    challenges the new source, and the port must be drained), so there is no sleep to inject."""
    from uavbus import Node
    from uavbus._bindings.ub_error import ConfigError, NoAnswerError, RefusedError, UbError
    from uavbus._bindings.ub_frame import FLAG_ENCRYPTED

    data = [r for r in records if contents.name(r.header) and _is_data(r)]
    if not data:
        raise PlayError(f"{args.file}: no recorded DATA frames in the selection (admin frames are not replayed "
                        "to another entity); check --only and --dir")
    bad = [m for m in (args.map or []) if "=" not in m or not all(m.split("=", 1))]
    if bad:
        raise PlayError(f"--map {bad[0]}: give SRC=NAME (a recorded source and the entity that plays it)")
    mapping = dict(m.split("=", 1) for m in (args.map or []))

    def src_of(r: Any) -> str:
        return str(r.header.src_id.rstrip(b"\0").decode("ascii", "replace"))

    sources = list(dict.fromkeys(src_of(r) for r in data))
    plays_as = _identities(sources, args.as_name, mapping, args.into)
    names = list(dict.fromkeys(plays_as.values()))
    identity = names[0]
    if args.to in names:
        raise PlayError(f"--to {args.to} is one of the player's own identities; give them other names (--as, --map)")
    encrypted = [r for r in data if r.header.flags & FLAG_ENCRYPTED]
    data = [r for r in data if not r.header.flags & FLAG_ENCRYPTED]
    if not data:
        raise PlayError(f"{args.file}: every selected frame was recorded encrypted (ciphertext); record in the clear "
                        "or on a signing-only link")
    identity_file = getattr(args, "identity", None)
    if identity_file:
        _check_identity(identity_file, args.key, names)
    with tempfile.TemporaryDirectory(prefix="uavbus-play-") as work:
        try:
            node = Node(contents.catalogue, config=_config(names, args.to, args.into, args.key, Path(work),
                                                           identity_file))
        except (ConfigError, UbError, OSError) as exc:
            raise PlayError(f"cannot be {', '.join(names)} on {args.into}: {exc}") from None
        try:
            try:
                node.open_ports_from_config()
            except (UbError, OSError) as exc:
                raise PlayError(f"cannot open {args.into}: {exc}") from None
            played = sorted({contents.name(r.header) for r in data})
            dirs = {n: node.bind(n) for n in played}
            _probe(node, args, identity, played[0], NoAnswerError, RefusedError)
            last, unanswered = data[-1], (NoAnswerError, RefusedError)
            before = _read(node, args.to, contents.name(last.header), unanswered)
            sent = failed = slips = 0
            slipped_s = 0.0
            start = clock()
            t0 = data[0].t_ms
            for rec in data:
                if not args.fast:
                    due = start + (rec.t_ms - t0) / 1000.0 / args.speed
                    late = clock() - due
                    if late > SLIP_S:
                        # The player was not scheduled in time (a loaded machine): sending everything overdue at
                        # once would turn the recorded timing into a burst. The rest keeps its spacing, later.
                        start += late
                        due += late
                        slips += 1
                        slipped_s += late
                    while (left := due - clock()) > 0.002:
                        node.poll(min(left - 0.001, 0.01))   # answers a challenge, drains the port
                    while clock() < due:
                        pass
                name = contents.name(rec.header)
                dirs[name].raw = rec.payload
                if node.send(plays_as[src_of(rec)], name, args.to) > 0:
                    sent += 1
                else:
                    failed += 1
            end = clock() + 0.3
            while clock() < end:
                node.poll(0.01)
            drops = {k: v for k, v in node.counters()["drops"].items() if v}
            # The receiver's write policy drops refused DATA without a word: what it holds afterwards is the
            # player's only evidence (an INSPECT read, which the probe showed it answers).
            after = _read(node, args.to, contents.name(last.header), unanswered)
            stored = None if after is None else after == bytes(last.payload)
            report = {"event": "played", "file": args.file, "to": args.to,
                      "as": identity if len(names) == 1 else names, "plays_as": plays_as, "into": args.into,
                      "signed": bool(args.key), "identity": bool(identity_file), "frames": sent,
                      "slips": slips, "slipped_ms": round(slipped_s * 1000.0, 1), "not_sent": failed, "encrypted_skipped": len(encrypted),
                      "drops": drops, "stored": stored, "sources": sources}
        finally:
            node.close()
    print(json.dumps(report), file=out)
    if failed:
        raise PlayError(f"{failed} of {len(data)} frames were not sent to {args.to} "
                        f"({', '.join(f'{k}={v}' for k, v in drops.items()) or 'the port refused them'})")
    if sent and stored is False and after == before:
        raise PlayError(f"{args.to} stored none of the {sent} frames played: its {contents.name(data[-1].header)} "
                        f"is what it was before the replay; most likely its write policy refused them (not_allowed "
                        f"in its stats: give {args.to} a write rule for {', '.join(names)} or a subscription of its "
                        "own)")
    return 0


def _read(node: Any, to: str, content: str, unanswered: tuple[type, ...]) -> bytes | None:
    """`to`'s directory `content` as it holds it now (INSPECT read), or None when it does not answer it."""
    try:
        return bytes(node.remote(to, timeout=PROBE_S).read_raw(content))
    except unanswered:
        return None


def _check_identity(identity: str, key: str | None, names: list[str]) -> None:
    """--identity goes with --key (the hop tag stays the group key's) and one played entity (an identity file is
    one entity's); its folder holds what the node needs beside it."""
    if not key:
        raise PlayError("--identity goes with --key FILE (the fleet's group key signs each hop; the identity adds "
                        "the origin tag)")
    if len(names) != 1:
        raise PlayError(f"--identity {identity}: one identity file is one entity's; the player plays as "
                        f"{', '.join(names)}: give --as NAME (or --only one source)")
    folder = Path(identity).resolve().parent
    missing = [str(p) for p in (Path(identity), folder / "authority.pub", folder / "fleet.certs") if not p.exists()]
    if missing:
        raise PlayError(f"--identity {identity}: {', '.join(missing)} not found (the layout `uavbus keys fleet` "
                        "writes: NAME.id, authority.pub and fleet.certs in one folder)")


def _is_data(rec: Any) -> bool:
    from uavbus._bindings.ub_frame import ADMIN_DATA

    return rec.header.admin == ADMIN_DATA


def _probe(node: Any, args: Any, identity: str, content: str, no_answer: type, refused: type) -> None:
    """One INSPECT read of `content` at the target before playing: its answer (a value, or a refusal, which
    also proves the path) or one line saying why nothing would arrive."""
    try:
        node.remote(args.to, timeout=PROBE_S).read_raw(content)
    except refused:
        return   # the target answered (e.g. reads restricted to others): it hears the player and can answer
    except no_answer:
        key = f"signed with {args.key}" if args.key else "unsigned"
        raise PlayError(f"no answer from {args.to} over {args.into} in {PROBE_S:g} s (the player is {identity}, "
                        f"{key}): {args.to} does not know {identity} or has no route back to it (add it to "
                        f"{args.to}'s configuration, or play --as an entity it knows), or the network is signed "
                        f"and the key is {'not the fleet key' if args.key else 'missing (--key FILE)'}"
                        f"{_origin_hint(args)}") from None


def _origin_hint(args: Any) -> str:
    """A fleet with identities (`uavbus keys fleet`: authority.pub beside the group key) also refuses frames without
    an origin tag from their source (`no_origin`): the group key alone is not enough there, and the line must not
    blame the key the operator got right."""
    if not args.key or not (Path(args.key).resolve().parent / "authority.pub").exists():
        return ""
    return (f", or {args.to} checks origin tags (an authority.pub lies beside {args.key}: a fleet with identities) "
            "and refuses the player's frames as no_origin: the player signs with the group key only")
