"""One uavbus directory per MAVLink message type: the names, and the C files the bridge is built from.

The MAVLink bridge (docs/bridges.md) hosts the latest value of every message type of a dialect as a
catalogued directory instance. This module is the one place that says how a message becomes a
directory; the C build (bridges/mavlink/CMakeLists.txt) runs it at configure time, and Python tools
use `directory_name()` to find a message's directory.

**Names.** `<MESSAGE>_<msgid>`: `HEARTBEAT_0`, `ATTITUDE_30`, `COMMAND_LONG_76`. The paper's content
ID takes the first 8 and last 8 characters of a name, and message names alone collide under it
(`MISSION_CURRENT` and `MISSION_SET_CURRENT` both give `MISSION__CURRENT`). The last 8 characters of
`<MESSAGE>_<msgid>` always hold `_<msgid>` whole for ids below 10^7, so two messages never share an
ID and the catalogue keeps the default ("paper") ID scheme that the rest of a system uses: a GCS can
have flight-software and MAVLink directories in one catalogue.

Run as a program (what CMake does):

    python -m uavbus.bridges.mavlink_dirs --dialect common --out DIR

writes into DIR, only when their content changes (so the build does not redo work):

    mav_directories.h    `extern mavlink_<message>_t <MESSAGE>_<id>;` per message, plus the bridge's
                         status directory: what `uavbus_generate()` catalogues
    mav_directories.c    the storage, and the table msgid -> (name, storage, size) of ub_mavbridge.h
    mav_ub_config.h      the runtime capacities the bridge needs (one binding per directory)

and prints the dialect's XML files (one per line) for CMake to watch.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import sys
from dataclasses import dataclass
from pathlib import Path

STATUS_DIRECTORY = "mavbridgeStatus"
STATUS_TYPE = "struct ub_mavbridge_status"
# Raw MAVLink frames between bridge nodes (the front door, docs/bridges.md): one catalogued directory.
FRAME_DIRECTORY = "mavFrame"
FRAME_TYPE = "struct ub_mavframe"
# Directories the bridge binds besides the messages (the status); the rest of the margin is for the
# application's own bindings when it embeds the bridge in a bigger node.
EXTRA_BINDINGS = 16
MAX_MSGID_DIGITS = 7
_NAME = re.compile(r"^([A-Z][A-Z0-9_]*)_(\d+)$")


@dataclass(frozen=True)
class Message:
    name: str  # "ATTITUDE"
    msgid: int

    @property
    def directory(self) -> str:
        return directory_name(self.name, self.msgid)

    @property
    def c_type(self) -> str:
        return f"mavlink_{self.name.lower()}_t"


def directory_name(message: str, msgid: int) -> str:
    """The directory of MAVLink message `message` (its XML name) with id `msgid`: `ATTITUDE_30`."""
    if not 0 <= msgid < 10**MAX_MSGID_DIGITS:
        raise ValueError(f"MAVLink message {message} has id {msgid}: directory names hold ids below "
                         f"10^{MAX_MSGID_DIGITS} (MAVLink 2 ids are 24-bit; no dialect uses more yet)")
    return f"{message}_{msgid}"


def parse_directory_name(name: str) -> tuple[str, int] | None:
    """(message, msgid) of a directory name made by directory_name(), else None."""
    m = _NAME.match(name)
    return (m.group(1), int(m.group(2))) if m else None


def find_directory(names: object, message: str) -> str | None:
    """The directory of `message` ("ATTITUDE" or "ATTITUDE_30") among catalogue instance `names`."""
    for n in names:  # type: ignore[attr-defined]
        parsed = parse_directory_name(str(n))
        if parsed is not None and (parsed[0] == message or str(n) == message):
            return str(n)
    return None


def dialect_xml(dialect: str) -> Path:
    """pymavlink's XML of `dialect` ("common", "ardupilotmega", ...) or a path to an XML file."""
    p = Path(dialect)
    if p.suffix == ".xml":
        if not p.is_file():
            raise SystemExit(f"mavlink_dirs: {p}: no such dialect file")
        return p.resolve()
    import pymavlink

    root = Path(pymavlink.__file__).resolve().parent
    for candidate in (root / "dialects" / "v20" / f"{dialect}.xml",
                      root / "message_definitions" / "v1.0" / f"{dialect}.xml"):
        if candidate.is_file():
            return candidate
    raise SystemExit(f"mavlink_dirs: pymavlink has no dialect '{dialect}' (look in {root / 'dialects' / 'v20'})")


def read_dialect(xml: Path) -> tuple[list[Message], list[Path]]:
    """Every message of `xml` and of the files it includes, by id; and the XML files read."""
    from pymavlink.generator import mavparse

    messages: dict[int, Message] = {}
    files: list[Path] = []
    pending = [xml]
    while pending:
        path = pending.pop()
        if path in files:
            continue
        files.append(path)
        with contextlib.redirect_stdout(io.StringIO()):  # mavparse prints warnings about enum values
            doc = mavparse.MAVXML(str(path), mavparse.PROTOCOL_2_0)
        for m in doc.message:
            old = messages.get(m.id)
            if old is not None and old.name != m.name:
                raise SystemExit(f"mavlink_dirs: {path}: message id {m.id} is both {old.name} and {m.name}")
            messages[m.id] = Message(m.name, m.id)
        pending += [path.parent / inc for inc in doc.include]
    return sorted(messages.values(), key=lambda m: m.msgid), files


def _header(dialect: str, messages: list[Message]) -> str:
    lines = [
        f"/* Generated by uavbus.bridges.mavlink_dirs from the MAVLink dialect '{dialect}'. DO NOT EDIT. */",
        "/* One directory per MAVLink message type: the latest value the bridge received or was given",
        " * (docs/bridges.md). Catalogued by uavbus_generate(); names are <MESSAGE>_<msgid>. */",
        "#ifndef MAV_DIRECTORIES_H",
        "#define MAV_DIRECTORIES_H",
        "",
        f'#include "{dialect}/mavlink.h"',
        '#include "ub_mavbridge_status.h"',
        "",
    ]
    lines += [f"extern {m.c_type} {m.directory};" for m in messages]
    lines += ["", "/* The bridge's own state and counters (ub_mavbridge_status.h). */",
              f"extern {STATUS_TYPE} {STATUS_DIRECTORY};",
              "/* One raw MAVLink frame between bridge nodes (the front door, ub_mavbridge_status.h). */",
              f"extern {FRAME_TYPE} {FRAME_DIRECTORY};", "", "#endif", ""]
    return "\n".join(lines)


def _source(dialect: str, messages: list[Message]) -> str:
    lines = [
        f"/* Generated by uavbus.bridges.mavlink_dirs from the MAVLink dialect '{dialect}'. DO NOT EDIT. */",
        '#include "mav_directories.h"',
        '#include "ub_mavbridge.h"',
        "",
    ]
    lines += [f"{m.c_type} {m.directory};" for m in messages]
    lines += [f"{STATUS_TYPE} {STATUS_DIRECTORY};", f"{FRAME_TYPE} {FRAME_DIRECTORY};", "",
              "/* Sorted by msgid (ub_mavbridge_init() checks). */",
              "const ub_mav_dir_t mav_directories[] = {"]
    lines += [f'    {{{m.msgid}u, "{m.directory}", &{m.directory}, (uint16_t)sizeof {m.directory}}},'
              for m in messages]
    lines += ["};", "const size_t mav_directories_count = sizeof mav_directories / sizeof mav_directories[0];", ""]
    return "\n".join(lines)


def _config(dialect: str, messages: list[Message]) -> str:
    return "\n".join([
        f"/* Generated by uavbus.bridges.mavlink_dirs for the MAVLink dialect '{dialect}'. DO NOT EDIT. */",
        "/* Runtime capacities of the bridge's build of the uavbus runtime (UB_CONFIG_FILE, ub_config.h):",
        " * one binding per message directory, the status directory, and room for the application's own. */",
        "#ifndef MAV_UB_CONFIG_H",
        "#define MAV_UB_CONFIG_H",
        f"#define UB_MAX_BINDINGS {len(messages) + EXTRA_BINDINGS}",
        f"#define UB_MAVBRIDGE_MAX_DIRS {len(messages)}",
        "#endif",
        "",
    ])


def _write_if_changed(path: Path, text: str) -> None:
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m uavbus.bridges.mavlink_dirs", description=__doc__.split("\n")[0])
    ap.add_argument("--dialect", default="common", help="pymavlink dialect name or an XML path (default common)")
    ap.add_argument("--out", required=True, help="directory for mav_directories.{h,c} and mav_ub_config.h")
    args = ap.parse_args(argv)
    xml = dialect_xml(args.dialect)
    messages, files = read_dialect(xml)
    names = [m.directory for m in messages]
    if len(set(names)) != len(names):
        raise SystemExit("mavlink_dirs: two messages give the same directory name")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    dialect = xml.stem
    _write_if_changed(out / "mav_directories.h", _header(dialect, messages))
    _write_if_changed(out / "mav_directories.c", _source(dialect, messages))
    _write_if_changed(out / "mav_ub_config.h", _config(dialect, messages))
    for f in files:
        print(f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
