"""Bench figure 11 (issue 28): commands beside a telemetry flood on a 57,600-baud radio, with and without
priorities, beside MAVLink 2 on the same link.

    prio_bench.py CATALOGUE_JSON PRIO_BENCH_BIN OUT_DIR [SECONDS]   -> the lines of bench/src/prio_bench.c

Writes the frames (u16 LE length + bytes) into OUT_DIR, made by the real code: uavbus compact packets (what a
compact link sends: the C codec through cffi, COBS and the delimiter, as bench/wire_bench.py makes them) and
MAVLink 2 frames from pymavlink; then runs prio_bench (the impairment's bandwidth model, ub_impair.h, on the
injected clock) once per case. Everything runs in simulated time: the figures do not depend on the machine.

The load: ATTITUDE at 50 Hz, HIGHRES_IMU at 100 Hz, GPS_RAW_INT at 10 Hz (about 1.7 times what 5,760
bytes/s carry, in either encoding), a command every 250-299 ms: for uavbus a PUB_STOP (an admin frame: class
command), for MAVLink 2 a COMMAND_LONG (MAV_CMD_DO_SET_MODE). With fragments: a 16 KiB directory's FRAGMENT
frames (255-byte compact packets, class bulk) offered as fast as the link takes them.
"""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from uavbus import Catalogue
from uavbus._bindings.ub_catalogue import ub_entity_id
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus._ub import lib

sys.path.insert(0, str(Path(__file__).resolve().parent))
from wire_bench import compact_codec, compact_wire, streams  # noqa: E402  (the figure 9 frames)

RATES = {"ATTITUDE": 50, "HIGHRES_IMU": 100, "GPS_RAW_INT": 10}
MTU = 255


def write(path: Path, frames: list[bytes]) -> Path:
    with open(path, "wb") as f:
        for fr in frames:
            f.write(struct.pack("<H", len(fr)) + fr)
    return path


def main() -> None:
    cat = Catalogue.load(sys.argv[1])
    binary, out = sys.argv[2], Path(sys.argv[3])
    seconds = sys.argv[4] if len(sys.argv) > 4 else "60"
    out.mkdir(parents=True, exist_ok=True)
    tel: dict[str, list[str]] = {"compact": [], "mavlink2": []}
    for label, hz in RATES.items():
        s = streams(cat, label)
        for form in tel:
            tel[form].append(f"{write(out / f'{form}-{label}.frames', s[form])}:{hz}")

    src, dest = ub_entity_id("gcs"), ub_entity_id("uav1")
    codec, _keep = compact_codec(cat, [src, dest])
    att = cat.instance("benchAttitude")
    # uavbus command: PUB_STOP of the attitude flow (16-byte payload: ub_admin_wire.h UB_PL_STOP_LEN).
    stop = []
    for k in range(8):
        payload = struct.pack("<IIII", 0x1000 + k, 7, 0, 0)
        h = FrameHeader(dir_id=att.id, dest_id=dest, src_id=src, admin=lib.UB_ADMIN_PUB_STOP,
                        payload_size=len(payload), seq=0x20000 + k, fingerprint=att.type.fingerprint)
        stop.append(compact_wire(codec, ub_frame_finish(h, payload), False))
    # MAVLink 2 command: COMMAND_LONG, every field set (nothing trimmed).
    mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    cmd = [bytes(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, 1.0, 4.0, 1.0, 1.0, 1.0,
                                                      1.0, 1.0).pack(mav)) for _ in range(8)]
    # Fragments of a 16 KiB directory, each packet within the 255-byte MTU (ub_frag.h payload: transfer, index,
    # count, total, then the bytes).
    total, chunk = 16384, 200
    count = -(-total // chunk)
    frags = []
    for i in range(min(count, 64)):
        body = bytes((7 + i + j) % 251 + 1 for j in range(min(chunk, total - i * chunk)))
        payload = struct.pack("<HHHH", 1, i, count, total) + body
        h = FrameHeader(dir_id=att.id, dest_id=dest, src_id=src, admin=lib.UB_ADMIN_FRAGMENT,
                        payload_size=len(payload), seq=0x30000 + i, fingerprint=att.type.fingerprint)
        w = compact_wire(codec, ub_frame_finish(h, payload), False)
        if len(w) > MTU:
            raise SystemExit(f"prio_bench.py: a fragment packet is {len(w)} bytes, above the {MTU}-byte MTU")
        frags.append(w)
    stop_f = write(out / "compact-command.frames", stop)
    cmd_f = write(out / "mavlink2-command.frames", cmd)
    frag_f = write(out / "compact-fragments.frames", frags)
    print(f"sizes\tcompact-command\t{len(stop[1])}\tmavlink2-command\t{len(cmd[1])}\tfragment\t{len(frags[1])}")

    cases = [
        ("MAVLink 2", "0", cmd_f, "-", tel["mavlink2"]),
        ("uavbus compact", "0", stop_f, "-", tel["compact"]),
        ("uavbus compact", "1", stop_f, "-", tel["compact"]),
        ("uavbus compact", "0", stop_f, frag_f, tel["compact"]),
        ("uavbus compact", "1", stop_f, frag_f, tel["compact"]),
    ]
    for label, prio, c, b, t in cases:
        r = subprocess.run([binary, seconds, prio, label, str(c), str(b), *t], capture_output=True, text=True,
                           timeout=600)
        if r.returncode != 0:
            raise SystemExit(f"prio_bench: {label} prio={prio}: exit {r.returncode}: {r.stderr.strip()}")
        sys.stdout.write(r.stdout)
        sys.stdout.flush()


if __name__ == "__main__":
    main()
