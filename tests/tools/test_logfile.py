"""The Python log reader (the C reader through cffi): header, records, truncated tails at random cut points,
damage at random places skipped and counted, a damaged header (one copy, both halves, both copies with
--catalogue), format 1 and 2 files, follow."""

from __future__ import annotations

import random
import threading
import time
from pathlib import Path

import pytest
from logwriter import MAGIC, file_header, record, write_log

from uavbus.logfile import RECORD_HEADER_LEN, LogFormatError, LogReader, ReadStats, follow, parse_header


def test_reads_header_and_every_record(sample_log, cat) -> None:
    path, _, expected = sample_log()
    log = LogReader(path)
    assert log.header.node == "gcs"
    assert log.header.links == {0: "gcsPortDatalink1", 1: "gcsPortDatalink2"}
    assert log.header.start_unix_ms == 1_700_000_000_000
    recs = log.records()
    assert len(recs) == 20 * 6 + 1
    assert log.ignored_bytes == 0 and log.stats.ignored_reason == ""
    gps = [r for r in recs if r.header.dir_id == cat.instance("gpsOut").id and r.dir == "rx"]
    assert [r.header.seq for r in gps] == [e["seq"] for e in expected]
    assert [cat.decode("gpsOut", r.payload) for r in gps] == [e["value"] for e in expected]
    assert recs[-1].dir == "tx" and recs[-1].link == "gcsPortDatalink1"
    assert [r.seq for r in recs] == list(range(len(recs)))
    assert log.header.version == 3 and log.header.first_seq == 0 and log.header.damaged == 0
    assert log.stats.missing_records == 0 and log.stats.damaged_records == 0
    assert log.catalogue().name == "flightsw"


def test_truncated_at_random_cut_points_reads_whole_records_only(sample_log, tmp_path: Path) -> None:
    path, data, _ = sample_log(n_gps=6)
    full = LogReader(path).records()
    ends = [r.offset + RECORD_HEADER_LEN + len(r.frame) for r in full]
    header_size = LogReader(path).header.size
    rng = random.Random(20261121)
    cuts = sorted({rng.randrange(header_size, len(data)) for _ in range(60)} | {header_size, len(data) - 1})
    for cut in cuts:
        cut_path = tmp_path / f"cut{cut}.ublog"
        cut_path.write_bytes(data[:cut])
        log = LogReader(cut_path)
        whole = sum(1 for e in ends if e <= cut)
        assert len(log.records()) == whole, cut
        last_end = ends[whole - 1] if whole else header_size
        assert log.ignored_bytes == cut - last_end, cut
        if log.ignored_bytes:
            assert "truncated" in log.stats.ignored_reason
        assert [r.frame for r in log.records()] == [r.frame for r in full[:whole]]


def test_cut_inside_header_is_an_error(sample_log, tmp_path: Path) -> None:
    path, data, _ = sample_log(n_gps=1)
    cut = tmp_path / "h.ublog"
    cut.write_bytes(data[:30])
    with pytest.raises(LogFormatError, match="ends inside the log header"):
        LogReader(cut)
    copy = LogReader(path).header.size // 2
    cut.write_bytes(b"NOTALOG!" + data[8:copy] + b"NOTALOG!" + data[copy + 8:])  # both copies' magic
    with pytest.raises(LogFormatError, match="not a uavbus log"):
        LogReader(cut)


def test_damaged_header_and_record_are_reported(sample_log, tmp_path: Path, cat) -> None:
    path, data, _ = sample_log(n_gps=3)
    header_size = LogReader(path).header.size
    copy = header_size // 2
    recs = LogReader(path).records()
    bad = bytearray(data)
    bad[header_size - 3] ^= 0x01  # inside the spare copy's catalogue JSON: the primary serves
    (tmp_path / "bh.ublog").write_bytes(bytes(bad))
    log = LogReader(tmp_path / "bh.ublog")
    assert log.header.damaged == 2 and log.header.node == "gcs" and len(log.records()) == len(recs)
    assert log.header.header_note() == "header spare copy damaged (the primary is whole)"
    bad[copy - 3] ^= 0x01  # the same byte of the primary: no copy whole, and none can be joined
    (tmp_path / "bh.ublog").write_bytes(bytes(bad))
    with pytest.raises(LogFormatError, match=r"header CRC mismatch: both copies .* --catalogue FILE"):
        LogReader(tmp_path / "bh.ublog")
    # Given the catalogue, every record is read (the sound fixed parts say where they start).
    log = LogReader(tmp_path / "bh.ublog", catalogue_json=cat.json_text)
    assert log.header.lost and log.header.size == header_size
    assert [r.frame for r in log.records()] == [r.frame for r in recs] and log.ignored_bytes == 0
    assert log.catalogue().name == "flightsw"
    bad = bytearray(data)
    bad[recs[4].offset + RECORD_HEADER_LEN + 70] ^= 0x40  # payload byte of the 5th record
    (tmp_path / "br.ublog").write_bytes(bytes(bad))
    log = LogReader(tmp_path / "br.ublog")
    # Only the damaged record is lost: the reader skips it and reads on.
    assert [r.seq for r in log.records()] == [r.seq for r in recs if r.seq != 4]
    assert log.stats.ignored_reason == "1 damaged record skipped"
    assert log.ignored_bytes == RECORD_HEADER_LEN + len(recs[4].frame)
    assert log.stats.damaged_records == 1 and log.stats.missing_records == 1 and log.stats.resyncs == 0


def _damage(data: bytes, start: int, rng: random.Random) -> tuple[bytes, list[tuple[int, int]]]:
    """Flips, deletes and inserts bytes at seeded places after `start`; returns the damaged bytes and the
    damaged ranges in the original's offsets (an insertion is the empty range at its place)."""
    out = bytearray(data)
    spots = sorted(rng.sample(range(start, len(data)), 5), reverse=True)  # back to front: offsets stay valid
    ranges = []
    for at in spots:
        kind = rng.choice(("flip", "delete", "insert"))
        n = rng.randint(1, 40)
        if kind == "flip":
            for k in range(at, min(at + n, len(out))):
                out[k] ^= rng.randint(1, 255)
            ranges.append((at, min(at + n, len(data))))
        elif kind == "delete":
            del out[at:at + n]
            ranges.append((at, min(at + n, len(data))))
        else:
            out[at:at] = bytes(rng.getrandbits(8) for _ in range(n))
            ranges.append((at, at))
    return bytes(out), ranges


def test_every_undamaged_record_survives_damage_at_random_places(sample_log, tmp_path: Path) -> None:
    path, data, _ = sample_log(n_gps=20)
    full = LogReader(path).records()
    header_size = LogReader(path).header.size
    rng = random.Random(17)
    for trial in range(40):
        bad, ranges = _damage(data, header_size, rng)
        p = tmp_path / f"d{trial}.ublog"
        p.write_bytes(bad)
        log = LogReader(p)
        got = {r.seq: r.frame for r in log.records()}

        def touched(r) -> bool:
            end = r.offset + RECORD_HEADER_LEN + len(r.frame)
            return any((a < end and b > r.offset) if a != b else r.offset < a < end for a, b in ranges)

        for r in full:
            if not touched(r):
                assert got.get(r.seq) == r.frame, (trial, r.seq)
        assert all(got[s] == full[s].frame for s in got)  # nothing read that was not written
        assert header_size + log.stats.record_bytes + log.ignored_bytes == len(bad)
        assert log.stats.missing_records == (max(got) + 1) - len(got)  # from first_seq 0 (the header says)
        if log.ignored_bytes:
            assert log.stats.ignored_reason


def test_format_1_logs_are_still_read(sample_log, tmp_path: Path, cat) -> None:
    path, _, _ = sample_log(n_gps=3)
    v2 = LogReader(path).records()
    records = [(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1) for r in v2]
    v1_path = tmp_path / "v1.ublog"
    data = write_log(v1_path, "gcs", {0: "gcsPortDatalink1", 1: "gcsPortDatalink2"}, cat.json_text, records, version=1)
    log = LogReader(v1_path)
    assert log.header.version == 1 and log.header.first_seq is None
    assert [(r.frame, r.t_ms, r.link_id, r.dir) for r in log.records()] == [(r.frame, r.t_ms, r.link_id, r.dir)
                                                                            for r in v2]
    bad = bytearray(data)
    bad[log.records()[2].offset + 30] ^= 0x10  # format 1 has one CRC per record: the reader searches on
    v1_path.write_bytes(bytes(bad))
    log = LogReader(v1_path)
    assert [r.frame for r in log.records()] == [r.frame for i, r in enumerate(v2) if i != 2]
    assert log.stats.resyncs == 1


def _spread(size: int, n: int = 32) -> list[int]:
    return [(size - 1) * k // (n - 1) for k in range(n)]


def test_one_flipped_byte_anywhere_in_the_header_loses_nothing(sample_log, tmp_path: Path) -> None:
    """Issue 29: a flip in the header (42 % of the demo's log) lost every record. One flipped byte at each of
    32 positions spread over the header region, first and last byte included: every record read, the meta
    and the catalogue whole."""
    path, data, _ = sample_log(n_gps=5)
    good = LogReader(path)
    want = [r.frame for r in good.records()]
    copy = good.header.size // 2
    rng = random.Random(29)
    for at in _spread(good.header.size):
        bad = bytearray(data)
        bad[at] ^= rng.randint(1, 255)
        p = tmp_path / f"f{at}.ublog"
        p.write_bytes(bytes(bad))
        log = LogReader(p)
        assert log.header.damaged == (1 if at < copy else 2), at
        assert (log.header.node, log.header.links, log.header.catalogue_json) == (
            good.header.node, good.header.links, good.header.catalogue_json), at
        assert [r.frame for r in log.records()] == want and log.ignored_bytes == 0, at


def test_a_zeroed_kib_costs_at_most_the_records_it_covers(sample_log, tmp_path: Path, cat) -> None:
    """A 1 KiB zeroed block at offsets over the whole file: every record it does not cover is read. Over the
    header the flightsw catalogue (tens of kB a copy) always leaves a whole copy, or two halves joined."""
    path, data, _ = sample_log(n_gps=8)
    good = LogReader(path)
    full = good.records()
    size = good.header.size
    copy = size // 2
    offsets = sorted(set(_spread(size - 1024, 12)) | {copy - 512, copy - 1000, copy - 24}
                     | set(range(size, len(data) - 1024, 997)))
    joined = 0
    for at in offsets:
        bad = bytearray(data)
        bad[at:at + 1024] = bytes(1024)
        p = tmp_path / f"z{at}.ublog"
        p.write_bytes(bytes(bad))
        log = LogReader(p)
        joined += log.header.repaired
        assert log.header.node == "gcs" and log.header.catalogue_json == good.header.catalogue_json, at
        got = {r.seq: r.frame for r in log.records()}
        for r in full:
            end = r.offset + RECORD_HEADER_LEN + len(r.frame)
            if not (r.offset < at + 1024 and end > at):
                assert got.get(r.seq) == r.frame, (at, r.seq)
        assert all(got[s] == full[s].frame for s in got)
    assert joined >= 2  # the blocks over the boundary of the two copies were met, and joined


def test_both_copies_lost_reads_with_an_external_catalogue(sample_log, tmp_path: Path, cat) -> None:
    """The whole header zeroed (a region larger than a copy): no magic left. With the catalogue from
    elsewhere every record is still found (searched for from the start)."""
    path, data, _ = sample_log(n_gps=4)
    good = LogReader(path)
    bad = bytes(good.header.size) + data[good.header.size:]
    p = tmp_path / "lost.ublog"
    p.write_bytes(bad)
    with pytest.raises(LogFormatError, match="not a uavbus log"):
        LogReader(p)
    log = LogReader(p, catalogue_json=cat.json_text)
    assert log.header.lost and log.header.size == 0
    assert [r.frame for r in log.records()] == [r.frame for r in good.records()]
    assert log.ignored_bytes == good.header.size  # the zeroed header, skipped while searching
    assert "both copies of the header are lost" in log.header.header_note()


def test_format_2_logs_are_still_read(sample_log, tmp_path: Path, cat) -> None:
    path, _, _ = sample_log(n_gps=3)
    v3 = LogReader(path).records()
    records = [(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1) for r in v3]
    v2_path = tmp_path / "v2.ublog"
    write_log(v2_path, "gcs", {0: "gcsPortDatalink1", 1: "gcsPortDatalink2"}, cat.json_text, records, version=2)
    log = LogReader(v2_path)
    assert log.header.version == 2 and log.header.first_seq == 0 and log.header.damaged == 0
    assert [(r.frame, r.seq) for r in log.records()] == [(r.frame, r.seq) for r in v3]


def test_parse_header_waits_for_more_bytes(cat) -> None:
    head = file_header("n", {0: "l"}, cat.json_text)
    for cut in (0, 3, len(MAGIC), 20, len(head) - 1):
        assert parse_header(head[:cut]) is None
    assert parse_header(head).size == len(head)


def test_follow_yields_records_as_they_are_appended(sample_log, tmp_path: Path) -> None:
    _, data, _ = sample_log(n_gps=2)
    src = LogReader(tmp_path / "gcs.ublog")
    recs = src.records()
    path = tmp_path / "growing.ublog"
    done = threading.Event()

    def writer() -> None:
        with open(path, "wb") as f:
            # Header in two writes, then each record split in two writes: the reader must wait.
            f.write(data[:10]); f.flush(); time.sleep(0.02)
            f.write(data[10:src.header.size]); f.flush()
            for r in recs:
                raw = record(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1, seq=r.seq)
                f.write(raw[:7]); f.flush(); time.sleep(0.002)
                f.write(raw[7:]); f.flush()
        done.set()

    t = threading.Thread(target=writer)
    t.start()
    got = []
    for rec in follow(path, poll_s=0.005, stop=lambda: done.is_set() and len(got) >= len(recs)):
        got.append(rec)
    t.join()
    assert [r.frame for r in got] == [r.frame for r in recs]
    assert [r.t_ms for r in got] == [r.t_ms for r in recs]


def test_follow_skips_and_counts_damage(sample_log, tmp_path: Path) -> None:
    _, data, _ = sample_log(n_gps=3)
    src = LogReader(tmp_path / "gcs.ublog")
    recs = src.records()
    path = tmp_path / "damaged-growing.ublog"
    done = threading.Event()

    def writer() -> None:
        with open(path, "wb") as f:
            f.write(data[:src.header.size]); f.flush()
            for r in recs:
                raw = bytearray(record(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1, seq=r.seq))
                if r.seq == 5:
                    raw[40] ^= 0xFF  # a damaged frame
                if r.seq == 9:
                    raw = raw[:15]  # a torn write: the rest never came
                f.write(raw[:9]); f.flush(); time.sleep(0.001)
                f.write(raw[9:]); f.flush()
        done.set()

    t = threading.Thread(target=writer)
    t.start()
    stats = ReadStats()
    got = []
    want = [r for r in recs if r.seq not in (5, 9)]
    for rec in follow(path, poll_s=0.005, stats=stats, stop=lambda: done.is_set() and len(got) >= len(want)):
        got.append(rec)
    t.join()
    assert [r.seq for r in got] == [r.seq for r in want]
    assert stats.damaged_records == 1 and stats.resyncs == 1 and stats.missing_records == 2



def test_follow_moves_on_through_a_rotated_set(sample_log, tmp_path: Path, cat) -> None:
    """A writer that rotates (ub_log_open_path): following the first file reads on into the next one,
    and records the writer lost between the files (it could not open the next one) count as missing."""
    _, _, _ = sample_log(n_gps=2)
    recs = LogReader(tmp_path / "gcs.ublog").records()
    links = {0: "gcsPortDatalink1", 1: "gcsPortDatalink2"}
    first = tmp_path / "set.ublog"
    second = tmp_path / "set.0001.ublog"
    done = threading.Event()

    def raw(r, seq: int) -> bytes:
        return record(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1, seq=seq)

    def writer() -> None:
        with open(first, "wb") as f:
            f.write(file_header("gcs", links, cat.json_text)); f.flush()
            for seq in range(5):
                f.write(raw(recs[seq], seq)); f.flush(); time.sleep(0.002)
        time.sleep(0.05)
        with open(second, "wb") as f:  # seq 5 and 6 were never written
            f.write(file_header("gcs", links, cat.json_text, first_seq=7, file_index=1)); f.flush()
            for seq in range(7, 10):
                f.write(raw(recs[seq], seq)); f.flush(); time.sleep(0.002)
        done.set()

    t = threading.Thread(target=writer)
    t.start()
    stats = ReadStats()
    got = []
    for rec in follow(first, poll_s=0.005, stats=stats, stop=lambda: done.is_set() and len(got) >= 8):
        got.append(rec)
    t.join()
    assert [r.seq for r in got] == [0, 1, 2, 3, 4, 7, 8, 9]
    assert [r.frame for r in got] == [recs[i].frame for i in (0, 1, 2, 3, 4, 7, 8, 9)]
    assert stats.records == 8 and stats.missing_records == 2 and stats.ignored_bytes == 0
