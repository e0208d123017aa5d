"""``kinsync budget``: latency, serial and period error budgets (SPEC section 3)."""

from __future__ import annotations

import math
from typing import Annotated, Any, get_args

import typer
from rich.table import Table

from kinsync.budget import (
    Parity,
    bits_per_serial_byte,
    cross_track_scenario,
    latency_beam_error,
    period_error_budget,
    serial_transmission_time_s,
)
from kinsync.cli._output import console, fmt, print_json
from kinsync.errors import InputError

app = typer.Typer(help="Error budgets: what a latency, a serial FIFO or a period error costs.")

DEFAULT_LATENCIES_MS = (0.1, 0.5, 1.0, 2.0, 5.0, 10.0)
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


def latency_rows(
    range_m: float,
    slope_deg: float,
    rate_deg_s: float,
    latencies_ms: list[float],
    beam_deg: float = 0.0,
    speed_m_s: float = 0.0,
) -> dict[str, Any]:
    """Compute the cross-track budget as the JSON-ready document the CLI prints."""
    scenario = cross_track_scenario(range_m, slope_deg, rate_deg_s, beam_deg, speed_m_s)
    rows = []
    for ms in latencies_ms:
        b = latency_beam_error(scenario, ms * 1e-3)
        rows.append(
            {
                "latency_ms": ms,
                "attitude_error_deg": math.degrees(b.attitude_error_rad),
                "position_error_m": b.position_error_m,
                "vertical_error_m": b.vertical_error_m,
                "horizontal_error_m": b.horizontal_error_m,
                "vertical_error_linear_m": b.vertical_error_linear_m,
                "horizontal_error_linear_m": b.horizontal_error_linear_m,
                "point_error_m": b.point_error_m,
                "point_horizontal_error_m": b.point_horizontal_error_m,
                "point_vertical_error_m": b.point_vertical_error_m,
            }
        )
    return {
        "scenario": {
            "description": (
                "cross-track beam (beam_deg below horizontal: 0 horizontal, 90 nadir) onto a "
                "surface rising towards it at slope_deg, under a roll rate, heading North at "
                "speed_m_s"
            ),
            "range_m": scenario.range_m,
            "slope_deg": slope_deg,
            "rate_deg_s": rate_deg_s,
            "beam_deg": beam_deg,
            "speed_m_s": speed_m_s,
            "beam_ned": list(scenario.beam_ned),
            "normal_ned": list(scenario.normal_ned),
            "rate_ned_rad_s": list(scenario.rate_ned_rad_s),
            "vel_ned_m_s": list(scenario.vel_ned_m_s),
        },
        "rows": rows,
    }


def _beam_words(beam_deg: float) -> str:
    if beam_deg == 0.0:
        return "horizontal beam"
    if beam_deg == 90.0:
        return "beam at nadir"
    return f"beam {beam_deg:g} deg below horizontal"


@app.command("latency")
def latency(
    range_m: Annotated[float, typer.Option(help="Slant range to the surface (m).")] = 50.0,
    slope_deg: Annotated[
        float, typer.Option(help="Surface slope (deg), rising towards the beam; 0 = flat.")
    ] = 10.0,
    rate_deg_s: Annotated[float, typer.Option(help="Roll rate (deg/s).")] = 10.0,
    beam_deg: Annotated[
        float,
        typer.Option(
            help="Beam depression below horizontal (deg), cross-track: 0 = horizontal (a "
            "vessel's scanner onto a beach), 90 = nadir (airborne)."
        ),
    ] = 0.0,
    speed_m_s: Annotated[
        float,
        typer.Option(
            help="Speed over ground (m/s): the latency also misplaces the scanner by speed "
            "x latency along track."
        ),
    ] = 0.0,
    latency_ms: Annotated[
        list[float] | None,
        typer.Option(
            help="Latency to evaluate (ms; > 0: navigation lags the scanner); repeat for rows."
        ),
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Point error of a latency (exact ray-plane geometry): on the surface and at the point.

    "vertical" and "horizontal" are taken on the surface (the height of the placed point
    above it; how far apart the assumed and true beams meet it); "point" is the placed
    point's distance from the point really hit, and its horizontal and vertical parts.
    """
    doc = latency_rows(
        range_m,
        slope_deg,
        rate_deg_s,
        list(latency_ms or DEFAULT_LATENCIES_MS),
        beam_deg,
        speed_m_s,
    )
    if as_json:
        print_json(doc)
        return
    moving = f", {speed_m_s:g} m/s" if speed_m_s else ""
    surface = Table(
        title=(
            f"Latency error budget: {_beam_words(beam_deg)}, {range_m:g} m slant range, "
            f"{slope_deg:g} deg slope, {rate_deg_s:g} deg/s roll{moving} (worse sign): "
            "on the surface"
        )
    )
    for col in (
        "latency\n(ms)",
        "attitude\nerror (deg)",
        "vertical\n(mm)",
        "horizontal\n(mm)",
        "vertical,\nsmall-angle\n(mm)",
        "horizontal,\nsmall-angle\n(mm)",
    ):
        surface.add_column(col, justify="right")
    point = Table(title="at the point: the placed point against the point really hit (worse sign)")
    point_columns = ["latency\n(ms)"]
    point_columns += ["scanner\nmisplaced\n(mm)"] if speed_m_s else []
    point_columns += ["point\n(mm)", "horizontal\n(mm)", "vertical\n(mm)"]
    for col in point_columns:
        point.add_column(col, justify="right")
    for r in doc["rows"]:
        surface.add_row(
            f"{r['latency_ms']:g}",
            fmt(r["attitude_error_deg"]),
            fmt(r["vertical_error_m"], 1e3),
            fmt(r["horizontal_error_m"], 1e3),
            fmt(r["vertical_error_linear_m"], 1e3),
            fmt(r["horizontal_error_linear_m"], 1e3),
        )
        moved = [fmt(r["position_error_m"], 1e3)] if speed_m_s else []
        point.add_row(
            f"{r['latency_ms']:g}",
            *moved,
            fmt(r["point_error_m"], 1e3),
            fmt(r["point_horizontal_error_m"], 1e3),
            fmt(r["point_vertical_error_m"], 1e3),
        )
    console.print(surface)
    console.print(point)


@app.command("serial")
def serial(
    baud: Annotated[float, typer.Option(help="Line rate (bit/s).")],
    n_bytes: Annotated[
        int, typer.Option("--bytes", help="Receive FIFO depth or message length (bytes).")
    ],
    data_bits: Annotated[int, typer.Option(help="Data bits per byte (5-8).")] = 8,
    parity: Annotated[
        str, typer.Option(help="none, even, odd, mark or space (any case).")
    ] = "none",
    stop_bits: Annotated[float, typer.Option(help="Stop bits (1, 1.5 or 2).")] = 1.0,
    as_json: JsonOpt = False,
) -> None:
    """Delay added by a serial receive FIFO (or a message's transmission time)."""
    parities = get_args(Parity)
    parity_key = parity.strip().lower()
    if parity_key not in parities:
        msg = f"--parity {parity!r}: give one of {', '.join(parities)} (any case)"
        raise InputError(msg)
    if stop_bits not in (1.0, 1.5, 2.0):
        msg = f"--stop-bits {stop_bits:g}: give 1, 1.5 or 2"
        raise InputError(msg)
    parity = parity_key
    latency_s = serial_transmission_time_s(n_bytes, baud, data_bits, parity, stop_bits)
    if as_json:
        print_json({"latency_s": latency_s})
        return
    bits = bits_per_serial_byte(data_bits, parity, stop_bits)
    table = Table(title="Serial FIFO / transmission delay")
    for col in ("baud", "bytes", "bits per byte", "latency (ms)"):
        table.add_column(col, justify="right")
    table.add_row(f"{baud:g}", str(n_bytes), f"{bits:g}", fmt(latency_s, 1e3, 6))
    console.print(table)


@app.command("period")
def period(
    profiles: Annotated[int, typer.Option(help="Profiles since the clock was fixed.")],
    period_error_s: Annotated[float, typer.Option(help="Error of the mirror period (s).")],
    speed_m_s: Annotated[float, typer.Option(help="Platform speed (m/s).")],
    as_json: JsonOpt = False,
) -> None:
    """Time and position error accumulated by a profile-clock period error."""
    b = period_error_budget(profiles, period_error_s, speed_m_s)
    if as_json:
        print_json({"time_error_s": b.time_error_s, "position_error_m": b.position_error_m})
        return
    table = Table(title="Profile-clock period error")
    for col in (
        "profiles",
        "period error (s)",
        "speed (m/s)",
        "time error (ms)",
        "position error (m)",
    ):
        table.add_column(col, justify="right")
    table.add_row(
        str(profiles),
        f"{period_error_s:g}",
        f"{speed_m_s:g}",
        fmt(b.time_error_s, 1e3),
        fmt(b.position_error_m),
    )
    console.print(table)
