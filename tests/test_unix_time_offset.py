"""Two inputs 315964782 s apart are named as Unix time against GPS time."""

from __future__ import annotations

from kinsync._unix_time import UNIX_MINUS_GPS_S, unix_offset_text
from kinsync.pipelines.georef_times import PointTimes, time_scale_hint

GPS = (1.3e9, 1.3e9 + 223.5)
UNIX = (GPS[0] + UNIX_MINUS_GPS_S + 0.1, GPS[1] + UNIX_MINUS_GPS_S - 0.1)


def test_either_input_may_be_the_unix_one() -> None:
    text = unix_offset_text(UNIX, GPS, "the points", "the trajectory")
    assert text is not None
    assert text.startswith("the times of the points look like Unix time")
    assert "those of the trajectory like GPS time" in text
    assert "convert the times of the points to GPS time: subtract 315964800 s" in text
    text = unix_offset_text(GPS, UNIX, "the cloud", "the trajectory")
    assert text is not None
    assert text.startswith("the times of the trajectory look like Unix time")
    assert unix_offset_text(GPS, (GPS[0] - 18.0, GPS[1] - 18.0), "a", "b") is None


def test_georef_names_unix_points_against_a_gps_trajectory() -> None:
    """It advised 'seconds of week vs GPS time, or UTC against GPS (18 s apart)'."""
    hint = time_scale_hint(PointTimes("gps"), *UNIX, *GPS)
    assert hint is not None
    assert "the times of the points look like Unix time" in hint
