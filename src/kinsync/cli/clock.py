"""``kinsync clock``: fit the local clock -> GPS time model from PPS + ZDA, apply it."""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from kinsync._text import counted
from kinsync._typing import BoolArray, FloatArray
from kinsync.cli._output import console, fmt, print_json, quantity_table
from kinsync.cli._progress import progress_display
from kinsync.clock import (
    CONVENTIONS,
    OUTSIDE_POLICIES,
    ClockFit,
    ClockModel,
    Convention,
    OutsidePolicy,
    fit_clock_to_log,
)
from kinsync.errors import InputError, OutsideSpanError
from kinsync.io.atomic import atomic_write_bytes
from kinsync.messages import NmeaLog, RejectedLine
from kinsync.progress import Stages

app = typer.Typer(help="PPS + ZDA time tagging: map the local clock to GPS time.")

JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


def parse_convention(text: str) -> Convention:
    """``preceding`` or ``following`` (case-insensitive), else `InputError`."""
    key = text.strip().lower()
    for c in CONVENTIONS:
        if key == c:
            return c
    msg = f"--convention must be preceding or following, got {text!r}"
    raise InputError(msg)


def _parse_outside(text: str | None) -> OutsidePolicy | None:
    if text is None:
        return None
    key = text.strip().lower()
    for p in OUTSIDE_POLICIES:
        if key == p:
            return p
    msg = f"--outside must be extrapolate, raise or nan, got {text!r}"
    raise InputError(msg)


@app.command("fit")
def fit(
    pps: Annotated[Path, typer.Option(help="PPS log: CSV with column t_local_s.")],
    nmea: Annotated[Path, typer.Option(help="NMEA log: CSV t_local_s,sentence.")],
    baud: Annotated[float, typer.Option(help="Serial line rate of the NMEA port (bit/s), 8N1.")] = (
        115200.0
    ),
    convention: Annotated[
        str,
        typer.Option(
            help="Which edge a ZDA names: 'preceding' (the last before it) or 'following'."
        ),
    ] = "preceding",
    piecewise: Annotated[
        bool,
        typer.Option("--piecewise", help="Interpolate between consecutive good pulses too."),
    ] = False,
    model_out: Annotated[
        Path | None, typer.Option(help="Write the model here (JSON, for kinsync clock apply).")
    ] = None,
    figure: Annotated[Path | None, typer.Option(help="Write a residual figure here (PNG).")] = (
        None
    ),
    as_json: JsonOpt = False,
) -> None:
    """Fit offset and drift of the local clock from PPS edges and ZDA messages."""
    conv = parse_convention(convention)
    result, log = _fit_logs(pps, nmea, baud, conv, piecewise, model_out, figure)
    doc: dict[str, Any] = result.as_document()
    rejected = sorted([*log.rejected, *result.rejected_zdas], key=lambda r: r.line)
    doc["rejected_lines"] = [{"line": r.line, "reason": r.reason} for r in rejected]
    doc["model_out"] = None if model_out is None else str(model_out)
    doc["figure"] = None if figure is None else str(figure)
    if as_json:
        print_json(doc)
        return
    m = result.model
    table = quantity_table(f"Clock model from {pps} and {nmea}")
    # No digit below the step the float64 reference times can hold (2.4e-7 s near 1.4e9 s).
    decimals = m.time_decimals
    table.add_row(
        "offset at reference (s)", f"{m.offset_s:.{decimals}f} ± {result.offset_std_s:.2e}"
    )
    table.add_row("drift (ppm)", f"{m.drift_ppm:.6f} ± {result.drift_std_ppm:.6f}")
    table.add_row("reference_local_s (first good pulse)", f"{m.reference_local_s:.{decimals}f}")
    table.add_row("reference_gps_s", f"{m.reference_gps_s:.{decimals}f}")
    table.add_row("residual RMS (us)", fmt(result.residual_rms_s, 1e6, 4))
    table.add_row("pulses used / read", f"{result.n_pulses} / {result.n_pulses_read}")
    table.add_row("missing pulses", str(result.n_missing))
    table.add_row("spurious pulses", str(result.n_spurious))
    table.add_row("ZDAs paired / read", f"{result.n_zda_paired} / {result.n_zda}")
    table.add_row("ZDAs naming a wrong second", str(result.n_wrong_zda))
    table.add_row("ZDAs with no pulse", str(result.n_unpaired_zda))
    if result.n_duplicate_zda:
        table.add_row("ZDAs repeating a second already named", str(result.n_duplicate_zda))
    table.add_row("rejected NMEA lines", str(result.n_bad_lines))
    table.add_row("rejected messages (total)", str(result.n_rejected_messages))
    table.add_row("ZDA transmission start after its edge (ms)", fmt(result.zda_delay_s, 1e3, 5))
    table.add_row("model", "piecewise-linear between pulses" if m.piecewise else "linear")
    console.print(table)
    console.print(m.formula)
    _print_rejected(rejected)
    if model_out is not None:
        console.print(f"model: {model_out}")
    if figure is not None:
        console.print(f"figure: {figure}")


def _print_rejected(rejected: list[RejectedLine], shown: int = 5) -> None:
    """The first corrupt lines, then the sentence types not read, by type with a count.

    Well-formed sentences kinsync does not read (GSV, VTG, ...) are not errors; listed
    line by line they hid the corrupt lines behind "... and N more".
    """
    corrupt = [r for r in rejected if r.unsupported_type is None]
    for r in corrupt[:shown]:
        console.print(f"rejected line {r.line}: {r.reason}")
    if len(corrupt) > shown:
        console.print(f"... and {len(corrupt) - shown} more rejected line(s) (see --json)")
    ignored = Counter(r.unsupported_type for r in rejected if r.unsupported_type is not None)
    if ignored:
        kinds = ", ".join(f"{n} {kind}" for kind, n in sorted(ignored.items()))
        console.print(f"ignored (sentence types kinsync does not read, not errors): {kinds}")


def _fit_logs(
    pps: Path,
    nmea: Path,
    baud: float,
    conv: Convention,
    piecewise: bool,
    model_out: Path | None,
    figure: Path | None,
) -> tuple[ClockFit, NmeaLog]:
    """Read the logs, fit the clock, write the model and the figure, showing the stages."""
    # Readers imported here, not at module level: they pull pyarrow, which other commands skip.
    from kinsync.io.clock_model import read_pps_csv, write_clock_model  # noqa: PLC0415
    from kinsync.io.nmea import read_nmea_log  # noqa: PLC0415

    with progress_display("clock fit") as progress:  # a day's NMEA log takes 10 s or more
        stages = Stages(progress, {"reading the logs": 3.0, "fitting": 1.0, "writing": 1.0})
        stages.start("reading the logs")
        pulses = read_pps_csv(pps)
        log = read_nmea_log(nmea)
        stages.start("fitting")
        result = fit_clock_to_log(pulses, log, baud=baud, convention=conv, piecewise=piecewise)
        stages.start("writing")
        if model_out is not None:
            write_clock_model(result.model, model_out, result)
        if figure is not None:
            from kinsync.report.clock_figures import (  # noqa: PLC0415  (matplotlib)
                clock_residual_figure,
            )

            atomic_write_bytes(figure, clock_residual_figure(result))
        stages.finish()
    return result, log


@app.command("apply")
def apply(
    model: Annotated[Path, typer.Option(help="Clock model JSON (kinsync clock fit --model-out).")],
    in_path: Annotated[Path, typer.Option("--in", help="CSV with a local-time column.")],
    out: Annotated[Path, typer.Option(help="CSV to write: every input column plus t_gps_s.")],
    column: Annotated[str, typer.Option(help="Local-time column (s).")] = "t_local_s",
    out_column: Annotated[str, typer.Option(help="Name of the GPS-time column added.")] = (
        "t_gps_s"
    ),
    outside: Annotated[
        str | None,
        typer.Option(
            help="Times outside the fitted span: extrapolate (all, with the linear model), "
            "raise or nan. Default: a linear model extrapolates up to one span length "
            "beyond either end and refuses times further out (another clock, most "
            "likely); a piecewise model refuses every time outside the span."
        ),
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Add GPS time (s since 1980-01-06) to a CSV by applying a clock model to a column."""
    # Readers imported here, not at module level: they pull pyarrow, which other commands skip.
    from kinsync.io.clock_model import read_clock_model  # noqa: PLC0415
    from kinsync.io.points import table_columns  # noqa: PLC0415
    from kinsync.io.tables import read_time_column  # noqa: PLC0415
    from kinsync.pipelines.clock_apply import write_with_gps_time  # noqa: PLC0415

    policy = _parse_outside(outside)
    if not out_column.strip() or any(c in out_column for c in ',"\r\n'):
        msg = (
            f"--out-column {out_column!r}: give a column name (not empty, without commas, "
            "quotes or line breaks)"
        )
        raise InputError(msg)
    if out.suffix.lower() != ".csv":
        msg = f"--out {out}: clock apply writes CSV; give a .csv file"
        raise InputError(msg)
    clock = read_clock_model(model)
    with progress_display("clock apply") as progress:
        stages = Stages(progress, {"reading the time column": 1.0, "writing": 3.0})
        stages.start("reading the time column")
        t_local, line_of_row = read_time_column(in_path, column)
        if out_column.strip() in [h.strip() for h in table_columns(in_path)]:
            msg = (
                f"{in_path}: already has a column {out_column!r}; choose another name with "
                "--out-column"
            )
            raise InputError(msg)
        inside = clock.inside_span(t_local)
        used = policy or ("raise" if clock.piecewise else "extrapolate")
        limits = None if policy is not None or clock.piecewise else clock.extrapolation_limits_s()
        where = _Column(in_path, column, line_of_row)
        if used == "raise":
            _refuse_outside(clock, model, where, t_local, ~inside)
        elif limits is not None:
            far = (t_local < limits[0]) | (t_local > limits[1])
            _refuse_far_outside(clock, model, where, t_local, far)
        t_gps = clock.apply(t_local, outside=used)
        stages.start("writing", f"writing {out}")
        n_rows = write_with_gps_time(
            in_path,
            out,
            out_column,
            t_gps,
            progress=lambda done: stages.say(f"writing: {done:,} of {t_gps.size:,} rows"),
        )
        stages.finish()
    n_outside = int(len(inside) - inside.sum())
    doc = {
        "in": str(in_path),
        "out": str(out),
        "column": column,
        "out_column": out_column,
        "n_rows": n_rows,
        "n_outside_span": n_outside,
        "outside": used,
        "span_local_s": list(clock.span_local_s),
        "extrapolation_limit_local_s": None if limits is None else list(limits),
        "piecewise": clock.piecewise,
    }
    if as_json:
        print_json(doc)
        return
    console.print(f"{out}: {counted(n_rows, 'row')}, column {out_column} added (GPS seconds)")
    if n_outside:
        lo, hi = clock.span_local_s
        what = "extrapolated with the linear model" if used == "extrapolate" else "set to nan"
        # One line, as a warning is (rich would wrap it at 80 columns, into a file too).
        note = f"{n_outside} time(s) outside the fitted span [{lo!r}, {hi!r}] s were {what}"
        print(f"kinsync: note: {note}", file=sys.stderr)


@dataclass(frozen=True)
class _Column:
    """The time column of a CSV, and how to name a data row's line."""

    source: Path
    name: str
    line_of_row: Callable[[int], int]


def _refuse_outside(
    clock: ClockModel,
    model: Path,
    column: _Column,
    t_local_s: FloatArray,
    outside: BoolArray,
) -> None:
    """Refuse times outside the fitted span (piecewise model, or ``--outside raise``)."""
    if not np.any(outside):
        return
    row = int(np.flatnonzero(outside)[0])
    lo, hi = clock.span_local_s
    kind = "piecewise " if clock.piecewise else ""
    msg = (
        f"{column.source}: line {column.line_of_row(row)}, column {column.name!r}: "
        f"{float(t_local_s[row])!r} s is outside the span the {kind}clock model {model} was "
        f"fitted on, [{lo!r}, {hi!r}] s ({counted(int(np.count_nonzero(outside)), 'row')} "
        "outside); fit the clock over a longer log, or give --outside nan (NaN there) or "
        "--outside extrapolate (the linear model)"
    )
    raise OutsideSpanError(msg)


def _refuse_far_outside(
    clock: ClockModel,
    model: Path,
    column: _Column,
    t_local_s: FloatArray,
    far: BoolArray,
) -> None:
    """Refuse times further from the fitted span than its own length (linear default)."""
    if not np.any(far):
        return
    row = int(np.flatnonzero(far)[0])
    t = float(t_local_s[row])
    lo, hi = clock.span_local_s
    where = f"{lo - t:.6g} s before" if t < lo else f"{t - hi:.6g} s after"
    msg = (
        f"{column.source}: line {column.line_of_row(row)}, column {column.name!r}: {t!r} s "
        f"lies {where} "
        f"the span the clock model {model} was fitted on, [{lo!r}, {hi!r}] s "
        f"({hi - lo:.6g} s long), further than that span's own length "
        f"({counted(int(np.count_nonzero(far)), 'row')} that far out): the column is most "
        "likely on another clock or time base (Unix time against time since boot, say); "
        "apply a model fitted on the clock that wrote it, or force the line with --outside "
        "extrapolate (or --outside nan: NaN outside the span)"
    )
    raise OutsideSpanError(msg)
