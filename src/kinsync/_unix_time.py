"""Unix time against GPS time: how far apart they are, and how to convert.

Unix time (UTC seconds since 1970-01-01, leap seconds not counted) runs 315964800 s
ahead of GPS time (seconds since 1980-01-06) less the leap seconds GPS time has gained
on UTC (18 s since 2017). Two logs of one survey whose times lie that far apart are one
in each (`unix_offset_text`); the readers refuse a GPS time after today, which a Unix
time is (`kinsync.io.gps_week.check_not_future`).
"""

from __future__ import annotations

__all__ = ["UNIX_ADVICE", "UNIX_MINUS_GPS_S", "unix_offset_text"]

GPS_EPOCH_UNIX_S = 315_964_800.0
"""Unix time of the GPS epoch, 1980-01-06T00:00:00 UTC (s)."""

UNIX_MINUS_GPS_S = GPS_EPOCH_UNIX_S - 18.0
"""Unix time less GPS time since 2017 (s): 315964800 s less the 18 leap seconds."""

UNIX_ADVICE = (
    "convert it to GPS time: subtract 315964800 s and add the leap seconds (18 s since "
    "2017; in Python kinsync.clock.utc_to_gps_s)"
)
"""How to turn Unix time into GPS time."""

_SLACK_S = 60.0
"""How far (s) two spans may miss each other once one is shifted by `UNIX_MINUS_GPS_S`
(older leap-second counts, logs that start a little apart)."""


def unix_offset_text(
    a_span_s: tuple[float, float], b_span_s: tuple[float, float], a_name: str, b_name: str
) -> str | None:
    """Which of two inputs looks like Unix time and which GPS time, or None.

    Parameters
    ----------
    a_span_s, b_span_s : tuple of float
        First and last time (s) of each input.
    a_name, b_name : str
        The inputs, for the text ("the points", "the trajectory").

    Returns
    -------
    str or None
        E.g. "the times of the points look like Unix time (UTC seconds since 1970),
        those of the trajectory like GPS time: about 315964782 s apart; convert ...";
        None when the spans do not lie
        that far apart.
    """
    (a0, a1), (b0, b1) = a_span_s, b_span_s
    for unix, gps, (u0, u1), (g0, g1) in (
        (a_name, b_name, (a0, a1), (b0, b1)),
        (b_name, a_name, (b0, b1), (a0, a1)),
    ):
        if u0 - UNIX_MINUS_GPS_S <= g1 + _SLACK_S and u1 - UNIX_MINUS_GPS_S >= g0 - _SLACK_S:
            return (
                f"the times of {unix} look like Unix time (UTC seconds since 1970-01-01), "
                f"those of {gps} like GPS time (seconds since 1980-01-06): about "
                f"{UNIX_MINUS_GPS_S:.0f} s apart; "
                f"{UNIX_ADVICE.replace('convert it', f'convert the times of {unix}')}"
            )
    return None
