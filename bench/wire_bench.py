"""Bytes on the wire (bench figure 9, issue #15): one message each of ATTITUDE, GPS_RAW_INT and HIGHRES_IMU as
uavbus full and compact frames, unsigned and SIGNED, beside MAVLink 2 unsigned and signed frames from pymavlink.

    python bench/wire_bench.py BENCHCAT.catalogue.json OUT_DIR   -> lines "bytes<TAB>message<TAB>form<TAB>n",
                                                                     and OUT_DIR/<form>-<message>.frames

Every byte counted is made by the real code: uavbus frames by the C runtime through cffi (ub_frame_finish,
ub_sec_protect, ub_compact_encode + COBS stuffing and the delimiter: what a compact link sends), MAVLink frames
by pymavlink (msg.pack, with MAVLink2 signing set up for the signed form). Values: every field non-zero (as
bench figure 4), so neither side gains from trailing-zero truncation. The compact form is the steady state of a
link whose dictionaries agree (content and both entities as indices, 16-bit sequence); every 128th frame of a
source carries all 32 sequence bits (UB_COMPACT_SEQ32_EVERY), and the .frames streams for the radio model
(bench/src/radio_bench.c) include those. Each .frames file holds 256 consecutive frames (u16 LE length + bytes).
"""

from __future__ import annotations

import struct
import sys
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from uavbus import Catalogue
from uavbus._bindings import ub_sec
from uavbus._bindings.ub_catalogue import ub_entity_id
from uavbus._bindings.ub_frame import FLAG_SIGNED, FrameHeader, ub_frame_finish
from uavbus._ub import ffi, lib

sys.path.insert(0, str(Path(__file__).resolve().parent))
from py_bench import MESSAGES, fill, mavlink_message  # noqa: E402  (same messages and values as figure 4)

STREAM = 256  # frames per .frames file: two SEQ32 frames among them, as a long run has
SEQ32_EVERY = 128  # UB_COMPACT_SEQ32_EVERY (ub_compact.h)
FORMS = ("full", "full_signed", "compact", "compact_signed", "mavlink2", "mavlink2_signed")


def compact_codec(cat: Catalogue, ids: list[bytes]):
    """An agreed dictionary (what LINK_HELLO establishes): the catalogue and the sender's sorted entity list."""
    c = ffi.new("ub_compact_codec_t *")
    c.cat = cat.c_catalogue
    c.cat_hash = lib.ub_compact_catalogue_hash(c.cat)
    arr = ffi.new("uint8_t[][12]", len(ids))
    for k, i in enumerate(sorted(ids)):
        ffi.memmove(arr[k], i, 12)
    c.content_ok, c.entities_ok, c.n_ids, c.ids = 1, 1, len(ids), arr
    c.list_hash = lib.ub_compact_list_hash(arr, len(ids))
    return c, arr


def compact_wire(codec, frame: bytes, seq32: bool) -> bytes:
    pkt = ffi.new("uint8_t[]", lib.UB_COMPACT_PACKET_MAX)
    n = lib.ub_compact_encode(codec, frame, len(frame), seq32, pkt, lib.UB_COMPACT_PACKET_MAX)
    if n < 0:
        raise RuntimeError(f"ub_compact_encode: {n}")
    wire = ffi.new("uint8_t[]", lib.UB_COMPACT_WIRE_MAX)
    w = lib.ub_cobs_encode(pkt, n, wire, lib.UB_COMPACT_WIRE_MAX)
    if w == 0:
        raise RuntimeError("ub_cobs_encode: no room")
    return bytes(ffi.buffer(wire, w))


def streams(cat: Catalogue, label: str) -> dict[str, list[bytes]]:
    inst_name, ts, mav_cls, _ = MESSAGES[label]
    inst = cat.instance(inst_name)
    value = fill(cat, inst_name)
    src, dest = ub_entity_id("uav1"), ub_entity_id("gcs")
    codec, _keep = compact_codec(cat, [src, dest])
    sec = ub_sec.ub_sec_new({1: bytes(range(32))}, tx_key=1, counter=1)

    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    smav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    smav.signing.secret_key = bytes(range(32))
    smav.signing.link_id = 1
    smav.signing.sign_outgoing = True
    smav.signing.timestamp = 1

    out: dict[str, list[bytes]] = {f: [] for f in FORMS}
    for k in range(STREAM):
        value[ts] = 1000 + k  # a changing timestamp, as a real stream has
        payload = cat.encode(inst_name, value)
        seq = 0x10000 + k
        h = FrameHeader(dir_id=inst.id, dest_id=dest, src_id=src, payload_size=len(payload), seq=seq,
                        fingerprint=inst.type.fingerprint)
        full = ub_frame_finish(h, payload)
        signed = ub_sec.ub_sec_protect(sec, FrameHeader(dir_id=inst.id, dest_id=dest, src_id=src, seq=seq,
                                                        fingerprint=inst.type.fingerprint, flags=FLAG_SIGNED,
                                                        key_id=1, counter_hi=0), payload)
        seq32 = k % SEQ32_EVERY == 0
        out["full"].append(full)
        out["full_signed"].append(signed)
        out["compact"].append(compact_wire(codec, full, seq32))
        out["compact_signed"].append(compact_wire(codec, signed, seq32))
        msg = mavlink_message(mav_cls, value)
        out["mavlink2"].append(bytes(msg.pack(mav)))
        out["mavlink2_signed"].append(bytes(mavlink_message(mav_cls, value).pack(smav)))
    return out


def main() -> None:
    cat = Catalogue.load(sys.argv[1])
    out_dir = Path(sys.argv[2])
    out_dir.mkdir(parents=True, exist_ok=True)
    for label in MESSAGES:
        s = streams(cat, label)
        for form, frames in s.items():
            # The steady-state size: a frame with a 16-bit sequence (the stream's second frame).
            print(f"bytes\t{label}\t{form}\t{len(frames[1])}")
            with open(out_dir / f"{form}-{label}.frames", "wb") as f:
                for fr in frames:
                    f.write(struct.pack("<H", len(fr)) + fr)


if __name__ == "__main__":
    main()
