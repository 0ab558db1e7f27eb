"""Negative codes from the C runtime become the right exceptions (uavbus._bindings.ub_error), and the
Python table stays in step with runtime_c/include/ub/ub_error.h."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from uavbus._bindings import ub_catalogue as uc
from uavbus._bindings import ub_error as ue
from uavbus._bindings import ub_frame as uf
from uavbus._ub import ffi, lib

ERROR_HEADER = Path(__file__).resolve().parents[2] / "runtime_c" / "include" / "ub" / "ub_error.h"
HEADER_CODES: dict[str, int] = {
    name: int(value)
    for name, value in re.findall(r"^#define (UB_ERR_\w+) (-\d+)", ERROR_HEADER.read_text(), re.MULTILINE)
}
VECTORS = json.loads((Path(__file__).resolve().parents[1] / "vectors" / "frames.json").read_text())["vectors"]
FRAME = bytes.fromhex(VECTORS[0]["frame"])


def test_every_code_in_the_c_header_has_its_own_exception() -> None:
    assert len(HEADER_CODES) >= 14
    assert set(ue.ERRORS_BY_CODE) == set(HEADER_CODES.values())
    for name, code in HEADER_CODES.items():
        assert getattr(lib, name) == code
        assert ue.ub_strerror(code) == name


@pytest.mark.parametrize("code", sorted(ue.ERRORS_BY_CODE), ids=ue.ub_strerror)
def test_ensure_raises_the_class_for_the_code(code: int) -> None:
    with pytest.raises(ue.ERRORS_BY_CODE[code]) as info:
        ue.ensure(code, "context")
    assert isinstance(info.value, ue.UbError) and info.value.code == code
    assert info.value.detail == "context"
    if code == lib.UB_ERR_CONFIG:  # a config message is complete as it is: file:line: what to do
        assert str(info.value) == "context"
    else:
        assert str(info.value) == f"{ue.ub_strerror(code)}: context"


def test_ensure_passes_non_negative_results_through() -> None:
    assert ue.ensure(0, "ok") == 0 and ue.ensure(88, "length") == 88


def test_unknown_code_keeps_its_value() -> None:
    with pytest.raises(ue.UbError) as info:
        ue.ensure(-999, "x")
    assert info.value.code == -999 and type(info.value) is ue.UbError


@pytest.mark.parametrize(("cls", "builtin"), [
    (ue.InvalidArgumentError, ValueError), (ue.TruncatedError, ValueError), (ue.ChecksumError, ValueError),
    (ue.RangeError, OverflowError), (ue.NotFoundError, LookupError), (ue.WouldBlockError, BlockingIOError),
    (ue.IoError, OSError), (ue.ClosedError, ConnectionError), (ue.NoSpaceError, BufferError),
])
def test_exceptions_are_also_builtins(cls: type[ue.UbError], builtin: type[Exception]) -> None:
    assert issubclass(cls, builtin) and issubclass(cls, ue.UbError)


def test_truncated_frame_raises_truncated() -> None:
    with pytest.raises(ue.TruncatedError):
        uf.ub_frame_parse(FRAME[:-1])
    with pytest.raises(ue.TruncatedError):
        uf.ub_frame_parse(FRAME[:10])


def test_corrupt_payload_raises_checksum() -> None:
    corrupt = bytearray(FRAME)
    corrupt[-1] ^= 1
    with pytest.raises(ue.ChecksumError):
        uf.ub_frame_parse(bytes(corrupt))


def test_bad_sync_and_trailing_bytes_raise_invalid_argument() -> None:
    with pytest.raises(ue.InvalidArgumentError):
        uf.ub_frame_parse(b"\x00" + FRAME[1:])
    with pytest.raises(ue.InvalidArgumentError):
        uf.ub_frame_parse(FRAME + b"\x00")


def header(**changes: int) -> uf.FrameHeader:
    return uf.FrameHeader(dir_id=bytes(16), dest_id=bytes(12), src_id=bytes(12), **changes)


def test_finish_refuses_hop_limit_zero_and_oversized_payload_in_c() -> None:
    with pytest.raises(ue.RangeError):
        uf.ub_frame_finish(header(hop_limit=0), b"")
    assert len(uf.ub_frame_finish(header(), bytes(uf.MAX_PAYLOAD))) == uf.FRAME_HEADER_LEN + uf.MAX_PAYLOAD
    with pytest.raises(ue.RangeError):
        uf.ub_frame_finish(header(), bytes(uf.MAX_PAYLOAD + 1))


def test_finish_refuses_a_short_buffer_in_c() -> None:
    h = ffi.new("ub_frame_header_t *", {"hop_limit": 1})
    buf = ffi.new("uint8_t[]", uf.FRAME_HEADER_LEN - 1)
    with pytest.raises(ue.NoSpaceError):
        ue.ensure(lib.ub_frame_finish(buf, len(buf), h), "short buffer")


def test_wrong_id_length_and_out_of_range_fields_are_refused() -> None:
    with pytest.raises(ue.InvalidArgumentError):
        uf.ub_frame_finish(uf.FrameHeader(dir_id=bytes(15), dest_id=bytes(12), src_id=bytes(12)), b"")
    with pytest.raises(ue.RangeError):
        uf.ub_frame_finish(header(seq=1 << 32), b"")


def test_set_hop_limit_errors() -> None:
    with pytest.raises(ue.RangeError):
        uf.ub_frame_set_hop_limit(FRAME, 0)
    with pytest.raises(ue.InvalidArgumentError):
        uf.ub_frame_set_hop_limit(FRAME[:-1], 3)


def test_entity_id_too_long_raises_range() -> None:
    with pytest.raises(ue.RangeError):
        uc.ub_entity_id("thirteen_char")


def test_name_with_nul_is_refused() -> None:
    with pytest.raises(ue.InvalidArgumentError):
        uc.ub_dir_id_paper("imu\0Out")
