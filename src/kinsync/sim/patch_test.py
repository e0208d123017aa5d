"""Patch-test simulator: survey lines over known planes for mount self-calibration.

A *patch test* is the survey a crew drives to calibrate its scanner mount: the same
features (flat ground, walls, roofs, a quay, a shore, spheres) scanned from lines in
both directions at two speeds. Errors of the mount then show as features that do not
coincide between lines: a lever-arm or boresight error moves each line's points
differently depending on the direction, a latency error in proportion to the speed
(and to the attitude rates). `simulate_patch_test` makes such a survey with a known
mount, `write_patch_test` writes the files a real one gives.

**Scenarios** (settings: `kinsync.sim.patch_config.PatchTestConfig`; the scenes in
numbers: `kinsync.sim.patch_scene`; the drive: `kinsync.sim.patch_route`):

- ``"vehicle"``: a mapping car on a town block — flat ground, six gable-roofed
  buildings set square, oblique and gable-end to a 280 m main street (walls facing six
  azimuths, 20-35 deg roofs), a garden wall; the lines run both ways along the street
  at 5 and 12 m/s (two lines each way per speed by default), joined by roundabout-like
  balloon turns (`kinsync.sim.patch_route`). Small body roll and pitch on the springs.
  The 360 deg profiler sits 2.75 m above the ground at the back of the roof, its head
  turned 30 deg about the vertical from across-track and tilted 30 deg (boresight
  pitch -30: the nadir beam looks back), so that it sees walls of every azimuth, the
  roofs and the ground, each from several directions.
- ``"vessel"``: a survey launch in a harbour channel — a vertical quay wall with its
  deck and a shed turned -25 deg to the quay on one bank, a shore sloping at 15 deg on
  the other, two spheres on posts at the quay edge; lines both ways at 2 and 4 m/s in
  lanes 13 m from the quay and 21 m from the shore; wave roll (4 deg, 7 s), pitch
  (1.5 deg, 5 s) and heave (0.15 m, 6 s). The profiler is on a starboard mast 3.5 m
  above the water, its head rolled so that its nadir beam looks to starboard, its
  plane turned 20 deg from across-track; the water returns nothing.

**What is simulated.** The exact drive (`kinsync.sim.drive_truth.simulate_truth`) at
``nav_rate_hz``, plus the platform's roll/pitch/heave. A 2-D profiler with a mirror
clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (SPEC section 4) turning at
``profile_rate_hz`` over the full circle in ``angular_step_deg`` steps, mounted with
the TRUE mount (nominal + injected boresight, lever-arm errors), scans the scene from
the TRUE trajectory; each beam's nearest hit within ``[min_range_m, max_range_m]``
gives a return with Gaussian range noise along the beam. Only returns measured during
the straight lines are kept (the turnarounds are driven but not kept); ``density``
thins the beams regularly (1: every beam; profile ``n`` keeps every ``1/density``-th
beam from an offset that shifts by the golden ratio from profile to profile, so that
no angle is left out) so that a Monte Carlo run can be small.
The navigation solution is the truth with smooth, time-correlated errors
(`kinsync.sim.nav_noise.noisy_trajectory`: position, level and heading errors
correlated over ``error_corr_time_s``) and carries the true latency: a record tagged
``t`` describes the state at ``t - tau`` (SPEC section 1), i.e. it is the noisy truth
shifted by ``+tau``; the records lie on the regular ``nav_rate_hz`` grid of GPS time.

**What each scenario makes observable** (formal, range noise only, features' shapes
as nuisance parameters). Both: boresight roll, pitch and yaw, lever x and y, and the
latency, which two speeds separate from lever x (one speed: correlation -0.996). The
vehicle drives level lines, so a lever-z error moves every line along the same road
normal and the planes absorb it: lever z shows only through the car's small roll and
pitch (about 1/1000 of the information of the next-weakest parameter), i.e. it is
practically unobservable there. The vessel's wave roll makes lever z observable
(formal sigma under 1 mm) and adds latency information through the attitude rates.

**Cost.** Vehicle defaults: 8 lines, 6.1 million returns in about 4 s (vessel: 1.6
million in about 7 s). ``density=0.002, passes_per_direction=1, nav_rate_hz=50``:
about 6 000 (vessel 1 600) returns in 0.15 (0.25) s, for Monte Carlo runs.

**Time.** Everything is GPS time (continuous seconds since 1980-01-06). Written files:
the SBET holds GPS seconds of week (``read_sbet(path, gps_week=W)`` and
``kinsync georef --gps-week W`` give GPS time back; ``W`` is in ``truth.json``), the
LAS/LAZ files hold adjusted standard GPS time (GPS - 1e9 s, global-encoding bit set).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import laspy
import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.lines import ScanLine
from kinsync.errors import InputError
from kinsync.frames import geodetic_to_ecef, rotation_ned_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.atomic import atomic_write_text, output_folder
from kinsync.io.las import ADJUSTED_GPS_OFFSET_S
from kinsync.io.las_writer import LasChunkWriter
from kinsync.io.mount_file import write_mount
from kinsync.io.sbet import SECONDS_PER_WEEK, write_sbet
from kinsync.mount import Mount
from kinsync.sim.folder import simulation_folder
from kinsync.sim.nav_noise import noisy_trajectory
from kinsync.sim.patch_config import SCENARIOS, PatchTestConfig, Scenario
from kinsync.sim.patch_route import LineWindow, drive_patch_test
from kinsync.sim.patch_scene import PatchTestScene, vehicle_scene, vessel_scene
from kinsync.sim.scene import NO_HIT
from kinsync.trajectory import Trajectory

__all__ = [
    "PATCH_TEST_SIMULATION",
    "SCENARIOS",
    "PatchTestConfig",
    "PatchTestSimulation",
    "Scenario",
    "check_patch_test_folder",
    "patch_test_files",
    "simulate_patch_test",
    "write_patch_test",
]

PATCH_TEST_SIMULATION = "patch-test"
"""``truth.json`` ``"simulation"`` of a patch-test folder."""

PointFileFormat = Literal["laz", "las"]

_RANGE_STREAM = 11
"""Random stream of the range noise (the trajectory errors use `sim._common`'s)."""
_CHUNK_BEAMS = 60_000
"""Beams cast at once: about a second of scanning, so the scene's culling works."""
_T0_OFFSET_S = 0.4371
"""Profile 0 starts this long after the first trajectory record."""


@dataclass(frozen=True, eq=False)
class PatchTestSimulation:
    """A simulated patch test, in memory.

    Attributes
    ----------
    config : PatchTestConfig
    lines : tuple of ScanLine
        One per line, in driving order: returns in the scanner frame with their GPS
        times, measured along the true trajectory with the true mount, and the
        NAVIGATION trajectory over the line (noisy, tagged ``tau`` late).
    line_windows : tuple of LineWindow
        When each line was driven, its speed, heading and direction.
    line_hit_ids : tuple of ndarray of int64
        Per line, shape (N_i,): the scene feature each return hit (`PatchTestScene`
        ``hit_id`` of a plane or a sphere).
    mount_nominal : Mount
        What the user knows (latency included).
    mount_true : Mount
        What the scanner really is (nominal + errors).
    scene : PatchTestScene
        Planes and spheres in the local NED frame at ``scene.origin_lat_lon_h``.
    truth_trajectory : Trajectory
        Exact motion of the body, GPS time (no latency).
    navigation : Trajectory
        The whole navigation solution (what ``trajectory.out`` holds).
    gps_week : int
        GPS week of ``start_gps_s``: pass it to ``read_sbet`` / ``--gps-week``.
    truth : dict
        ``truth.json`` without the file names (`write_patch_test` adds them).
    """

    config: PatchTestConfig
    lines: tuple[ScanLine, ...]
    line_windows: tuple[LineWindow, ...]
    line_hit_ids: tuple[IntArray, ...]
    mount_nominal: Mount
    mount_true: Mount
    scene: PatchTestScene
    truth_trajectory: Trajectory
    navigation: Trajectory
    gps_week: int
    truth: dict[str, Any] = field(repr=False)

    @property
    def n_points(self) -> int:
        """Returns over all lines."""
        return sum(len(line) for line in self.lines)


@dataclass(frozen=True, eq=False)
class _Beams:
    """What the casting needs once per simulation."""

    angles_rad: FloatArray
    unit_scanner: FloatArray
    t0_s: float
    period_s: float
    truth: GeorefTrajectory
    mount: Mount
    scene: PatchTestScene
    origin_ecef_m: FloatArray
    R_local_to_ecef: FloatArray


_GOLDEN = 0.6180339887498949
"""Per-profile offset of the thinned beams: ``frac(n * golden)`` (low discrepancy)."""


def _thinned_beams(
    first_profile: int, last_profile: int, n_angles: int, density: float
) -> tuple[IntArray, IntArray]:
    """Profile numbers and beam indices kept by the regular thinning, both shape (B,).

    Profile ``n`` keeps beams ``floor((k + o_n) / density)``, ``k = 0, 1, ...``, with the
    offset ``o_n = frac(n golden)``: about ``n_angles * density`` beams per profile,
    whose angles shift from one profile to the next (no angular aliasing).
    """
    prof = np.arange(first_profile, last_profile + 1, dtype=np.int64)
    if density >= 1.0:
        return np.repeat(prof, n_angles), np.tile(np.arange(n_angles, dtype=np.int64), prof.size)
    offset = np.mod(prof * _GOLDEN, 1.0)
    counts = np.maximum(np.ceil(n_angles * density - offset), 0.0).astype(np.int64)
    total = int(counts.sum())
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    k = np.arange(total, dtype=np.int64) - starts
    beam = np.floor((k + np.repeat(offset, counts)) / density).astype(np.int64)
    return np.repeat(prof, counts), np.minimum(beam, n_angles - 1)


def _scan_line(
    beams: _Beams, cfg: PatchTestConfig, window: LineWindow, index: int
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Returns of one line: GPS times (N,), scanner-frame points (N, 3), hit ids (N,)."""
    n_ang = beams.angles_rad.size
    T = beams.period_s
    first = math.floor((window.t_start_s - beams.t0_s) / T) - 1
    last = math.ceil((window.t_end_s - beams.t0_s) / T) + 1
    per_chunk = max(1, int(_CHUNK_BEAMS / (n_ang * cfg.density)))
    rng = np.random.default_rng([int(cfg.seed), _RANGE_STREAM, index])
    assert cfg.max_range_m is not None
    water = beams.scene.water_hit_id
    out_t: list[FloatArray] = []
    out_xyz: list[FloatArray] = []
    out_hit: list[IntArray] = []
    for p0 in range(first, last + 1, per_chunk):
        prof, a = _thinned_beams(p0, min(p0 + per_chunk - 1, last), n_ang, cfg.density)
        t = beams.t0_s + (prof + beams.angles_rad[a] / (2.0 * math.pi)) * T
        inside = (t >= window.t_start_s) & (t <= window.t_end_s)
        t, a = t[inside], a[inside]
        if t.size == 0:
            continue
        u = beams.unit_scanner[a]
        o_ecef, _ = georeference(t, np.zeros_like(u), beams.truth, beams.mount)
        tip_ecef, _ = georeference(t, u, beams.truth, beams.mount)
        d_loc = (tip_ecef - o_ecef) @ beams.R_local_to_ecef
        d_loc /= np.linalg.norm(d_loc, axis=1, keepdims=True)
        o_loc = (o_ecef - beams.origin_ecef_m) @ beams.R_local_to_ecef
        r, hit = beams.scene.scene.cast(o_loc, d_loc, cfg.max_range_m)
        ok = (hit != NO_HIT) & (r >= cfg.min_range_m)
        if water is not None:
            ok &= hit != water
        r_meas = r[ok] + rng.normal(0.0, cfg.range_noise_m, int(np.count_nonzero(ok)))
        out_t.append(t[ok])
        out_xyz.append(u[ok] * r_meas[:, None])
        out_hit.append(hit[ok])
    if sum(x.size for x in out_t) == 0:
        msg = (
            f"patch test: {window.name} has no return; raise density "
            f"({cfg.density}) or the range limit ({cfg.max_range_m} m)"
        )
        raise InputError(msg)
    return np.concatenate(out_t), np.concatenate(out_xyz), np.concatenate(out_hit)


def _scene(cfg: PatchTestConfig) -> PatchTestScene:
    assert cfg.street_azimuth_deg is not None
    assert cfg.max_range_m is not None
    if cfg.scenario == "vehicle":
        return vehicle_scene(
            cfg.origin_lat_lon_h,
            cfg.street_azimuth_deg,
            spheres=bool(cfg.spheres),
            ground_margin_m=cfg.max_range_m,
        )
    return vessel_scene(cfg.origin_lat_lon_h, cfg.street_azimuth_deg, spheres=bool(cfg.spheres))


def simulate_patch_test(config: PatchTestConfig | None = None) -> PatchTestSimulation:
    """Simulate a patch test: drive, scene, scan, navigation errors, latency, truth.

    Parameters
    ----------
    config : PatchTestConfig, optional
        Default: the vehicle scenario with its defaults.

    Returns
    -------
    PatchTestSimulation

    Raises
    ------
    InputError
        A line without any return (density too low).
    """
    cfg = config or PatchTestConfig()
    scene = _scene(cfg)
    mount_true = cfg.mount_true
    tau = mount_true.latency_s
    assert cfg.speeds_m_s is not None
    assert cfg.motion is not None
    assert cfg.street_azimuth_deg is not None
    # The truth is sampled at start - tau + k / rate, so that the navigation records
    # (the truth tagged tau late) fall on the regular grid start + k / rate.
    drive = drive_patch_test(
        scene.layout,
        cfg.origin_lat_lon_h,
        cfg.street_azimuth_deg,
        cfg.speeds_m_s,
        cfg.passes_per_direction,
        cfg.motion,
        rate_hz=cfg.nav_rate_hz,
        t_start_s=cfg.start_gps_s - tau,
    )
    truth = drive.truth
    navigation = noisy_trajectory(
        truth,
        std_pos_ned_m=cfg.std_pos_ned_m,
        std_att_deg=cfg.std_att_deg,
        corr_time_s=cfg.error_corr_time_s,
        seed=int(cfg.seed),
    ).shifted(tau)
    angles = cfg.angles_rad()
    origin = scene.origin_lat_lon_h
    beams = _Beams(
        angles_rad=angles,
        unit_scanner=mount_true.profile_to_scanner(angle_rad=angles, range_m=np.ones(angles.size)),
        t0_s=truth.t_start_s + _T0_OFFSET_S,
        period_s=cfg.profile_period_s,
        truth=GeorefTrajectory.from_trajectory(truth, 0.0),
        mount=mount_true.with_latency(0.0),
        scene=scene,
        origin_ecef_m=geodetic_to_ecef(*origin),
        R_local_to_ecef=rotation_ned_to_ecef(origin[0], origin[1]),
    )
    lines: list[ScanLine] = []
    hits: list[IntArray] = []
    for i, window in enumerate(drive.lines):
        t, xyz, hit = _scan_line(beams, cfg, window, i)
        hit.setflags(write=False)
        nav = navigation.sliced(
            window.t_start_s + tau - cfg.line_margin_s, window.t_end_s + tau + cfg.line_margin_s
        )
        lines.append(ScanLine(window.name, t, xyz, nav))
        hits.append(hit)
    gps_week = math.floor(navigation.t_start_s / SECONDS_PER_WEEK)
    sim_truth = _truth_document(cfg, scene, drive.lines, lines, hits, navigation, gps_week)
    sim_truth["drive"] = {
        "length_m": drive.length_m,
        "t_start_gps_s": navigation.t_start_s,
        "t_end_gps_s": navigation.t_end_s,
        "n_records": len(navigation),
    }
    sim_truth["scanner"]["t0_gps_s"] = beams.t0_s
    return PatchTestSimulation(
        config=cfg,
        lines=tuple(lines),
        line_windows=drive.lines,
        line_hit_ids=tuple(hits),
        mount_nominal=cfg.mount_nominal,
        mount_true=mount_true,
        scene=scene,
        truth_trajectory=truth,
        navigation=navigation,
        gps_week=gps_week,
        truth=sim_truth,
    )


def _mount_document(m: Mount) -> dict[str, Any]:
    return {
        "lever_arm_body_m": list(m.lever_arm_body_m),
        "boresight_rpy_deg": list(m.boresight_rpy_deg),
        "antenna_lever_arm_body_m": list(m.antenna_lever_arm_body_m),
        "latency_s": m.latency_s,
        "profiler_azimuth_deg": m.profiler_azimuth_deg,
    }


def _truth_document(
    cfg: PatchTestConfig,
    scene: PatchTestScene,
    windows: tuple[LineWindow, ...],
    lines: list[ScanLine],
    hits: list[IntArray],
    navigation: Trajectory,
    gps_week: int,
) -> dict[str, Any]:
    config = asdict(cfg)
    config["nominal_mount"] = _mount_document(cfg.mount_nominal)
    line_docs = []
    for w, line, hit in zip(windows, lines, hits, strict=True):
        ids, counts = np.unique(hit, return_counts=True)
        line_docs.append(
            {
                "name": w.name,
                "direction": w.direction,
                "speed_m_s": w.speed_m_s,
                "heading_deg": w.heading_deg,
                "t_start_gps_s": w.t_start_s,
                "t_end_gps_s": w.t_end_s,
                "n_points": len(line),
                "points_by_feature": {
                    scene.feature_name(int(k)): int(c) for k, c in zip(ids, counts, strict=True)
                },
            }
        )
    doc = {
        "simulation": PATCH_TEST_SIMULATION,
        "scenario": cfg.scenario,
        "seed": int(cfg.seed),
        "gps_week": gps_week,
        "time": {
            "scale": "GPS time (s since 1980-01-06); records of trajectory.out are GPS "
            "seconds of week: read_sbet(path, gps_week=gps_week) or --gps-week",
            "las_gps_time": "adjusted standard GPS time (GPS time - 1e9 s)",
            "latency": "a navigation record tagged t describes the state at t - latency_s",
        },
        "mount_true": _mount_document(cfg.mount_true),
        "mount_nominal": _mount_document(cfg.mount_nominal),
        "errors": {
            "boresight_rpy_deg": list(cfg.boresight_error_rpy_deg),
            "lever_arm_body_m": list(cfg.lever_arm_error_body_m),
            "latency_s": cfg.latency_error_s,
            "meaning": "true minus nominal; boresight as DIN 9300 roll, pitch, yaw angles",
        },
        "trajectory_errors": {
            "std_pos_ned_m": list(cfg.std_pos_ned_m),
            "std_att_deg_about_ned": list(cfg.std_att_deg),
            "corr_time_s": cfg.error_corr_time_s,
            "rate_hz": cfg.nav_rate_hz,
            "n_records": len(navigation),
        },
        "scanner": {
            "profile_rate_hz": cfg.profile_rate_hz,
            "period_s": cfg.profile_period_s,
            "angular_step_deg": cfg.angular_step_deg,
            "field_of_view_deg": [-180.0, 180.0],
            "range_noise_m": cfg.range_noise_m,
            "min_range_m": cfg.min_range_m,
            "max_range_m": cfg.max_range_m,
            "density": cfg.density,
            "clock": "t(n, phi) = t0 + (n + phi / 2 pi) T, phi from nadir",
        },
        "config": config,
        "n_points": sum(len(line) for line in lines),
        "lines": line_docs,
        "scene": scene.as_document(),
    }
    plain: dict[str, Any] = json.loads(json.dumps(doc))  # plain JSON types: lists, not tuples
    return plain


# ---------------------------------------------------------------------------- files
def patch_test_files(n_lines: int, file_format: PointFileFormat = "laz") -> tuple[str, ...]:
    """Files `write_patch_test` writes, ``truth.json`` last."""
    lines = tuple(f"line_{i + 1:02d}.{file_format}" for i in range(n_lines))
    return ("trajectory.out", "mount.toml", *lines, "truth.json")


def _previous_files(folder: Path, option: str) -> list[Path]:
    """Files of an earlier patch test in ``folder`` (to replace); refuse anything else."""
    prefix = f"{option} " if option else ""
    entries = sorted(p.name for p in folder.iterdir())
    if not entries:
        return []
    truth_path = folder / "truth.json"
    doc: Any = None
    if truth_path.is_file():
        try:
            doc = json.loads(truth_path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            doc = None
    if not isinstance(doc, dict) or doc.get("simulation") != PATCH_TEST_SIMULATION:
        what = "another simulation" if truth_path.is_file() else f"other files ({entries[0]}, ...)"
        msg = (
            f"{prefix}{folder}: the folder holds {what}; give a new or empty folder "
            "(or one holding an earlier patch-test simulation, which is replaced)"
        )
        raise InputError(msg)
    listed = doc.get("files")
    own = {str(f) for f in listed} if isinstance(listed, list) else set()
    own.add("truth.json")
    foreign = [e for e in entries if e not in own or not (folder / e).is_file()]
    if foreign:
        msg = (
            f"{prefix}{folder}: the folder holds an earlier patch test and other files "
            f"({', '.join(foreign[:3])}); give a new or empty folder"
        )
        raise InputError(msg)
    return [folder / e for e in entries]


def check_patch_test_folder(out_dir: Path, *, option: str = "") -> list[Path]:
    """Check that a patch test can be written to ``out_dir``; create nothing.

    ``out_dir`` must be missing, empty, or hold only an earlier patch-test simulation
    (the files its ``truth.json`` lists), which will be replaced.

    Parameters
    ----------
    out_dir : Path
        Output folder.
    option : str
        Command-line option naming the folder in messages (``"--out"``), if any.

    Returns
    -------
    list of Path
        The earlier simulation's files (empty when there is none).

    Raises
    ------
    InputError
        ``out_dir`` is a file, or holds anything else.
    """
    folder = output_folder(out_dir, "give a folder for the simulation", create=False, option=option)
    if not folder.is_dir():
        return []
    return _previous_files(folder, option)


def _write_line(path: Path, line: ScanLine, number: int) -> None:
    """One line's returns as LAS/LAZ 1.4, point format 6, adjusted standard GPS time."""
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    header.system_identifier = "kinsync patch-test simulator"
    n = len(line)
    chunk = laspy.ScaleAwarePointRecord.zeros(n, header=header)
    chunk["gps_time"] = line.t_s - ADJUSTED_GPS_OFFSET_S
    chunk["point_source_id"] = np.full(n, number, dtype=np.uint16)
    chunk["return_number"] = np.ones(n, dtype=np.uint8)  # single returns: 1 of 1
    chunk["number_of_returns"] = np.ones(n, dtype=np.uint8)
    xyz = line.xyz_scanner_m
    with LasChunkWriter(path, header, None, (0.0, 0.0, 0.0), 1e-4) as writer:
        writer.write(chunk, xyz[:, 0], xyz[:, 1], xyz[:, 2])


def write_patch_test(
    sim: PatchTestSimulation, out_dir: Path, *, file_format: PointFileFormat = "laz"
) -> tuple[Path, ...]:
    """Write the files of a real survey, and the truth.

    Layout::

        out_dir/trajectory.out    navigation solution, SBET (GPS seconds of week)
        out_dir/mount.toml        the NOMINAL mount (what the calibration starts from)
        out_dir/line_01.laz ...   one per line: scanner-frame x, y, z (m, 0.1 mm steps)
                                  and gps_time (adjusted standard GPS time), point
                                  format 6, point_source_id = line number
        out_dir/truth.json        true and nominal mounts, errors, GPS week, config,
                                  scene, lines with their files (written last)

    Parameters
    ----------
    sim : PatchTestSimulation
    out_dir : Path
        Output folder: created if missing; it must be empty or hold an earlier patch
        test, replaced as a whole once the new one is complete (an interrupted run
        leaves the earlier one untouched).
    file_format : {"laz", "las"}
        Point files compressed (LAZ) or not.

    Returns
    -------
    tuple of Path
        The files written, ``truth.json`` last.

    Raises
    ------
    InputError
        A bad format, an output folder that is a file or holds other files.
    """
    if file_format not in ("laz", "las"):
        msg = f"patch test: point file format must be laz or las, got {file_format!r}"
        raise InputError(msg)
    check_patch_test_folder(out_dir)
    names = patch_test_files(len(sim.lines), file_format)
    with simulation_folder(out_dir, "patch-test") as folder:
        write_sbet(sim.navigation, folder / names[0])
        write_mount(sim.mount_nominal, folder / names[1])
        for i, line in enumerate(sim.lines):
            _write_line(folder / names[2 + i], line, i + 1)
        truth = dict(sim.truth)
        truth["file_format"] = file_format
        truth["files"] = list(names)
        truth["lines"] = [{**doc, "file": names[2 + i]} for i, doc in enumerate(sim.truth["lines"])]
        atomic_write_text(folder / "truth.json", json.dumps(truth, indent=2) + "\n")
    return tuple(Path(out_dir) / n for n in names)
