"""Demo section: INS/GNSS on the NaveGo synthetic set against its peers' figures.

An independent project's data (``../shared/data/navego-synthetic``, when present):
the filter and the smoother with turn-on biases known (NaveGo's convention) and
estimated from zero, with position and with position and velocity updates, compared
with the truth and with the RMS figures the set's README quotes for two peer filters.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from kinsync.demo.ins import Summary, Vector3, _series, _triple
from kinsync.errors import InputError
from kinsync.ins.compare import Comparison, compare_to_truth
from kinsync.ins.config import InsConfig
from kinsync.ins.filter import run_ins
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState
from kinsync.io.atomic import atomic_write_bytes, atomic_write_text
from kinsync.io.gnss_csv import read_gnss_csv
from kinsync.io.imu_csv import read_imu_csv
from kinsync.io.nav_csv import read_truth_csv
from kinsync.report.html import Figure, Section, Table
from kinsync.report.ins_figures import ErrorSeries, error_envelope_figure
from kinsync.sim.drive import initial_state
from kinsync.trajectory import Trajectory

__all__ = [
    "NAVEGO_PEERS",
    "NAVEGO_VARIANTS",
    "find_navego_folder",
    "navego_section",
]

NAVEGO_RELATIVE = Path("..") / "shared" / "data" / "navego-synthetic"


NAVEGO_RESIDUAL_SIGMA_FACTOR = 10.0
"""NaveGo convention: σ of the residual turn-on bias = 10 x the bias instability."""


NAVEGO_PEERS: dict[str, tuple[Vector3, Vector3]] = {
    "position": ((1.2, 1.2, 1.5), (0.07, 0.08, 0.58)),
    "position + velocity": ((0.32, 0.42, 0.56), (0.03, 0.04, 0.29)),
}
"""Peer RMS (position N/E/D in m, roll/pitch/yaw in deg) from the NaveGo set's README:
a C++ 15/21-state filter with position updates, a Python filter with position and
velocity updates; both forward, initial state from the first truth epoch."""


def find_navego_folder() -> Path | None:
    """The NaveGo synthetic set in ``../shared`` beside the working folder or the checkout."""
    candidates = [
        Path.cwd() / NAVEGO_RELATIVE,
        Path(__file__).resolve().parents[3] / NAVEGO_RELATIVE,
    ]
    return next((c for c in candidates if (c / "imu_gnss_spec.json").is_file()), None)


def _navego_config(spec: dict[str, Any], *, known_turn_on: bool) -> InsConfig:
    """The configuration of ``tests/ins/test_navego.py`` from ``imu_gnss_spec.json``."""
    f = NAVEGO_RESIDUAL_SIGMA_FACTOR
    try:
        return InsConfig(
            gyro_arw_rad_s_rthz=spec["arw"][0],
            acc_vrw_m_s2_rthz=spec["vrw"][0],
            gyro_bias_sigma_rad_s=f * spec["gb_dyn"][0] if known_turn_on else spec["gb_sta"][0],
            acc_bias_sigma_m_s2=f * spec["ab_dyn"][0] if known_turn_on else spec["ab_sta"][0],
            gyro_bias_instability_rad_s=spec["gb_dyn"][0],
            acc_bias_instability_m_s2=spec["ab_dyn"][0],
            gyro_bias_corr_time_s=spec["gb_corr"][0],
            acc_bias_corr_time_s=spec["ab_corr"][0],
            gnss_std_pos_ned_m=tuple(spec["gnss"]["stdm"]),
            gnss_std_vel_ned_m_s=tuple(spec["gnss"]["stdv"]),
            antenna_lever_arm_body_m=tuple(spec["gnss"]["larm"]),
            init_std_att_rad=tuple(spec["ini_align_err"]),
        )
    except (KeyError, IndexError, TypeError) as err:
        msg = f"imu_gnss_spec.json: missing or malformed entry {err}; the NaveGo spec is needed"
        raise InputError(msg) from err


def _navego_init(truth: Trajectory, spec: dict[str, Any], *, known_turn_on: bool) -> InitialState:
    init = initial_state(truth, 0)
    if not known_turn_on:
        return init
    gb, ab = spec["gb_sta"], spec["ab_sta"]
    return replace(
        init,
        gyro_bias_rad_s=(float(gb[0]), float(gb[1]), float(gb[2])),
        acc_bias_m_s2=(float(ab[0]), float(ab[1]), float(ab[2])),
    )


NAVEGO_VARIANTS: tuple[tuple[str, bool, bool], ...] = (
    ("known (NaveGo convention)", True, False),
    ("known (NaveGo convention)", True, True),
    ("estimated from zero", False, True),
)
"""(turn-on bias handling, known_turn_on, use_velocity) of the NaveGo runs."""


def _peer_cells(cmp: Comparison, updates: str, smoothed: bool) -> tuple[list[str], bool | None]:
    """Peer figures of a forward run and whether every RMS is at or below them."""
    if smoothed:
        return ["-", "-", "-"], None
    pos, att = NAVEGO_PEERS[updates]
    meets = all(v <= p for v, p in zip(cmp.rms_pos_ned_m, pos, strict=True)) and all(
        v <= p for v, p in zip(cmp.rms_att_deg, att, strict=True)
    )
    return [_triple(pos), _triple(att), "yes" if meets else "no"], meets


@dataclass(frozen=True, eq=False)
class _NavegoData:
    """The NaveGo set as read: spec, IMU, GNSS and truth."""

    folder: Path
    spec: dict[str, Any]
    imu: ImuData
    gnss: GnssData
    truth: Trajectory


def _read_navego(folder: Path) -> _NavegoData:
    """Read the set's spec and its IMU, GNSS and truth files."""
    spec_path = folder / "imu_gnss_spec.json"
    try:
        spec: dict[str, Any] = json.loads(spec_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        msg = f"{spec_path}: cannot read the NaveGo spec ({err})"
        raise InputError(msg) from err
    return _NavegoData(
        folder=folder,
        spec=spec,
        imu=read_imu_csv(folder / "imu.csv"),
        gnss=read_gnss_csv(folder / "gnss.csv"),
        truth=read_truth_csv(folder / "truth.csv"),
    )


def _navego_runs(
    data: _NavegoData,
) -> tuple[list[dict[str, Any]], list[list[str]], list[ErrorSeries]]:
    """Every variant forward and smoothed: documents, table rows and the figure's series."""
    rows: list[list[str]] = []
    runs: list[dict[str, Any]] = []
    series: list[ErrorSeries] = []
    for turn_on, known, use_vel in NAVEGO_VARIANTS:
        updates = "position + velocity" if use_vel else "position"
        result = run_ins(
            data.imu,
            data.gnss,
            _navego_config(data.spec, known_turn_on=known),
            _navego_init(data.truth, data.spec, known_turn_on=known),
            use_velocity=use_vel,
            smooth=True,
        )
        assert result.smoothed is not None
        entry: dict[str, Any] = {"turn_on_biases": turn_on, "updates": updates}
        for sol in (result.forward, result.smoothed):
            cmp = compare_to_truth(sol, data.truth)
            kind = "smoothed" if sol.smoothed else "forward"
            peer, meets = _peer_cells(cmp, updates, sol.smoothed)
            entry[kind] = cmp.as_document()
            if meets is not None:
                entry["meets_peer"] = meets
            rows.append(
                [
                    turn_on,
                    updates,
                    kind,
                    _triple(cmp.rms_pos_ned_m),
                    _triple(cmp.rms_att_deg),
                    *peer,
                ]
            )
            if known and use_vel:
                series.append(
                    _series(f"{kind}, position + velocity", cmp, sol, "pos")  # same epochs
                )
        runs.append(entry)
    return runs, rows, series


def _navego_paragraphs(data: _NavegoData, runs: list[dict[str, Any]]) -> tuple[str, ...]:
    """The section's text: the set and its peers, and the turn-on bias conventions."""
    est = runs[2]
    return (
        (
            f"NaveGo's synthetic drive ({len(data.imu):,} IMU epochs at 200 Hz of an "
            f"ADIS16488-like unit, {len(data.gnss):,} GNSS epochs at 5 Hz with 5/5/10 m and "
            "0.05 m/s noise; an independent project's data, LGPL-3.0), initial state from "
            "the first truth epoch, noise and bias model from its imu_gnss_spec.json. "
            "The peer figures are those quoted in the set's README: a C++ 15/21-state "
            "filter with position updates and a Python filter with position and "
            "velocity updates, both forward."
        ),
        (
            "Turn-on biases: NaveGo's own filter subtracts the generator's turn-on "
            "biases (0.2 deg/s, 16 mg per axis) as known deterministic values, and the "
            "peer figures were obtained that way; kinsync does the same by giving them "
            "as the initial bias estimates and estimating the residual with sigma = "
            f"{NAVEGO_RESIDUAL_SIGMA_FACTOR:g} x the bias instability. Estimated from "
            "zero instead (sigma = the turn-on biases), the position figures still hold "
            f"(forward RMS {_triple(est['forward']['rms_pos_ned_m'])} m), but before the "
            "first turn (55 s of straight driving) roll and pitch cannot be told from "
            "the horizontal accelerometer biases nor yaw from the vertical gyro bias, "
            "so the forward attitude RMS "
            f"({_triple(est['forward']['rms_att_deg'])} deg) carries that transient; the "
            f"smoother brings it to {_triple(est['smoothed']['rms_att_deg'])} deg."
        ),
    )


_NAVEGO_HEADERS = (
    "turn-on biases",
    "GNSS updates",
    "solution",
    "RMS position N/E/D (m)",
    "RMS roll/pitch/yaw (deg)",
    "peer position (m)",
    "peer roll/pitch/yaw (deg)",
    "meets peer",
)


def navego_section(
    folder: Path,
    out_dir: Path,
    summary: Summary,
    progress: Callable[[str], None] | None = None,
) -> tuple[Section, dict[str, Any]]:
    """Run the filter and smoother on the NaveGo set and compare with its peer results.

    Three runs, each forward and smoothed: turn-on biases known (NaveGo's convention:
    ``gb_sta``/``ab_sta`` subtracted as deterministic, the residual estimated with
    σ = 10 × the instability) with position updates, and with position and velocity
    updates; turn-on biases estimated from zero (σ = ``gb_sta``, ``ab_sta``) with
    position and velocity updates. Writes ``navego.json`` and ``navego_1.png``.

    Parameters
    ----------
    folder : Path
        The NaveGo folder (``imu.csv``, ``gnss.csv``, ``truth.csv``,
        ``imu_gnss_spec.json``), e.g. from `find_navego_folder`.
    out_dir : Path
        Report folder (exists).
    summary : list of (str, str, str)
        Receives the (capability, scenario, result) row.
    progress : callable, optional
        Called with a short label as each stage starts.

    Returns
    -------
    (Section, dict)
        The report section and the document written to ``navego.json``.

    Raises
    ------
    InputError
        A file of the set is missing or malformed.
    """
    if progress:
        progress("INS/GNSS: NaveGo synthetic set")
    data = _read_navego(Path(folder))
    runs, rows, series = _navego_runs(data)
    doc: dict[str, Any] = {
        "folder": str(data.folder),
        "n_imu": len(data.imu),
        "n_gnss": len(data.gnss),
        "peers": {k: {"rms_pos_ned_m": p, "rms_att_deg": a} for k, (p, a) in NAVEGO_PEERS.items()},
        "residual_sigma_factor": NAVEGO_RESIDUAL_SIGMA_FACTOR,
        "runs": runs,
    }
    atomic_write_text(out_dir / "navego.json", json.dumps(doc, indent=2) + "\n")
    png = error_envelope_figure(
        series, ("North", "East", "Down"), "m", "NaveGo set: position error, turn-on biases known"
    )
    atomic_write_bytes(out_dir / "navego_1.png", png)
    pv = runs[1]["forward"]
    duration_s = data.imu.t_s[-1] - data.imu.t_s[0]
    summary.append(
        (
            "INS/GNSS, external data",
            f"NaveGo synthetic set, {duration_s:.0f} s, turn-on biases known",
            (
                f"forward pos+vel RMS {_triple(pv['rms_pos_ned_m'])} m (peer 0.32/0.42/0.56), "
                f"roll/pitch/yaw {_triple(pv['rms_att_deg'])} deg (peer 0.03/0.04/0.29)"
            ),
        )
    )
    section = Section(
        title="INS/GNSS on the NaveGo synthetic set (external check)",
        paragraphs=_navego_paragraphs(data, runs),
        tables=(
            Table(
                caption="RMS errors against truth.csv over the whole run, and the peers' "
                "forward figures",
                headers=_NAVEGO_HEADERS,
                rows=rows,
            ),
        ),
        figures=(
            Figure(
                caption="NaveGo set, turn-on biases known, position and velocity updates: "
                "position error with ±3σ, forward (left) and smoothed (right)",
                png=png,
            ),
        ),
    )
    return section, doc
