"""Regressions from the log-tools fuzzer (fuzz/python/fuzz_logtools_atheris.py) after the format-3 header:
a damaged primary copy seen before the spare has arrived, a catalogue missing a member, a clock no calendar
holds. Each once escaped as an exception or made follow() and LogReader disagree."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from uavbus import logfile
from uavbus.catalogue import Catalogue, CatalogueError
from uavbus.tools.common import human_time, iso_time

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "fuzz" / "python"))
from fuzz_cli import ENUMCAT, record_seed_log  # noqa: E402  (the fuzzer's own seed: a real log)


def test_follow_reads_what_logreader_reads_when_the_primary_header_is_damaged(tmp_path: Path) -> None:
    whole = tmp_path / "whole.ublog"
    record_seed_log(whole)
    data = bytearray(whole.read_bytes())
    data[0] ^= 0xFF  # the primary copy's magic: only the spare, further on, says where the header ends
    whole.write_bytes(data)
    expected = [(r.offset, bytes(r.frame)) for r in logfile.LogReader(whole).records()]
    assert len(expected) > 10

    # The same bytes arriving in four pieces, the first of which ends before the spare copy.
    grown = tmp_path / "grown.ublog"
    grown.write_bytes(b"")
    cuts = [64, len(data) // 3, 2 * len(data) // 3]
    pieces = [bytes(data[a:b]) for a, b in zip([0, *cuts], [*cuts, len(data)])]

    def grow(_s: float) -> None:
        with open(grown, "ab") as f:
            f.write(pieces.pop(0))

    followed = [(r.offset, bytes(r.frame)) for r in
                logfile.follow(grown, stop=lambda: not pieces, sleep=grow, rotation=False)]
    assert followed == expected


def test_follow_still_refuses_a_header_that_is_lost_for_good(tmp_path: Path) -> None:
    bad = tmp_path / "bad.ublog"
    bad.write_bytes(b"not a log at all, and it does not grow" * 10)
    with pytest.raises(logfile.LogFormatError):
        list(logfile.follow(bad, sleep=lambda _s: None, rotation=False))


def test_a_catalogue_missing_a_member_is_a_catalogue_error() -> None:
    doc = json.loads(ENUMCAT.read_text())
    del doc["types"][0]["packed_size"]
    with pytest.raises(CatalogueError, match="missing 'packed_size'"):
        Catalogue.from_json_text(json.dumps(doc), origin="embedded catalogue")
    with pytest.raises(CatalogueError, match="not a uavbus catalogue"):
        Catalogue.from_json_text(b"\xff\xfe{", origin="embedded catalogue")


def test_a_clock_no_calendar_holds_is_shown_not_raised() -> None:
    assert human_time(1.0e20) == "unix ms 100000000000000000000 (not a date)"
    assert iso_time(1.0e20) is None
    assert human_time(0) == "1970-01-01 00:00:00.000 UTC"
