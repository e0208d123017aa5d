"""Demo section for the loosely coupled INS/GNSS filter and smoother.

`ins_section`: a MEMS-grade (ADIS16488-like) IMU on a car that stands still, then
drives an oval; RTK GNSS with an outage in the middle. The real workflow: static
levelling and GNSS course-over-ground heading (`align_static_gnss_heading`), the
forward filter and the RTS smoother (`run_ins`), both compared with the simulation's
truth (`compare_to_truth`).

The NaveGo check on external data is `kinsync.demo.navego`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._typing import BoolArray, FloatArray
from kinsync._validate import finite_number, positive_number
from kinsync.demo.files import write_section_files
from kinsync.demo.tolerances import OUTAGE_TRAJECTORY, SIGMA_CONSISTENT, SIGMA_COVERAGE
from kinsync.errors import InputError
from kinsync.frames import ecef_to_ned, geodetic_to_ecef
from kinsync.ins.alignment import align_static_gnss_heading
from kinsync.ins.compare import Comparison, compare_to_truth
from kinsync.ins.config import InsConfig
from kinsync.ins.filter import InsResult, run_ins
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.report.html import Figure, Section, Table
from kinsync.report.ins_figures import ErrorSeries, error_envelope_figure, route_map_figure
from kinsync.report.verdict import Check
from kinsync.sim.drive import DriveSimConfig, DriveSimulation, simulate_drive

__all__ = [
    "ERROR_HEADERS",
    "InsDemoSetup",
    "ins_section",
]

Summary = list[tuple[str, str, str]]
Vector3 = tuple[float, float, float]

_MG = 9.80665e-3


@dataclass(frozen=True)
class InsDemoSetup:
    """The simulated MEMS drive of `ins_section` (defaults: the report's scenario).

    Attributes
    ----------
    duration_s : float
        Record length (s), static start included.
    static_s : float
        Standstill at the start (s).
    align_s : float
        Part of the standstill used for levelling (s), ``< static_s``; the filter starts
        at the first IMU epoch (the vehicle stands still throughout).
    speed_m_s : float
        Cruise speed on the oval (m/s).
    outage_s : (float, float)
        GNSS outage start and end (s), inside the drive.
    seed : int
        Simulation seed.
    """

    duration_s: float = 240.0
    static_s: float = 30.0
    align_s: float = 25.0
    speed_m_s: float = 5.0
    outage_s: tuple[float, float] = (120.0, 145.0)
    seed: int = 1

    def __post_init__(self) -> None:
        for name in ("duration_s", "static_s", "align_s", "speed_m_s"):
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        if self.align_s >= self.static_s:
            msg = f"align_s ({self.align_s} s) must be shorter than static_s ({self.static_s} s)"
            raise InputError(msg)
        start, end = (finite_number(v, "outage_s") for v in self.outage_s)
        if not self.static_s < start < end < self.duration_s:
            msg = (
                f"outage_s ({start}, {end}) must lie after the static start ({self.static_s} s) "
                f"and before the end ({self.duration_s} s)"
            )
            raise InputError(msg)
        object.__setattr__(self, "outage_s", (start, end))

    def drive_config(self) -> DriveSimConfig:
        """The `DriveSimConfig` of this drive (MEMS preset, oval, RTK GNSS defaults)."""
        return DriveSimConfig(
            route="oval",
            speed_m_s=self.speed_m_s,
            duration_s=self.duration_s,
            static_s=self.static_s,
            imu="mems",
            gnss_outages=(self.outage_s,),
            seed=self.seed,
        )


# ---------------------------------------------------------------------- formatting
def _g(value: float) -> str:
    return f"{value:.3g}"


def _triple(values: Sequence[float] | None, scale: float = 1.0) -> str:
    if values is None:
        return "-"
    return " / ".join(_g(v * scale) for v in values)


def _shares(within: Mapping[str, float] | None, block: str) -> str:
    if within is None:
        return "-"
    return " / ".join(f"{100.0 * within[f'{block}_{a}']:.1f}" for a in "ned")


def _plus_minus(value: float, std: float) -> str:
    decimals = max(0, 1 - math.floor(math.log10(std))) if std > 0 and math.isfinite(std) else 3
    return f"{value:.{decimals}f} ± {std:.{decimals}f}"


def _rms(err: FloatArray) -> Vector3:
    r = np.sqrt(np.mean(err**2, axis=0))
    return (float(r[0]), float(r[1]), float(r[2]))


def _max(err: FloatArray) -> Vector3:
    r = np.max(np.abs(err), axis=0)
    return (float(r[0]), float(r[1]), float(r[2]))


def _subset_errors(cmp: Comparison, mask: BoolArray) -> dict[str, Vector3]:
    """RMS and largest absolute errors over the epochs of ``mask``."""
    out = {
        "rms_pos_ned_m": _rms(cmp.err_pos_ned_m[mask]),
        "max_pos_ned_m": _max(cmp.err_pos_ned_m[mask]),
        "rms_att_deg": _rms(cmp.err_att_deg[mask]),
        "max_att_deg": _max(cmp.err_att_deg[mask]),
    }
    if cmp.err_vel_ned_m_s is not None:
        out["rms_vel_ned_m_s"] = _rms(cmp.err_vel_ned_m_s[mask])
        out["max_vel_ned_m_s"] = _max(cmp.err_vel_ned_m_s[mask])
    return out


def _error_row(label: str, e: dict[str, Any]) -> list[str]:
    return [
        label,
        _triple(e["rms_pos_ned_m"]),
        _triple(e["max_pos_ned_m"]),
        _triple(e.get("rms_vel_ned_m_s")),
        _triple(e.get("max_vel_ned_m_s")),
        _triple(e["rms_att_deg"]),
        _triple(e["max_att_deg"]),
    ]


ERROR_HEADERS = (
    "solution",
    "RMS position N/E/D (m)",
    "max |position| N/E/D (m)",
    "RMS velocity N/E/D (m/s)",
    "max |velocity| N/E/D (m/s)",
    "RMS roll/pitch/yaw (deg)",
    "max |roll/pitch/yaw| (deg)",
)
"""Columns of the error tables (cells: three values joined by " / ", 3 significant digits)."""


def _local_ne_m(lat_deg: FloatArray, lon_deg: FloatArray, origin: Vector3) -> FloatArray:
    """North, East (m) in the local level frame at ``origin`` (lat_deg, lon_deg, h_m)."""
    ecef = geodetic_to_ecef(lat_deg, lon_deg, np.full(np.shape(lat_deg), origin[2]))
    ned = ecef_to_ned(ecef, *origin)
    out: FloatArray = ned[:, :2]
    return out


def _series(label: str, cmp: Comparison, sol: NavSolution, what: str) -> ErrorSeries:
    k = np.searchsorted(sol.t_s, cmp.t_s)
    if what == "pos":
        return ErrorSeries(label, cmp.t_s, cmp.err_pos_ned_m, sol.std_pos_ned_m[k])
    return ErrorSeries(
        label,
        cmp.t_s,
        np.degrees(cmp.err_misorientation_ned_rad),
        np.degrees(sol.std_att_rad[k]),
    )


# ---------------------------------------------------------------------- MEMS drive
@dataclass(frozen=True, eq=False)
class _MemsRun:
    sim: DriveSimulation
    init: InitialState
    config: InsConfig
    result: InsResult
    forward: Comparison
    smoothed: Comparison


def _run_mems(setup: InsDemoSetup, progress: Callable[[str], None] | None) -> _MemsRun:
    if progress:
        progress("INS/GNSS: simulating the MEMS drive")
    sim = simulate_drive(setup.drive_config())
    init = align_static_gnss_heading(
        sim.imu,
        sim.gnss,
        static_s=setup.align_s,
        antenna_lever_arm_body_m=sim.config.antenna_lever_arm_body_m,
    )
    config = sim.ins_config  # the datasheet's figures as they are
    if progress:
        progress("INS/GNSS: forward filter and RTS smoother")
    result = run_ins(sim.imu, sim.gnss, config, init, smooth=True)
    assert result.smoothed is not None
    return _MemsRun(
        sim=sim,
        init=init,
        config=config,
        result=result,
        forward=compare_to_truth(result.forward, sim.truth),
        smoothed=compare_to_truth(result.smoothed, sim.truth),
    )


def _bias_rows(run: _MemsRun) -> tuple[list[list[str]], dict[str, Any]]:
    """Rows of the bias table (gyro in deg/s, accelerometer in mg) and their document."""
    errors = run.sim.imu_errors
    fwd = run.result.forward
    smo = run.result.smoothed
    assert smo is not None
    k0 = int(np.searchsorted(errors.t_s, fwd.t_s[0]))
    rows: list[list[str]] = []
    doc: dict[str, Any] = {}
    blocks = (
        ("gyro", "deg/s", math.degrees(1.0), errors.gyro_bias_total_rad_s(), "gyro_bias_rad_s"),
        ("accelerometer", "mg", 1.0 / _MG, errors.acc_bias_total_m_s2(), "acc_bias_m_s2"),
    )
    for name, unit, scale, injected, attr in blocks:
        est_s, est_f = getattr(smo, attr), getattr(fwd, attr)
        std_s, std_f = getattr(smo, "std_" + attr), getattr(fwd, "std_" + attr)
        aligned = getattr(run.init, attr)
        doc[attr] = {
            "injected_start": injected[k0].tolist(),
            "smoothed_start": est_s[0].tolist(),
            "smoothed_start_std": std_s[0].tolist(),
            "injected_end": injected[-1].tolist(),
            "forward_end": est_f[-1].tolist(),
            "forward_end_std": std_f[-1].tolist(),
            "alignment": list(aligned),
        }
        for i, axis in enumerate("XYZ"):
            rows.append(
                [
                    f"{name} {axis} ({unit})",
                    f"{injected[k0, i] * scale:.4f}",
                    _plus_minus(est_s[0, i] * scale, std_s[0, i] * scale),
                    f"{injected[-1, i] * scale:.4f}",
                    _plus_minus(est_f[-1, i] * scale, std_f[-1, i] * scale),
                    f"{aligned[i] * scale:.4f}" if name == "gyro" else "-",
                ]
            )
    return rows, doc


def _mems_figures(run: _MemsRun, s: InsDemoSetup, in_outage: BoolArray) -> tuple[Figure, ...]:
    """Position and attitude errors with ±3σ, and the route map with the outage."""
    fwd_sol, smo_sol = run.result.forward, run.result.smoothed
    assert smo_sol is not None
    a, b = s.outage_s
    t_out = f"{a:g}-{b:g} s"
    outage_idx = np.flatnonzero(in_outage)
    lo, hi = int(outage_idx[0]), int(outage_idx[-1]) + 1
    origin = (float(fwd_sol.lat_deg[0]), float(fwd_sol.lon_deg[0]), float(fwd_sol.h_m[0]))
    truth_at = run.sim.truth.interpolate(run.forward.t_s)
    assert truth_at.lat_lon_h is not None
    k = np.searchsorted(fwd_sol.t_s, run.forward.t_s)
    return (
        Figure(
            caption=(
                "Position error (solution minus truth, N/E/D) with the filter's ±3σ, "
                "forward filter (left) and smoothed (right); GNSS outage shaded"
            ),
            png=error_envelope_figure(
                [
                    _series("forward filter", run.forward, fwd_sol, "pos"),
                    _series("RTS smoothed", run.smoothed, smo_sol, "pos"),
                ],
                ("North", "East", "Down"),
                "m",
                "MEMS drive: position error",
                [s.outage_s],
            ),
        ),
        Figure(
            caption=(
                "Attitude error as the misorientation about N/E/D (deg) with ±3σ; the "
                "forward heading converges once the car accelerates and turns"
            ),
            png=error_envelope_figure(
                [
                    _series("forward filter", run.forward, fwd_sol, "att"),
                    _series("RTS smoothed", run.smoothed, smo_sol, "att"),
                ],
                ("about North", "about East", "about Down"),
                "deg",
                "MEMS drive: attitude error",
                [s.outage_s],
            ),
        ),
        Figure(
            caption=(
                "Left: the route (local frame at the start) with the GNSS fixes; right: "
                "forward and smoothed solutions through the outage"
            ),
            png=route_map_figure(
                _local_ne_m(truth_at.lat_lon_h[:, 0], truth_at.lat_lon_h[:, 1], origin),
                _local_ne_m(run.sim.gnss.lat_deg, run.sim.gnss.lon_deg, origin),
                [
                    ("forward filter", _local_ne_m(fwd_sol.lat_deg[k], fwd_sol.lon_deg[k], origin)),
                    ("RTS smoothed", _local_ne_m(smo_sol.lat_deg[k], smo_sol.lon_deg[k], origin)),
                ],
                (lo, hi),
                f"Oval at {s.speed_m_s:g} m/s, GNSS outage {t_out}",
            ),
        ),
    )


@dataclass(frozen=True, eq=False)
class _MemsOutcome:
    """The MEMS run's figures of merit, as the document, tables and text use them."""

    in_outage: BoolArray
    whole: dict[str, Any]
    outage: dict[str, Any]
    drift_m: dict[str, float]
    drift_std_m: dict[str, float]
    align_err_deg: FloatArray
    bias_rows: list[list[str]]
    bias_doc: dict[str, Any]
    acc_start_z: FloatArray


def _mems_outcome(s: InsDemoSetup, run: _MemsRun) -> _MemsOutcome:
    """Errors over the run and the outage, outage drift, alignment and bias errors."""
    a, b = s.outage_s
    in_outage = (run.forward.t_s >= a) & (run.forward.t_s <= b)
    last = int(np.flatnonzero(in_outage)[-1])
    t_last = run.forward.t_s[last]
    k_init = int(np.searchsorted(run.sim.truth.t_s, run.init.t_s))
    truth_rpy = np.degrees(run.sim.truth.euler_rpy_rad()[k_init])
    align_err = np.degrees(run.init.rpy_rad) - truth_rpy
    bias_rows, bias_doc = _bias_rows(run)
    smoothed_sol = run.result.smoothed
    assert smoothed_sol is not None
    return _MemsOutcome(
        in_outage=in_outage,
        whole={"forward": run.forward.as_document(), "smoothed": run.smoothed.as_document()},
        outage={
            "forward": _subset_errors(run.forward, in_outage),
            "smoothed": _subset_errors(run.smoothed, in_outage),
        },
        drift_m={
            name: float(np.hypot(*cmp.err_pos_ned_m[last, :2]))
            for name, cmp in (("forward", run.forward), ("smoothed", run.smoothed))
        },
        drift_std_m={
            name: float(np.hypot(*sol.std_pos_ned_m[int(np.searchsorted(sol.t_s, t_last)), :2]))
            for name, sol in (("forward", run.result.forward), ("smoothed", smoothed_sol))
        },
        align_err_deg=(align_err + 180.0) % 360.0 - 180.0,
        bias_rows=bias_rows,
        bias_doc=bias_doc,
        acc_start_z=np.abs(
            (smoothed_sol.acc_bias_m_s2[0] - np.array(bias_doc["acc_bias_m_s2"]["injected_start"]))
            / smoothed_sol.std_acc_bias_m_s2[0]
        ),
    )


def _mems_document(s: InsDemoSetup, run: _MemsRun, o: _MemsOutcome) -> dict[str, Any]:
    """The ``ins.json`` document."""
    sim, fwd_sol = run.sim, run.result.forward
    return {
        "setup": asdict(s),
        "imu_model": asdict(sim.config.imu_model()),
        "gnss_std_pos_ned_m": list(sim.config.gnss_std_pos_ned_m),
        "gnss_std_vel_ned_m_s": list(sim.config.gnss_std_vel_ned_m_s),
        "antenna_lever_arm_body_m": list(sim.config.antenna_lever_arm_body_m),
        "filter_config": asdict(run.config),
        "initial_state": asdict(run.init),
        "alignment_error_rpy_deg": o.align_err_deg.tolist(),
        "errors": o.whole,
        "errors_in_outage": o.outage,
        "horizontal_error_at_outage_end_m": o.drift_m,
        "smoothed_acc_bias_start_error_sigma": o.acc_start_z.tolist(),
        "biases": o.bias_doc,
        "gnss_used": fwd_sol.n_gnss_used,
        "gnss_rejected": fwd_sol.n_gnss_rejected,
    }


def _mems_tables(s: InsDemoSetup, run: _MemsRun, o: _MemsOutcome) -> tuple[Table, ...]:
    """Errors against the truth, 3-sigma shares and sensor biases."""
    a, b = s.outage_s
    t_out = f"{a:g}-{b:g} s"
    error_rows = [
        _error_row("forward filter", o.whole["forward"]),
        _error_row("smoothed", o.whole["smoothed"]),
        _error_row(f"forward filter, outage {t_out}", o.outage["forward"]),
        _error_row(f"smoothed, outage {t_out}", o.outage["smoothed"]),
    ]
    share_rows = [
        [
            label,
            _shares(cmp.within_3sigma, "pos"),
            _shares(cmp.within_3sigma, "vel"),
            _shares(cmp.within_3sigma, "att"),
        ]
        for label, cmp in (("forward filter", run.forward), ("smoothed", run.smoothed))
    ]
    bias_headers = (
        "bias",
        "injected, start",
        "smoothed, start",
        "injected, end",
        "forward, end",
        "static alignment",
    )
    return (
        Table(
            caption="Errors against the truth (whole run from the alignment epoch, and "
            "inside the GNSS outage only)",
            headers=ERROR_HEADERS,
            rows=error_rows,
        ),
        Table(
            caption="Share of epochs (%) with |error| within the filter's 3 sigma, "
            "N/E/D (attitude: misorientation about N/E/D)",
            headers=("solution", "position", "velocity", "attitude"),
            rows=share_rows,
        ),
        Table(
            caption="Sensor biases: injected (turn-on plus instability at that epoch) "
            "against the smoothed estimate at the start, the forward estimate at the end "
            "(1 sigma) and the static alignment's gyro estimate",
            headers=bias_headers,
            rows=o.bias_rows,
        ),
    )


def _mems_paragraphs(s: InsDemoSetup, run: _MemsRun, o: _MemsOutcome) -> tuple[str, ...]:
    """The section's text: set-up, workflow, outage, bias model."""
    a, b = s.outage_s
    fwd_sol = run.result.forward
    assert run.smoothed.within_3sigma is not None
    assert run.init.static_until_s is not None  # a static alignment sets it
    return (
        (
            f"An ADIS16488-like MEMS IMU (200 Hz; turn-on bias 0.2 deg/s and 16 mg per "
            "axis, bias instability 6.5 deg/h and 0.1 mg over 100 s, ARW 0.3 deg/sqrt(h), "
            f"VRW 0.029 m/s/sqrt(h)) on a car that stands still for {s.static_s:g} s, then "
            f"drives an oval (40 m straights, 10 m turns) at {s.speed_m_s:g} m/s until "
            f"{s.duration_s:g} s. RTK GNSS at 5 Hz (2/2/4 cm, 1/1/2 cm/s) on an antenna "
            "1.5 m above the IMU (lever arm 0.3, -0.2, -1.5 m), with no fixes from "
            f"{a:g} to {b:g} s."
        ),
        (
            f"The workflow: levelling over the first {s.align_s:g} s (roll and pitch from "
            "the mean specific force, gyro biases from the mean rate), heading from the "
            "GNSS course over ground once the car moves, then the forward filter (21 "
            "states, and one more for the vertical support the unknown tilt adds, ½gθ², "
            "until the turns show the tilt) with position and velocity updates (lever "
            "arm applied) and the RTS smoother, "
            f"from t = {run.init.t_s:g} s. Alignment error roll/pitch/yaw: "
            f"{_triple(o.align_err_deg.tolist())} deg; the accelerometer biases enter the "
            "levelling as tilt (10 mg is 0.57 deg), and the filter starts knowing that "
            "tilt and accelerometer bias err together, until the turns let it separate "
            "them; while the car stands it keeps the levelled attitude in the Jacobian of "
            "the accelerometer errors, so that it claims no more about the tilt than a "
            f"standstill shows (until t = {run.init.static_until_s:g} s). "
            f"{fwd_sol.n_gnss_used} GNSS epochs used, "
            f"{fwd_sol.n_gnss_rejected} rejected by the chi-square gate."
        ),
        (
            "Through the outage the forward solution drifts to "
            f"{o.drift_m['forward']:.2f} m horizontally by its last epoch; the smoother, "
            "which also uses the fixes after the outage, keeps the error to "
            f"{o.drift_m['smoothed'] * 100:.1f} cm. The smoothed errors stay inside the "
            "filter's 3-sigma on at least "
            f"{100 * min(run.smoothed.within_3sigma.values()):.1f} % of the epochs on "
            "every axis."
        ),
        (
            "Bias model: each sensor's bias is a turn-on bias (a random constant, sigma "
            "0.2 deg/s and 16 mg) plus the in-run instability (Gauss-Markov, 6.5 deg/h and "
            "0.1 mg over 100 s), two states per axis, with the datasheet's figures as "
            "they are. The smoothed accelerometer biases at the start lie within "
            f"{float(o.acc_start_z.max()):.1f} sigma of the injected ones; "
            f"{gyro_bias_sentence(o.bias_doc['gyro_bias_rad_s'])} (One "
            "Gauss-Markov state per bias, as before, relaxed its variance from the "
            "turn-on sigma to the instability within tau/2 = 50 s whatever the data said, "
            "and the filter grew over-confident in the biases it had not yet observed.)"
        ),
    )


def gyro_bias_sentence(gyro: Mapping[str, Any]) -> str:
    """How far the smoothed start gyro biases lie from the injected ones, in their σ.

    Parameters
    ----------
    gyro : mapping
        ``ins.json``'s ``biases.gyro_bias_rad_s``: ``smoothed_start``,
        ``smoothed_start_std`` and ``injected_start``, 3 values each (rad/s).

    Returns
    -------
    str
        One sentence; an axis beyond 3σ is named with its values (deg/s) and said to
        have a σ too small.
    """
    est = np.asarray(gyro["smoothed_start"], dtype=float)
    std = np.asarray(gyro["smoothed_start_std"], dtype=float)
    inj = np.asarray(gyro["injected_start"], dtype=float)
    z = (est - inj) / std
    worst = int(np.argmax(np.abs(z)))
    if abs(z[worst]) <= SIGMA_CONSISTENT.limit:
        return f"the gyro biases within {float(np.max(np.abs(z))):.1f} sigma."
    d = math.degrees(1.0)
    axes = "XYZ"
    off = [i for i in range(3) if abs(z[i]) > SIGMA_CONSISTENT.limit]
    named = "; ".join(
        f"gyro {axes[i]} {est[i] * d:.5f} ± {std[i] * d:.5f} deg/s against {inj[i] * d:.4f} "
        f"injected ({z[i]:+.2f} sigma)"
        for i in off
    )
    return (
        f"the gyro biases do not all: {named}. Beyond 3 sigma the smoother's gyro bias sigma "
        "is too small for that axis at the start of the run (no check of this report judges "
        "it)."
    )


def _gyro_caveats(gyro: Mapping[str, Any]) -> tuple[str, ...]:
    """The gyro bias sentence as a caveat of the verdict, when an axis lies beyond 3σ."""
    sentence = gyro_bias_sentence(gyro)
    if sentence.startswith("the gyro biases within"):
        return ()
    return ("Smoothed start biases: " + sentence,)


def _mems_summary_row(s: InsDemoSetup, o: _MemsOutcome) -> tuple[str, str, str]:
    """The terminal summary's row for the MEMS drive."""
    a, b = s.outage_s
    sm = o.whole["smoothed"]
    return (
        "INS/GNSS (MEMS)",
        (
            f"oval {s.duration_s / 60:.0f} min at {s.speed_m_s:g} m/s, static alignment, "
            f"{b - a:g} s GNSS outage"
        ),
        (
            f"outage drift forward {o.drift_m['forward']:.2f} m, smoothed "
            f"{o.drift_m['smoothed'] * 100:.1f} cm; smoothed RMS position "
            f"{_triple(sm['rms_pos_ned_m'])} m, roll/pitch/yaw {_triple(sm['rms_att_deg'])} deg"
        ),
    )


def _mems_checks(s: InsDemoSetup, run: _MemsRun, o: _MemsOutcome) -> tuple[Check, ...]:
    """The MEMS drive's verdict: the smoothed trajectory through the outage, honest σ."""
    assert run.smoothed.within_3sigma is not None
    a, b = s.outage_s
    shares = run.smoothed.within_3sigma
    worst = min(shares, key=lambda k: shares[k])
    return (
        Check(
            f"smoothed horizontal position error at the end of the {b - a:g} s GNSS outage",
            o.drift_m["smoothed"] * 1e3,
            OUTAGE_TRAJECTORY,
            o.drift_std_m["smoothed"] * 1e3,
            detail=f"forward filter alone {o.drift_m['forward']:.2f} m",
        ),
        Check(
            "share of epochs whose smoothed error lies inside ±3σ, worst axis",
            100.0 * shares[worst],
            SIGMA_COVERAGE,
            detail=worst.replace("_", " "),
        ),
    )


def ins_section(
    out_dir: Path,
    summary: Summary,
    *,
    setup: InsDemoSetup | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[Section, dict[str, Any]]:
    """Simulate a MEMS drive, align, filter, smooth, compare with the truth.

    Writes ``ins.json`` and ``ins_1.png`` .. ``ins_3.png`` into ``out_dir`` and appends a
    summary row.

    Parameters
    ----------
    out_dir : Path
        Report folder (exists).
    summary : list of (str, str, str)
        Receives the (capability, scenario, result) row.
    setup : InsDemoSetup, optional
        The drive; the report's scenario by default (tests pass a shorter one).
    progress : callable, optional
        Called with a short label as each stage starts.

    Returns
    -------
    (Section, dict)
        The report section and the document written to ``ins.json``.
    """
    s = setup or InsDemoSetup()
    run = _run_mems(s, progress)
    if progress:
        progress("INS/GNSS: figures")
    assert run.forward.within_3sigma is not None
    assert run.smoothed.within_3sigma is not None
    outcome = _mems_outcome(s, run)
    doc = _mems_document(s, run, outcome)
    figures = _mems_figures(run, s, outcome.in_outage)
    write_section_files(out_dir, "ins", figures, doc)
    summary.append(_mems_summary_row(s, outcome))
    section = Section(
        title="INS/GNSS: MEMS drive, static alignment, GNSS outage",
        checks=_mems_checks(s, run, outcome),
        caveats=_gyro_caveats(outcome.bias_doc["gyro_bias_rad_s"]),
        paragraphs=_mems_paragraphs(s, run, outcome),
        tables=_mems_tables(s, run, outcome),
        figures=figures,
    )
    return section, doc
