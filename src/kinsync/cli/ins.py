"""``kinsync ins``: loosely coupled INS/GNSS (SPEC section 6).

``kinsync ins run`` filters IMU and GNSS files into a navigation solution at the IMU
rate (CSV with σ and biases, or SBET); ``kinsync ins compare`` compares a solution
with a reference trajectory.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer
from rich.table import Table

from kinsync._text import counted
from kinsync.cli._help import literal
from kinsync.cli._options import GPS_WEEK_SPAN_HELP, MaxGapOpt, refuse_unused_gps_week
from kinsync.cli._output import console, fmt, print_json, quantity_table, warn
from kinsync.cli._progress import progress_display
from kinsync.errors import ConvergenceError, InputError
from kinsync.frames import quaternion_to_euler_rpy
from kinsync.progress import part, report

# The INS (numba, scipy.stats) and its readers load inside the commands, only when they run.
if TYPE_CHECKING:
    from kinsync.ins.config import InsConfig
    from kinsync.ins.file_rows import FileRows
    from kinsync.ins.measurements import GnssData, ImuData
    from kinsync.ins.solution import InitialState, NavSolution

__all__ = ["app", "compare", "run"]

app = typer.Typer(
    help="Loosely coupled INS/GNSS: filter IMU + GNSS files, compare with a reference.",
    no_args_is_help=True,
)

_DEFAULT_STATIC_S = 5.0
_CSV_SUFFIXES = (".csv",)
_SBET_SUFFIXES = (".sbet", ".out")


def _check_output(out: Path) -> None:
    suffix = out.suffix.lower()
    if suffix not in _CSV_SUFFIXES + _SBET_SUFFIXES:
        msg = (
            f"--out {out}: unknown output type {suffix!r}; use .csv (solution with σ and "
            "biases) or .sbet/.out (SBET)"
        )
        raise InputError(msg)
    parent = out.parent if str(out.parent) else Path()
    if not parent.is_dir():
        msg = f"--out {out}: output folder {parent} does not exist; create it first"
        raise InputError(msg)


def _initial_state_from_file(path: Path, imu: ImuData, max_gap_s: float | None) -> InitialState:
    """The reference state at the IMU start (interpolated when the file covers it).

    When the file starts after the first IMU sample, its first record is used (the
    filter then starts at that record's IMU epoch). ``max_gap_s``: the file's gap
    threshold (`kinsync.trajectory_gaps.max_gap_for`).
    """
    from kinsync.ins.solution import InitialState  # noqa: PLC0415
    from kinsync.io.trajectory_csv import read_trajectory_csv  # noqa: PLC0415
    from kinsync.trajectory_gaps import (  # noqa: PLC0415
        GAP_ADVICE,
        gap_threshold_text,
        max_gap_for,
    )

    traj = read_trajectory_csv(path)
    if traj.vel_ned_m_s is None or traj.lat_lon_h is None:
        msg = (
            f"--init-from {path}: needs geodetic positions and the velocity columns "
            "vn_m_s,ve_m_s,vd_m_s (the truth layout)"
        )
        raise InputError(msg)
    limit_s = max_gap_for(traj.t_s, max_gap_s)
    t0 = float(imu.t_s[0])
    gap = [g for g in traj.gaps(limit_s) if g.t_start_s < t0 < g.t_end_s]
    if gap:
        msg = (
            f"--init-from {path}: the IMU starts at t = {t0!r} s, inside a data gap of the "
            f"file ({gap[0].describe()} without a record; "
            f"{gap_threshold_text(limit_s, given=max_gap_s is not None)}), "
            f"where its state is not interpolated: {GAP_ADVICE}, or give a reference with "
            "a record near the IMU start"
        )
        raise InputError(msg)
    if traj.contains(t0, max_gap_s=limit_s):
        sample = traj.interpolate([t0], max_gap_s=limit_s)
        assert sample.lat_lon_h is not None
        lat, lon, h = (float(v) for v in sample.lat_lon_h[0])
        q = sample.q_body_to_ned[0]
        vel = [float(np.interp(t0, traj.t_s, traj.vel_ned_m_s[:, i])) for i in range(3)]
    else:
        if traj.t_start_s < t0 or traj.t_start_s > float(imu.t_s[-1]):
            msg = (
                f"--init-from {path}: its span [{traj.t_start_s!r}, {traj.t_end_s!r}] s does "
                f"not reach the IMU span [{t0!r}, {float(imu.t_s[-1])!r}] s"
            )
            raise InputError(msg)
        lat, lon, h = (float(v) for v in traj.lat_lon_h[0])
        q = traj.q_body_to_ned[0]
        vel = [float(v) for v in traj.vel_ned_m_s[0]]
        t0 = traj.t_start_s
    roll, pitch, yaw = (float(v) for v in quaternion_to_euler_rpy(q))
    return InitialState(
        t_s=t0,
        lat_deg=lat,
        lon_deg=lon,
        h_m=h,
        vel_ned_m_s=(vel[0], vel[1], vel[2]),
        rpy_rad=(roll, pitch, yaw),
    )


def _check_run_options(
    out: Path, init_from: Path | None, static_s: float | None, max_gap_s: float | None
) -> float:
    """Refuse ``ins run`` options that conflict; the static period to level over (s)."""
    _check_output(out)
    if static_s is not None and init_from is not None:
        msg = (
            f"--static-s {static_s:g} sets the levelling of a start without --init-from; "
            f"--init-from {init_from} gives the initial state instead: leave one out"
        )
        raise InputError(msg)
    static = _DEFAULT_STATIC_S if static_s is None else static_s
    if init_from is None and not static > 0.0:
        msg = (
            f"--static-s {static:g}: the levelling needs a standstill above 0 s at the start "
            "of the IMU record; give its length, or a reference state with --init-from"
        )
        raise InputError(msg)
    if max_gap_s is not None and init_from is None:
        msg = (
            "--max-gap-s is the gap threshold of the reference read with --init-from: give "
            "--init-from, or leave --max-gap-s out"
        )
        raise InputError(msg)
    return static


def _file_rows(path: Path, first_row: int = 0) -> FileRows:
    """The rows of a CSV read into a container, with their file lines, for messages.

    ``first_row``: the file's data row that holds the container's row 0.
    """
    from kinsync.ins.file_rows import FileRows  # noqa: PLC0415
    from kinsync.io.row_position import csv_line_of_row  # noqa: PLC0415

    def line_of_row(row: int) -> int:
        line = csv_line_of_row(path, row)
        return row + 2 if line is None else line

    return FileRows(line_of_row, first_row)


def _write_solution(solution: NavSolution, out: Path) -> dict[str, Any]:
    """Write the solution; an SBET with its σ in an smrmsg beside it, published together.

    Returns what the summary says of an SBET output (empty for a CSV): the GPS week of
    its seconds of week (``sbet_gps_week``, None when the times were seconds of week
    already) and its smrmsg file.
    """
    from kinsync.io.atomic import published_together  # noqa: PLC0415
    from kinsync.io.nav_csv import write_nav_csv  # noqa: PLC0415
    from kinsync.io.sbet import sbet_gps_week, write_sbet  # noqa: PLC0415
    from kinsync.io.smrmsg import SmrmsgData, smrmsg_companion_path, write_smrmsg  # noqa: PLC0415

    if out.suffix.lower() not in _SBET_SUFFIXES:
        write_nav_csv(solution, out)
        return {}
    companion = smrmsg_companion_path(out)
    sigma = SmrmsgData(
        t_s=solution.t_s,
        std_pos_ned_m=solution.std_pos_ned_m,
        std_vel_ned_m_s=solution.std_vel_ned_m_s,
        std_rpy_rad=solution.std_rpy_rad(),
    )
    with published_together():  # neither replaces an earlier file unless both are complete
        write_sbet(solution.to_trajectory(), out)
        write_smrmsg(sigma, companion)
    return {"sbet_gps_week": sbet_gps_week(solution.t_s), "smrmsg": str(companion)}


def _sbet_note(out: Path) -> str:
    """The warning of an SBET output: its body accelerations are not filled."""
    return (
        f"{out}: the SBET's body accelerations (fields 11-13) are written as 0: kinsync "
        "does not compute them; take accelerations from the IMU file where they are needed"
    )


@app.command("run")
def run(
    imu_path: Annotated[
        Path,
        typer.Option(
            "--imu",
            help=literal(
                "IMU CSV: t_s + gyro_[xyz]_rad_s + acc_[xyz]_m_s2, or t_s + dtheta_[xyz]_rad "
                "+ dv_[xyz]_m_s (body X forward, Y right, Z down)."
            ),
        ),
    ],
    gnss_path: Annotated[
        Path,
        typer.Option(
            "--gnss",
            help=literal(
                "GNSS CSV: t_s,lat_deg,lon_deg,h_m [+ std_n_m,std_e_m,std_d_m] "
                "[+ vn_m_s,ve_m_s,vd_m_s [+ std_vn_m_s,std_ve_m_s,std_vd_m_s]]."
            ),
        ),
    ],
    config_path: Annotated[
        Path, typer.Option("--config", help="INS configuration TOML (IMU error model, ...).")
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Output solution at the IMU rate: .csv (with σ and biases) or .sbet/.out "
            "(SBET, body accelerations written as 0; its σ in an smrmsg beside it: "
            "smrmsg<rest> for sbet<rest>, else smrmsg_<name>.out).",
        ),
    ],
    init_from: Annotated[
        Path | None,
        typer.Option(
            "--init-from",
            help="Initial state from a truth-layout CSV (t_s,lat_deg,lon_deg,h_m,vn_m_s,...,"
            "yaw_deg): its state at the first IMU epoch (interpolated between records), or "
            "its first record when it starts later. Default: static levelling + "
            "GNSS-velocity heading.",
        ),
    ] = None,
    static_s: Annotated[
        float | None,
        typer.Option(
            "--static-s",
            help="Without --init-from: length (s) of the static period at the IMU start "
            "used for levelling (default 5).",
        ),
    ] = None,
    no_velocity: Annotated[
        bool, typer.Option("--no-velocity", help="Use GNSS positions only, not velocities.")
    ] = False,
    smooth: Annotated[
        bool,
        typer.Option("--smooth", help="Write the Rauch-Tung-Striebel smoothed solution."),
    ] = False,
    max_gap_s: MaxGapOpt = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="Print one JSON object instead of a table.")
    ] = False,
) -> None:
    """Filter IMU + GNSS into a navigation solution (error-state EKF, 21 to 28 states).

    21 error states, 27 with scale factors; one more after a static start (no
    --init-from): 22 or 28.

    --max-gap-s is the gap threshold of the --init-from reference.
    """
    from kinsync.ins.alignment import align_static_gnss_heading  # noqa: PLC0415
    from kinsync.ins.checks import check_inputs, gnss_within_imu_span  # noqa: PLC0415
    from kinsync.ins.filter import run_ins  # noqa: PLC0415
    from kinsync.io.gnss_csv import read_gnss_csv  # noqa: PLC0415
    from kinsync.io.imu_csv import read_imu_csv  # noqa: PLC0415
    from kinsync.io.ins_config import read_ins_config  # noqa: PLC0415

    static_s = _check_run_options(out, init_from, static_s, max_gap_s)
    config = read_ins_config(config_path)
    imu = read_imu_csv(imu_path)
    gnss = read_gnss_csv(gnss_path)
    # Checked before levelling on them; run_ins takes these warnings instead of checking again.
    warnings = check_inputs(
        imu,
        gnss,
        config,
        imu_source=str(imu_path),
        gnss_source=str(gnss_path),
        static_s=static_s,
        config_source=str(config_path),
        imu_rows=_file_rows(imu_path),
        gnss_rows=_file_rows(gnss_path),
    )
    # the epochs before the IMU start are cut off: the messages name the file's rows
    gnss_rows = _file_rows(gnss_path, int(np.count_nonzero(gnss.t_s < imu.t_s[0])))
    gnss = gnss_within_imu_span(gnss, imu)
    init = (
        align_static_gnss_heading(
            imu,
            gnss,
            static_s=static_s,
            antenna_lever_arm_body_m=config.antenna_lever_arm_body_m,
            gyro_bias_rad_s=config.init_gyro_bias_rad_s,
            acc_bias_m_s2=config.init_acc_bias_m_s2,
            gnss_source=str(gnss_path),
            gnss_rows=gnss_rows,
        )
        if init_from is None
        else _initial_state_from_file(init_from, imu, max_gap_s)
    )
    skipped = _before_start(imu, gnss, init.t_s, init_from)
    if skipped:
        warnings.append(skipped)
    with progress_display("ins run") as progress:  # after the input checks: errors stay one line
        start = time.perf_counter()
        # run_ins checks the initial state and the χ² rejections; an error carries the
        # input checks' warnings (printed below only after a run that succeeded)
        result = run_ins(
            imu,
            gnss,
            config,
            init,
            use_velocity=not no_velocity,
            smooth=smooth,
            progress=part(progress, 0.0, 0.9),
            imu_source=str(imu_path),
            gnss_source=str(gnss_path),
            static_s=static_s,
            input_warnings=warnings,
            gnss_rows=gnss_rows,
        )
        seconds = time.perf_counter() - start
        solution = result.smoothed if smooth else result.forward
        if solution is None:
            msg = "the smoother returned no solution; run without --smooth"
            raise ConvergenceError(msg)
        report(progress, 0.9, "writing")
        written = _write_solution(solution, out)
        report(progress, 1.0, "writing")
    warnings = [*result.warnings, *([_sbet_note(out)] if written else [])]
    for warning in warnings:  # after the run: a failed run prints one error line
        warn(warning)
    summary = _run_document(
        solution, config, seconds=seconds, smooth=smooth, out=out, states=result.error_states
    )
    summary |= written
    summary["gnss_rejected_t_s"] = result.gnss_rejected_t_s.tolist()  # each one, by its time
    summary["warnings"] = warnings
    if as_json:
        print_json(summary)
        return
    _print_run_table(summary, solution, title=f"INS/GNSS {imu_path} + {gnss_path} -> {out}")


def _before_start(imu: ImuData, gnss: GnssData, t0_s: float, init_from: Path | None) -> str:
    """Warning for the IMU and GNSS epochs before the initial state (not filtered)."""
    n_imu = int(np.count_nonzero(imu.t_s < t0_s - 1e-3))
    if n_imu == 0:
        return ""
    n_gnss = int(np.count_nonzero(gnss.t_s < t0_s - 1e-3))
    return (
        f"{n_imu} IMU epochs (t_s {imu.t_s[0]:.3f} .. {imu.t_s[n_imu - 1]:.3f}) and {n_gnss} "
        f"GNSS epochs before the initial state at t_s {t0_s:.3f} are not filtered: the "
        f"reference given with --init-from {init_from} starts there"
    )


def _run_document(
    solution: NavSolution,
    config: InsConfig,
    *,
    seconds: float,
    smooth: bool,
    out: Path,
    states: int,
) -> dict[str, Any]:
    """The ``--json`` document of ``ins run`` (without its warnings)."""
    n = len(solution)
    calibrated = config.init_gyro_bias_rad_s is not None or config.init_acc_bias_m_s2 is not None
    return {
        "epochs": n,
        "gnss_used": int(solution.n_gnss_used),
        "gnss_rejected": int(solution.n_gnss_rejected),
        "seconds": seconds,
        "epochs_per_s": n / seconds if seconds > 0 else None,
        "smoothed": smooth,
        "out": str(out),
        "error_states": states,
        "turn_on_biases": "calibrated" if calibrated else "estimated from zero",
        "final_gyro_bias_deg_h": [
            math.degrees(float(v)) * 3600.0 for v in solution.gyro_bias_rad_s[-1]
        ],
        "final_acc_bias_mg": [float(v) / 9.80665e-3 for v in solution.acc_bias_m_s2[-1]],
        "final_gyro_scale_ppm": (
            None if solution.gyro_scale_ppm is None else solution.gyro_scale_ppm[-1].tolist()
        ),
        "final_acc_scale_ppm": (
            None if solution.acc_scale_ppm is None else solution.acc_scale_ppm[-1].tolist()
        ),
    }


def _rejected_text(doc: dict[str, Any], shown: int = 5) -> str:
    """The χ² rejections: their count, and the times of the first ``shown``."""
    times = doc.get("gnss_rejected_t_s") or []
    if not times:
        return str(doc["gnss_rejected"])
    listed = ", ".join(f"{t:.3f}" for t in times[:shown])
    more = f", ... ({len(times)} in all, --json lists each)" if len(times) > shown else ""
    return f"{doc['gnss_rejected']} (t_s {listed}{more})"


def _print_run_table(doc: dict[str, Any], solution: NavSolution, *, title: str) -> None:
    table = quantity_table(title)
    seconds = float(doc["seconds"])
    table.add_row("epochs written", str(doc["epochs"]))
    table.add_row("solution", "smoothed (RTS)" if doc["smoothed"] else "forward filter")
    table.add_row("GNSS epochs used", str(doc["gnss_used"]))
    table.add_row("GNSS epochs rejected (χ² gate)", _rejected_text(doc))
    table.add_row("seconds", fmt(seconds))
    table.add_row("epochs per second", fmt(doc["epochs_per_s"]))
    table.add_row(
        "final σ N, E, D (m)",
        ", ".join(fmt(float(v)) for v in solution.std_pos_ned_m[-1]),
    )
    table.add_row(
        f"error states (turn-on biases {doc['turn_on_biases']})", str(doc["error_states"])
    )
    rows = (
        ("final gyro bias x, y, z (deg/h)", doc["final_gyro_bias_deg_h"]),
        ("final accelerometer bias x, y, z (mg)", doc["final_acc_bias_mg"]),
        ("final gyro scale factor x, y, z (ppm)", doc["final_gyro_scale_ppm"]),
        ("final accelerometer scale factor (ppm)", doc["final_acc_scale_ppm"]),
    )
    for label, values in rows:
        if values is not None:
            table.add_row(label, ", ".join(_triple(values)))
    if "smrmsg" in doc:
        week = doc["sbet_gps_week"]
        table.add_row(
            "SBET GPS week",
            "not known (the input times are seconds of week)"
            if week is None
            else f"{week} (read the SBET with --gps-week {week})",
        )
        table.add_row("σ (smrmsg, beside the SBET)", Path(doc["smrmsg"]).name)
    console.print(table)


def _triple(values: Sequence[float] | None, digits: int = 4) -> list[str]:
    if values is None:
        return ["-"] * 3
    return [fmt(v, digits=digits) if math.isfinite(v) else "-" for v in values]


@app.command("compare")
def compare(
    solution_path: Annotated[
        Path,
        typer.Argument(
            help="Solution: .csv (kinsync ins run output, or any trajectory CSV) or .sbet/.out.",
            metavar="TRAJ",
        ),
    ],
    truth_path: Annotated[
        Path,
        typer.Argument(
            help=literal(
                "Reference trajectory: .csv (t_s,lat_deg,lon_deg,h_m,[vn_m_s,...,]roll_deg,"
                "pitch_deg,yaw_deg) or .sbet/.out."
            ),
            metavar="TRUTH",
        ),
    ],
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week", help="GPS week of SBET seconds-of-week times. " + GPS_WEEK_SPAN_HELP
        ),
    ] = None,
    max_gap_s: MaxGapOpt = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="Print one JSON object instead of a table.")
    ] = False,
) -> None:
    """Compare a solution with a reference: RMS/max errors N/E/D, velocity, attitude.

    Epochs outside the reference's span or in one of its data gaps (a record interval
    over --max-gap-s, by default 10 median intervals, never interpolated across) are
    left out and counted.
    """
    from kinsync.ins.compare import compare_to_truth  # noqa: PLC0415
    from kinsync.ins.solution import NavSolution  # noqa: PLC0415
    from kinsync.io.nav_csv import read_navigation  # noqa: PLC0415
    from kinsync.trajectory_gaps import (  # noqa: PLC0415
        GAP_ADVICE,
        gap_threshold_shown_s,
        gap_threshold_text,
    )

    refuse_unused_gps_week(gps_week, navigation=[solution_path, truth_path])
    solution = read_navigation(solution_path, gps_week=gps_week)
    truth = read_navigation(truth_path, gps_week=gps_week)
    if isinstance(truth, NavSolution):
        truth = truth.to_trajectory()
    result = compare_to_truth(solution, truth, max_gap_s=max_gap_s)
    if result.n_in_truth_gaps:
        named = "; ".join(g.describe() for g in result.truth_gaps[:3])
        more = f"; and {len(result.truth_gaps) - 3} more" if len(result.truth_gaps) > 3 else ""
        warn(
            f"{truth_path}: {counted(result.n_in_truth_gaps, 'solution epoch')} "
            f"left out, in {counted(len(result.truth_gaps), 'data gap')} of the reference "
            f"({named}{more}), {gap_threshold_text(result.truth_gap_threshold_s)}, where it "
            f"is not interpolated: {GAP_ADVICE}"
        )
    if result.max_abs_pitch_deg > _GIMBAL_WARNING_PITCH_DEG:
        warn(
            f"{truth_path}: the reference pitches to "
            f"{result.max_abs_pitch_deg:.2f} deg: near 90 deg roll and yaw are ill-defined "
            "(gimbal lock) and their differences can be large for a small misorientation; "
            "read the misorientation about N, E, D (misorientation RMS, "
            "rms_misorientation_ned_deg) instead"
        )
    if as_json:
        print_json(result.as_document())
        return
    table = Table(title=f"{solution_path} vs {truth_path} ({counted(result.n_epochs, 'epoch')})")
    table.add_column("error")
    for axis in ("N / roll", "E / pitch", "D / yaw"):
        table.add_column(axis, justify="right")
    table.add_row("position RMS (m)", *_triple(result.rms_pos_ned_m))
    table.add_row("position max (m)", *_triple(result.max_pos_ned_m))
    table.add_row("velocity RMS (m/s)", *_triple(result.rms_vel_ned_m_s))
    table.add_row("velocity max (m/s)", *_triple(result.max_vel_ned_m_s))
    table.add_row("attitude RMS (deg)", *_triple(result.rms_att_deg))
    table.add_row("attitude max (deg)", *_triple(result.max_att_deg))
    table.add_row("misorientation RMS (deg, N/E/D)", *_triple(result.rms_misorientation_ned_deg))
    if result.within_3sigma is not None:
        w = result.within_3sigma
        for kind, label in (("pos", "position"), ("vel", "velocity"), ("att", "misorientation")):
            shares = tuple(w.get(f"{kind}_{a}", float("nan")) for a in "ned")
            table.add_row(f"{label} within 3σ (share)", *_triple(shares, digits=3))
    console.print(table)
    if result.n_outside_truth or result.n_in_truth_gaps:
        limit_s = result.truth_gap_threshold_s
        console.print(
            f"left out: {result.n_outside_truth} epoch(s) outside the reference's span, "
            f"{result.n_in_truth_gaps} in its data gaps (record intervals longer than "
            f"{limit_s if max_gap_s is not None else gap_threshold_shown_s(limit_s):.6g} s, "
            "--max-gap-s)",
            highlight=False,
        )


_GIMBAL_WARNING_PITCH_DEG = 80.0
"""Above this |pitch| of the reference `ins compare` warns that roll and yaw errors mean
little: at 80 deg an error of 0.01 deg about North reads as 0.06 deg of roll and yaw."""
