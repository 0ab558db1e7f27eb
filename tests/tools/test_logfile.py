"""The Python log reader: header, records, truncated tails at random cut points, damaged records, follow."""

from __future__ import annotations

import random
import threading
import time
from pathlib import Path

import pytest
from logwriter import MAGIC, file_header, record

from uavbus.logfile import RECORD_HEADER, LogFormatError, LogReader, follow, parse_header


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
    assert log.catalogue().name == "flightsw"


def test_truncated_at_random_cut_points_reads_whole_records_only(sample_log, tmp_path: Path) -> None:
    path, data, _ = sample_log(n_gps=6)
    full = LogReader(path).records()
    ends = [r.offset + RECORD_HEADER.size + len(r.frame) for r in full]
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
    cut.write_bytes(b"NOTALOG!" + data[8:])
    with pytest.raises(LogFormatError, match="not a uavbus log"):
        LogReader(cut)


def test_damaged_header_and_record_are_reported(sample_log, tmp_path: Path) -> None:
    path, data, _ = sample_log(n_gps=3)
    header_size = LogReader(path).header.size
    bad = bytearray(data)
    bad[header_size - 3] ^= 0x01  # inside the catalogue JSON
    (tmp_path / "bh.ublog").write_bytes(bytes(bad))
    with pytest.raises(LogFormatError, match="header CRC mismatch"):
        LogReader(tmp_path / "bh.ublog")
    recs = LogReader(path).records()
    bad = bytearray(data)
    bad[recs[4].offset + RECORD_HEADER.size + 70] ^= 0x40  # payload byte of the 5th record
    (tmp_path / "br.ublog").write_bytes(bytes(bad))
    log = LogReader(tmp_path / "br.ublog")
    assert len(log.records()) == 4
    assert log.stats.ignored_reason == f"bad record CRC at offset {recs[4].offset}"
    assert log.ignored_bytes == len(data) - recs[4].offset


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
                raw = record(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1)
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
