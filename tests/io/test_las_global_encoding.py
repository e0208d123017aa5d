"""Global-encoding bits kinsync writes, on every laspy it accepts.

laspy before 2.7 clears a bit with an exclusive or: ``wkt = False`` on a fresh header
set the WKT bit, and ``gps_time_type = WEEK_TIME`` labelled week times as adjusted
standard GPS time. These tests fail there without `set_global_encoding_bit`.
"""

from __future__ import annotations

from typing import Literal

import laspy
import numpy as np
import pyarrow as pa
import pytest

from kinsync.io.las_header import set_global_encoding_bit
from kinsync.io.las_table import arrow_numpy_dtype, plan_table_las

ENCODING = laspy.header.GlobalEncoding
WAVEFORM = ENCODING.WAVEFORM_INTERNAL_MASK | ENCODING.WAVEFORM_EXTERNAL_MASK


@pytest.mark.parametrize("start", [0, 0b1_1111])
@pytest.mark.parametrize("mask", [ENCODING.GPS_TIME_TYPE_MASK, ENCODING.WKT_MASK, WAVEFORM])
def test_a_bit_set_or_cleared_again_keeps_its_state_and_the_other_bits(
    start: int, mask: int
) -> None:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.global_encoding.value = start
    for on in (False, False, True, True, False):
        set_global_encoding_bit(header, mask, on=on)
        assert header.global_encoding.value & mask == (mask if on else 0)
        assert header.global_encoding.value & ~mask == start & ~mask


@pytest.mark.parametrize(
    ("time_scale", "expected"),
    [("week", laspy.header.GpsTimeType.WEEK_TIME), ("gps", laspy.header.GpsTimeType.STANDARD)],
)
def test_a_table_to_las_header_says_its_time_scale(
    time_scale: Literal["gps", "week"], expected: laspy.header.GpsTimeType
) -> None:
    plan = plan_table_las({"intensity": pa.uint16(), "range_m": pa.float32()}, time_scale)
    header = plan.header()
    assert header.global_encoding.gps_time_type == expected
    assert not header.global_encoding.wkt
    assert plan.extra == (("range_m", "f4"),)


@pytest.mark.parametrize(
    ("kind", "expected"),
    [
        (pa.int8(), "i1"),
        (pa.uint64(), "u8"),
        (pa.float16(), "f2"),
        (pa.float64(), "f8"),
        (pa.bool_(), "?"),
        (pa.string(), "O"),
    ],
)
def test_the_numpy_type_of_an_arrow_column(kind: pa.DataType, expected: str) -> None:
    assert arrow_numpy_dtype(kind) == np.dtype(expected)
