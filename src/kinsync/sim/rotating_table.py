"""Rotating-table latency test simulator (Method A, SPEC section 2).

A profile scanner and an IMU sit on one bracket on a rotating table and scan a
precision sphere on a stand above a floor. The simulator follows the physics and the
acquisition chain, so the latency enters the data the way it does on a real table:

1. **Table.** Table-centred NED frame: origin on the table axis at the height of the
   scanner's optical centre. The true axis is +Down tilted by a levelling error
   (random magnitude up to ``levelling_error_arcsec_max``, random direction). The
   table angle is ``psi(t) = psi0 + omega t + regulation noise`` (three random
   sinusoids of relative rate noise ``rate_regulation_noise_rel``, RMS). The IMU sits
   flat on the table, so ``R_body_to_ned(t) = Rot(axis_true, psi(t)) @ R_tilt``
   (``R_tilt`` takes +Down onto the true axis). The scanner frame is the body frame
   up to a boresight (``boresight_rpy_deg``, default zero), and the scanner's optical
   centre sits a random distance up to ``optical_centre_offset_max_m`` off the axis,
   turning with the table.
2. **Scanner.** The mirror turns about the scanner Y axis: beam
   ``d_s(phi) = (cos phi, 0, -sin phi)`` in the scanner X-Z plane, ``angular_step_deg``
   apart, ``profile_rate_hz`` profiles per second on a free-running clock; a point at
   mirror angle ``phi`` of the profile starting at ``t_p`` is measured at
   ``t = t_p + (phi / 2 pi) T``. Ranges carry Gaussian noise along the beam.
3. **Scene.** Sphere (radius ``sphere_radius_m``) whose centre is ``sphere_range_m``
   from the axis horizontally, at a random azimuth, ``sphere_elevation_m`` above the
   optical centre; a vertical stand (cylinder, ``stand_radius_m``) from the floor up
   to the sphere; a horizontal floor ``floor_below_sphere_m`` below the sphere centre.
   Every beam is cast against the three and keeps the nearest hit.
4. **Attitude stream.** The IMU records at ``imu_rate_hz``; the record tagged ``t_k``
   holds the true attitude at ``t_k - tau`` with ``tau = latency_s + FIFO delay``
   (``fifo_bytes`` at ``baud``, 8N1), plus white attitude noise
   (``imu_attitude_noise_deg`` per axis) and, optionally, an error constant over each
   pass (``pass_attitude_error_deg`` per NED axis, drawn anew per pass, in the truth as
   ``attitude_error_ned_deg``): the navigation record lags the scanner (SPEC section 1).
5. **Acquisition software.** Each point measured at ``t`` is georeferenced with the
   attitude slerp-interpolated from the records *at their tags* at ``t``, assuming the
   optical centre on the axis: ``x_ned = R_used(t) @ R_scanner_to_body @ x_scanner``.
   The export keeps the returns in a box of ``+-roi_half_width_m`` around the sphere
   centre (the user's crop) and adds stray points (``stray_fraction`` of the kept
   points, uniform in the box).
6. **Passes.** For each rate magnitude and each sign, ``passes`` passes, alternating
   the direction (+, -, +, ...). A pass is the stretch of time during which the box
   around the sphere lies within ``pass_margin_deg`` of the scan plane.

The settings are a `kinsync.sim.table_config.RotatingTableConfig`; the scene and the
scanning of one pass are in `kinsync.sim.table_scan`.

Without noise, with a constant rate, the centre of a + pass is the true centre turned
by ``-omega tau`` about the axis and that of a - pass by ``+omega tau``.

References
----------
Seube, N., Picard, A., Rondeau, M., "A simple method to recover the latency time of
tactical grade IMU systems", ISPRS J. Photogramm. Remote Sens. 74, 2012, 85-89.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync.errors import InputError
from kinsync.frames import quaternion_to_euler_rpy
from kinsync.io.atomic import atomic_write_text
from kinsync.io.mount_file import write_mount
from kinsync.io.passes import PassFileFormat, pass_file_name, write_passes
from kinsync.io.tables import write_numeric_csv
from kinsync.latency.passes import SpherePass
from kinsync.mount import Mount
from kinsync.progress import Progress, report
from kinsync.sim.folder import simulation_folder
from kinsync.sim.table_config import LABEL_NAMES, RotatingTableConfig
from kinsync.sim.table_scan import _Simulator
from kinsync.trajectory import Trajectory

__all__ = [
    "MAX_TABLE_PROFILES",
    "RotatingTableSimulation",
    "simulate_rotating_table",
    "size_problem",
    "write_simulation",
]


@dataclass(frozen=True, eq=False)
class RotatingTableSimulation:
    """Result of `simulate_rotating_table`.

    Attributes
    ----------
    config : RotatingTableConfig
        The set-up simulated.
    passes : tuple of SpherePass
        Exported passes: georeferenced points (table-centred NED, m) and times,
        sphere and clutter, with the signed controller rate and the nominal axis +Down.
    point_labels : tuple of ndarray, shape (N_i,)
        Per pass, the label of each point (`LABEL_SPHERE`, `LABEL_STAND`,
        `LABEL_FLOOR`, `LABEL_STRAY`).
    points_scanner_m : tuple of ndarray, shape (N_i, 3)
        Per pass, the same points in the scanner frame as the scanner measured them (m).
    attitude : Trajectory
        IMU attitude records at their tags (the stream the acquisition software used).
    truth : dict
        JSON-ready ground truth (latency, sphere centre, axis, levelling error,
        optical-centre offset, points per pass, config, seed).
    """

    config: RotatingTableConfig
    passes: tuple[SpherePass, ...]
    point_labels: tuple[IntArray, ...]
    points_scanner_m: tuple[FloatArray, ...]
    attitude: Trajectory
    truth: dict[str, Any] = field(default_factory=dict)


MAX_TABLE_PROFILES = 500_000
"""Most profiles one simulation scans (all passes): about 22 million points, 2 min.

The default set-up scans about 60,000; ``--passes 100`` at the default rates about
400,000. Slow rates scan for long: a pass at 0.01 deg/s scans for over 3000 s."""


def _n_profiles(cfg: RotatingTableConfig, sim: _Simulator) -> float:
    """Profiles the passes of ``cfg`` scan (each pass turns the table through its span)."""
    seconds = sum(
        2.0 * cfg.passes * 2.0 * sim.half_span_rad / math.radians(rate) for rate in cfg.rates_deg_s
    )
    return seconds * cfg.profile_rate_hz


def size_problem(
    config: RotatingTableConfig,
    *,
    rates_name: str = "rates_deg_s",
    passes_name: str = "passes",
    sim: _Simulator | None = None,
) -> str | None:
    """Why ``config`` is too large to simulate (more than `MAX_TABLE_PROFILES`), or None.

    Parameters
    ----------
    config : RotatingTableConfig
    rates_name, passes_name : str
        How the message names the rates and the passes (the command's options).
    sim : _Simulator, optional
        The simulation's own state (its drawn scene gives the pass span); default one
        drawn from ``config.seed``.

    Returns
    -------
    str or None
        The reason, naming what to change; None when the simulation fits.
    """
    state = _Simulator(config, np.random.default_rng(config.seed)) if sim is None else sim
    n = _n_profiles(config, state)
    if n <= MAX_TABLE_PROFILES:
        return None
    rates = ",".join(f"{r:g}" for r in config.rates_deg_s)
    return (
        f"{rates_name} {rates} with {passes_name} {config.passes}: the passes would scan "
        f"{n:,.0f} profiles (each pass turns the table "
        f"{math.degrees(2.0 * state.half_span_rad):.3g} deg at {config.profile_rate_hz:g} "
        f"profiles/s), more than the {MAX_TABLE_PROFILES:,} kinsync simulates in one run; "
        f"give faster rates ({rates_name}) or fewer passes ({passes_name})"
    )


# ---------------------------------------------------------------------- geometry helpers


# ---------------------------------------------------------------------- one pass


# ---------------------------------------------------------------------- public API
def simulate_rotating_table(
    config: RotatingTableConfig | None = None, *, progress: Progress | None = None
) -> RotatingTableSimulation:
    """Simulate a rotating-table latency test.

    Parameters
    ----------
    config : RotatingTableConfig, optional
        Set-up; the defaults reproduce the published test (0.20 m sphere at 1.5 m,
        rates 2-18 deg/s, 15 passes each way, 4.21 ms IMU latency).
    progress : Progress, optional
        Told the share of the passes simulated (stage "simulating passes") at the
        start and after each pass.

    Returns
    -------
    RotatingTableSimulation
        Passes in simulation order: for each rate, ``passes`` pairs of a + pass then a
        - pass. Deterministic for ``config.seed``.

    Raises
    ------
    InputError
        A configuration in which the scanner never sees the sphere, or one that would
        scan more than `MAX_TABLE_PROFILES` profiles (`size_problem`).
    """
    cfg = RotatingTableConfig() if config is None else config
    rng = np.random.default_rng(cfg.seed)
    sim = _Simulator(cfg, rng)
    problem = size_problem(cfg, sim=sim)
    if problem is not None:
        raise InputError(f"rotating-table config: {problem}")
    site = cfg.site_lat_lon_h
    rates = cfg.signed_rates_deg_s
    passes: list[SpherePass] = []
    labels: list[IntArray] = []
    scanner_points: list[FloatArray] = []
    att_t: list[FloatArray] = []
    att_q: list[FloatArray] = []
    pass_truth: list[dict[str, Any]] = []
    t_begin = cfg.t_start_s
    report(progress, 0.0, "simulating passes")
    for i, rate in enumerate(rates):
        timing = sim.timing(rate, t_begin)
        pass_error = sim.pass_attitude_error_rad()
        tags, q = sim.attitude_records(timing, pass_error)
        attitude = Trajectory(
            t_s=tags, q_body_to_ned=q, pos_ned_m=np.zeros((tags.size, 3)), origin_lat_lon_h=site
        )
        res = sim.scan(timing, attitude)
        passes.append(
            SpherePass(
                source=f"simulated pass {i} ({rate:+g} deg/s)",
                rate_deg_s=rate,
                points_ned_m=res.points_ned_m,
                t_s=res.t_s,
            )
        )
        labels.append(res.labels)
        scanner_points.append(res.points_scanner_m)
        att_t.append(tags)
        att_q.append(q)
        counts = np.bincount(res.labels, minlength=len(LABEL_NAMES))
        pass_truth.append(
            {
                "index": i,
                "rate_deg_s": rate,
                "t_start_s": timing.t_begin_s,
                "t_end_s": timing.t_begin_s + timing.duration_s,
                "n_points": int(res.labels.size),
                "attitude_error_ned_deg": np.degrees(pass_error).tolist(),
                **{f"n_{name}": int(counts[k]) for k, name in enumerate(LABEL_NAMES)},
            }
        )
        t_begin += timing.duration_s + cfg.pass_gap_s
        report(progress, (i + 1) / len(rates), "simulating passes")
    attitude_all = Trajectory(
        t_s=np.concatenate(att_t),
        q_body_to_ned=np.concatenate(att_q),
        pos_ned_m=np.zeros((sum(t.size for t in att_t), 3)),
        origin_lat_lon_h=site,
    )
    truth = _truth(cfg, sim, pass_truth)
    return RotatingTableSimulation(
        config=cfg,
        passes=tuple(passes),
        point_labels=tuple(labels),
        points_scanner_m=tuple(scanner_points),
        attitude=attitude_all,
        truth=truth,
    )


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.floating | np.integer):
        return value.item()
    return value


def _truth(
    cfg: RotatingTableConfig, sim: _Simulator, pass_truth: list[dict[str, Any]]
) -> dict[str, Any]:
    scene = sim.scene
    by_rate: dict[str, list[int]] = {}
    for p in pass_truth:
        by_rate.setdefault(f"{p['rate_deg_s']:+g}", []).append(p["n_sphere"])
    doc: dict[str, Any] = _jsonable(
        {
            "description": "kinsync rotating-table simulation: ground truth (SPEC section 2)",
            "seed": cfg.seed,
            "latency_s": cfg.total_latency_s,
            "imu_latency_s": cfg.latency_s,
            "fifo_delay_s": cfg.fifo_delay_s,
            "latency_sign": "tau > 0: the attitude record tagged t describes the table at t - tau",
            "sphere_center_ned_m": scene.sphere_center_ned_m,
            "sphere_radius_m": cfg.sphere_radius_m,
            "axis_ned_true": scene.axis_ned,
            "axis_ned_nominal": [0.0, 0.0, 1.0],
            "levelling_error_arcsec": math.degrees(scene.levelling_error_rad) * 3600.0,
            "levelling_error_azimuth_deg": math.degrees(scene.levelling_azimuth_rad),
            "optical_centre_offset_m": float(np.linalg.norm(scene.offset_body_m)),
            "optical_centre_offset_body_m": scene.offset_body_m,
            "floor_d_m": scene.floor_d_m,
            "stand_top_d_m": scene.stand_top_d_m,
            "roi_box_ned_m": {"min": scene.box_lo, "max": scene.box_hi},
            "pass_span_deg": math.degrees(2.0 * sim.half_span_rad),
            "labels": list(LABEL_NAMES),
            "n_passes": len(pass_truth),
            "n_points": sum(p["n_points"] for p in pass_truth),
            "sphere_points_per_pass": [p["n_sphere"] for p in pass_truth],
            "mean_sphere_points_per_pass_by_rate": {
                k: float(np.mean(v)) for k, v in by_rate.items()
            },
            "passes": pass_truth,
            "config": asdict(cfg),
        }
    )
    return doc


def write_simulation(
    sim: RotatingTableSimulation,
    folder: Path,
    *,
    file_format: PassFileFormat = "csv",
    raw: bool = False,
) -> None:
    """Write a simulation as a pass folder plus ``truth.json``.

    Layout::

        folder/passes.csv, pass_000.<ext>, ...   (`kinsync.io.passes.write_passes`)
        folder/truth.json                         ground truth, with each pass's file
        folder/raw/pass_000.csv, ...              (raw=True) t_s,x_m,y_m,z_m, scanner frame
        folder/raw/attitude.csv                   (raw=True) t_s,roll_deg,pitch_deg,yaw_deg
        folder/raw/mount.toml                     (raw=True) boresight, zero lever arm and
                                                  latency (what the acquisition assumed)

    ``passes.csv`` is written last, so the folder is complete once it exists.

    Parameters
    ----------
    sim : RotatingTableSimulation
    folder : Path
        Output folder (created if missing).
    file_format : {"csv", "las", "laz"}
        Format of the georeferenced pass files.
    raw : bool
        Also write the scanner-frame points, the attitude log and the mount (the raw
        input of Method A).

    Raises
    ------
    InputError
        ``folder`` is an existing file, or an unknown format.
    """
    if file_format not in ("csv", "las", "laz"):
        msg = f"pass file format must be csv, las or laz, got {file_format!r}"
        raise InputError(msg)
    with simulation_folder(folder, "rotating-table") as out:
        n = len(sim.passes)
        if raw:
            raw_dir = out / "raw"
            raw_dir.mkdir(exist_ok=True)
            for i, (p, xs) in enumerate(zip(sim.passes, sim.points_scanner_m, strict=True)):
                assert p.t_s is not None
                write_numeric_csv(
                    raw_dir / pass_file_name(i, n, "csv"),
                    {"t_s": p.t_s, "x_m": xs[:, 0], "y_m": xs[:, 1], "z_m": xs[:, 2]},
                )
            rpy_deg = np.degrees(quaternion_to_euler_rpy(sim.attitude.q_body_to_ned))
            write_numeric_csv(
                raw_dir / "attitude.csv",
                {
                    "t_s": sim.attitude.t_s,
                    "roll_deg": rpy_deg[:, 0],
                    "pitch_deg": rpy_deg[:, 1],
                    "yaw_deg": rpy_deg[:, 2],
                },
            )
            mount = Mount(boresight_rpy_deg=sim.config.boresight_rpy_deg)
            write_mount(mount, raw_dir / "mount.toml")
        truth = dict(sim.truth)
        truth["file_format"] = file_format
        truth["passes"] = [
            {**p, "file": pass_file_name(i, n, file_format)}
            for i, p in enumerate(sim.truth["passes"])
        ]
        atomic_write_text(out / "truth.json", json.dumps(truth, indent=2) + "\n")
        write_passes(out, sim.passes, file_format=file_format)
