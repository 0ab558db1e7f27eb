"""`uavbus log play FILE --to ENTITY --into SPEC`: recorded directories delivered to the entity you choose.

The plain `log play` sends the recorded frames as they are: they reach only their original destination.
With `--to`, the player is a node of its own (an entity, `--as NAME`, by default the recorded source):
every selected DATA record is sent again as a new frame from the player to ENTITY, with the recorded payload,
at the recorded time (or scaled, `--speed`), over the port SPEC (any transport a node has: udp, tcp,
serial). The receiving node treats it as any frame from that entity: its routes, its duplicate window, its
write policy decide.

On a signed network (`--key FILE`, the operator's explicit choice) the player signs with its own identity
and counter: the recorded tags are never reused (they name the recorded source and its counter, which the
receiver has already seen). The receiver challenges the new source once; the player answers.

Before the first frame the player asks ENTITY for one of the recorded directories (an INSPECT read, which
every node answers): silence means the frames would vanish too, and the player says why in one line instead
of playing into the void (no route, ENTITY does not know the player, or a wrong or missing key).
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


class PlayError(SystemExit):
    """One line: what went wrong and what to do (exit status 5)."""

    def __init__(self, message: str) -> None:
        super().__init__(f"uavbus log play: {message}")


def _identity(sources: set[str], as_name: str | None, mapping: dict[str, str]) -> str:
    if as_name:
        return as_name
    names = {mapping.get(s, s) for s in sources}
    if len(names) != 1:
        raise PlayError(f"the selection has {len(sources)} sources ({', '.join(sorted(sources))}), mapped to "
                        f"{', '.join(sorted(names))}: the player is one entity; give --as NAME, map them to one "
                        "name with --map SRC=NAME, or pick one source's contents with --only")
    return names.pop()


def _config(identity: str, to: str, spec: str, key: str | None, work: Path) -> Path:
    """The player's node: `identity` with one link ("play") toward `to` on `spec`; with a key, signed."""
    doc: dict[str, Any] = {
        "system": "uavbus-log-play",
        "entities": [{"name": identity, "links": ["play"], "linktoentity": {to: "0x00000001"}}, {"name": to}],
        "hosts": [identity],
        "ports": {"play": _port(spec)},
    }
    if key:
        kp = Path(key).resolve()
        state = kp.parent / "play-state"
        state.mkdir(exist_ok=True, mode=0o700)
        # Counters persist beside the key: a second replay under the same identity continues above the first,
        # so the receiver's replay window never mistakes it for a replay.
        doc["security"] = {"keys": [str(kp)], "require_signed": True,
                           "counter_file": str(state / "{entity}.counter")}
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
            sleep: Callable[[float], None] = time.sleep, clock: Callable[[], float] = time.monotonic) -> int:
    from uavbus import Node
    from uavbus._bindings.ub_error import NoAnswerError, RefusedError, UbError
    from uavbus._bindings.ub_error import ConfigError
    from uavbus._bindings.ub_frame import FLAG_ENCRYPTED

    data = [r for r in records if contents.name(r.header) and _is_data(r)]
    if not data:
        raise PlayError(f"{args.file}: no recorded DATA frames in the selection (admin frames are not replayed "
                        "to another entity); check --only and --dir")
    mapping = dict(m.split("=", 1) for m in (args.map or []))
    sources = {r.header.src_id.rstrip(b"\0").decode("ascii", "replace") for r in data}
    identity = _identity(sources, args.as_name, mapping)
    if identity == args.to:
        raise PlayError(f"--to {args.to} is the player's own identity; give the player another name with --as")
    encrypted = [r for r in data if r.header.flags == FLAG_ENCRYPTED]
    data = [r for r in data if r.header.flags != FLAG_ENCRYPTED]
    if not data:
        raise PlayError(f"{args.file}: every selected frame was recorded encrypted (ciphertext); record in the clear "
                        "or on a signing-only link")
    with tempfile.TemporaryDirectory(prefix="uavbus-play-") as work:
        try:
            node = Node(contents.catalogue, config=_config(identity, args.to, args.into, args.key, Path(work)))
        except (ConfigError, UbError, OSError) as exc:
            raise PlayError(f"cannot be {identity} on {args.into}: {exc}") from None
        try:
            try:
                node.open_ports_from_config()
            except (UbError, OSError) as exc:
                raise PlayError(f"cannot open {args.into}: {exc}") from None
            names = {contents.name(r.header) for r in data}
            dirs = {n: node.bind(n) for n in names}
            _probe(node, args, identity, sorted(names)[0], NoAnswerError, RefusedError)
            sent = failed = 0
            start = clock()
            t0 = data[0].t_ms
            for rec in data:
                if not args.fast:
                    due = start + (rec.t_ms - t0) / 1000.0 / args.speed
                    while (left := due - clock()) > 0.002:
                        node.poll(min(left - 0.001, 0.01))   # answers a challenge, drains the port
                    while clock() < due:
                        pass
                name = contents.name(rec.header)
                dirs[name].raw = rec.payload
                if node.send(identity, name, args.to) > 0:
                    sent += 1
                else:
                    failed += 1
            end = clock() + 0.3
            while clock() < end:
                node.poll(0.01)
            drops = {k: v for k, v in node.counters()["drops"].items() if v}
            report = {"event": "played", "file": args.file, "to": args.to, "as": identity, "into": args.into,
                      "signed": bool(args.key), "frames": sent, "not_sent": failed, "encrypted_skipped": len(encrypted),
                      "drops": drops, "sources": sorted(sources)}
        finally:
            node.close()
    print(json.dumps(report), file=out)
    if failed:
        raise PlayError(f"{failed} of {len(data)} frames were not sent to {args.to} "
                        f"({', '.join(f'{k}={v}' for k, v in drops.items()) or 'the port refused them'})")
    return 0


def _is_data(rec: Any) -> bool:
    from uavbus._bindings.ub_frame import lib

    return rec.header.admin == lib.UB_ADMIN_DATA


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
                        f"and the key is {'not the fleet key' if args.key else 'missing (--key FILE)'}") from None
