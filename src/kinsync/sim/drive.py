"""Drive simulator: a whole survey drive with its truth, IMU, GNSS and files.

`simulate_drive` makes a route (`kinsync.sim._route`), samples its truth
(`kinsync.sim.drive_truth`), simulates the IMU (`kinsync.sim.imu`) and the GNSS
receiver (`kinsync.sim.gnss`) with the errors a `DriveSimConfig` asks for;
`write_drive_simulation` writes ``imu.csv``, ``gnss.csv``, ``truth.csv``,
``truth.json`` (set-up, seed, injected errors) and ``ins.toml`` (a matching filter
configuration), the files a real drive gives.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.ins.config import InsConfig
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState
from kinsync.io.atomic import atomic_write_text
from kinsync.io.gnss_csv import write_gnss_csv
from kinsync.io.imu_csv import write_imu_csv
from kinsync.io.ins_config import write_ins_config
from kinsync.io.nav_csv import write_truth_csv
from kinsync.sim._common import Vector3, _non_negative, _vector3
from kinsync.sim._route import (
    KinematicState,
    Route,
    RouteKinematics,
    Segment,
    Stop,
    Straight,
    Turn,
    VehicleMotion,
    figure_eight_route,
    oval_route,
    survey_lines_route,
    turn_chord_m,
)
from kinsync.sim.drive_truth import DriveTrajectory, simulate_truth
from kinsync.sim.folder import simulation_folder
from kinsync.sim.gnss import _outages, simulate_gnss
from kinsync.sim.imu import ImuErrorModel, ImuErrorTruth, simulate_imu
from kinsync.trajectory import Trajectory

__all__ = [
    "DRIVE_FILES",
    "IMU_KINDS",
    "ROUTE_KINDS",
    "DriveSimConfig",
    "DriveSimulation",
    "KinematicState",
    "Route",
    "RouteKinematics",
    "Segment",
    "Stop",
    "Straight",
    "Turn",
    "VehicleMotion",
    "figure_eight_route",
    "initial_state",
    "oval_route",
    "simulate_drive",
    "survey_lines_route",
    "turn_chord_m",
    "write_drive_simulation",
]


# ---------------------------------------------------------------------- complete drive
RouteKind = Literal["oval", "loop", "lines"]
ImuKind = Literal["navigation", "mems"]
ROUTE_KINDS: tuple[RouteKind, ...] = ("oval", "loop", "lines")
"""Route names of `DriveSimConfig.route`: oval, figure-eight loop, survey lines."""
IMU_KINDS: tuple[ImuKind, ...] = ("navigation", "mems")
"""IMU presets of `DriveSimConfig.imu`."""


def _kind_route(kind: RouteKind, speed: float, static_s: float, laps: int) -> Route:
    if kind == "oval":
        return oval_route(speed_m_s=speed, laps=laps, static_s=static_s)
    if kind == "loop":
        return figure_eight_route(speed_m_s=speed, laps=laps, static_s=static_s)
    return survey_lines_route(speed_m_s=speed, n_lines=laps, static_s=static_s)


@dataclass(frozen=True)
class DriveSimConfig:
    """Set-up of a simulated drive (defaults: one oval lap at 2 m/s, RLG IMU, RTK 5 Hz).

    Attributes
    ----------
    route : {"oval", "loop", "lines"}
        `oval_route`, `figure_eight_route` or `survey_lines_route` (their defaults).
    speed_m_s : float
        Cruise speed (m/s).
    laps : int or None
        Laps (oval, loop) or lines (lines); default: enough to fill ``duration_s``,
        else 1 lap / 2 loops / 4 lines.
    duration_s : float or None
        Record length (s); default the route's. The route is cut (or extended at
        standstill) to this length.
    static_s : float
        Standstill at the start (s), for static levelling.
    imu : {"navigation", "mems"}
        `ImuErrorModel.navigation_grade` or `ImuErrorModel.mems`.
    imu_rate_hz : float or None
        IMU rate (Hz); default the preset's (50 or 200 Hz). The truth has the same rate.
    gnss_rate_hz : float
        GNSS epoch rate (Hz).
    gnss_std_pos_ned_m, gnss_std_vel_ned_m_s : (float, float, float)
        GNSS noise sigma N, E, D (m, m/s).
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> antenna, body FRD (m).
    gnss_outages : tuple of (start_s, end_s)
        GNSS outages (s, on the output time scale).
    origin_lat_lon_h : (float, float, float)
        Start position (deg, deg, m).
    initial_yaw_deg : float
        Start heading (deg).
    roll_amplitude_deg, roll_period_s, pitch_amplitude_deg, pitch_period_s : float
        Vessel roll/pitch oscillations (deg, s).
    undulation_amplitude_m, undulation_wavelength_m : float
        Height undulation along the path (m).
    t_start_s : float
        Time of the first record (s).
    seed : int
        Seed (same seed, same data).
    """

    route: RouteKind = "oval"
    speed_m_s: float = 2.0
    laps: int | None = None
    duration_s: float | None = None
    static_s: float = 60.0
    imu: ImuKind = "navigation"
    imu_rate_hz: float | None = None
    gnss_rate_hz: float = 5.0
    gnss_std_pos_ned_m: Vector3 = (0.02, 0.02, 0.04)
    gnss_std_vel_ned_m_s: Vector3 = (0.01, 0.01, 0.02)
    antenna_lever_arm_body_m: Vector3 = (0.3, -0.2, -1.5)
    gnss_outages: tuple[tuple[float, float], ...] = ()
    origin_lat_lon_h: Vector3 = (46.8, -71.2, 10.0)
    initial_yaw_deg: float = 35.0
    roll_amplitude_deg: float = 0.0
    roll_period_s: float = 6.0
    pitch_amplitude_deg: float = 0.0
    pitch_period_s: float = 8.0
    undulation_amplitude_m: float = 0.0
    undulation_wavelength_m: float = 50.0
    t_start_s: float = 0.0
    seed: int = 1

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if self.route not in ROUTE_KINDS:
            msg = f"drive simulation: route must be oval, loop or lines, got {self.route!r}"
            raise InputError(msg)
        if self.imu not in IMU_KINDS:
            msg = f"drive simulation: imu must be navigation or mems, got {self.imu!r}"
            raise InputError(msg)
        set_(self, "speed_m_s", positive_number(self.speed_m_s, "speed_m_s"))
        set_(self, "static_s", _non_negative(self.static_s, "static_s"))
        set_(self, "gnss_rate_hz", positive_number(self.gnss_rate_hz, "gnss_rate_hz"))
        set_(self, "t_start_s", finite_number(self.t_start_s, "t_start_s"))
        for name in ("duration_s", "imu_rate_hz"):
            value = getattr(self, name)
            if value is not None:
                set_(self, name, positive_number(value, name))
        if self.laps is not None:
            set_(self, "laps", _count(self.laps, "laps"))
        if self.duration_s is not None and self.duration_s <= self.static_s:
            msg = (
                f"drive simulation: duration_s {self.duration_s:g} s ends within the "
                f"standstill (static_s {self.static_s:g} s): nothing would be driven; give a "
                "longer duration or a shorter standstill"
            )
            raise InputError(msg)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            msg = f"drive simulation: seed must be a whole number, got {self.seed!r}"
            raise InputError(msg)
        if self.seed < 0:
            msg = f"drive simulation: seed must be >= 0, got {self.seed}"
            raise InputError(msg)
        set_(self, "seed", int(self.seed))
        for name in (
            "gnss_std_pos_ned_m",
            "gnss_std_vel_ned_m_s",
            "antenna_lever_arm_body_m",
            "origin_lat_lon_h",
        ):
            set_(self, name, _vector3(getattr(self, name), name))
        set_(self, "gnss_outages", _outages(self.gnss_outages))

    def imu_model(self) -> ImuErrorModel:
        """The IMU preset at the configured rate."""
        if self.imu == "navigation":
            model = ImuErrorModel.navigation_grade()
        else:
            model = ImuErrorModel.mems()
        return model if self.imu_rate_hz is None else replace(model, rate_hz=self.imu_rate_hz)

    def build_route(self) -> Route:
        """The route, with laps enough for ``duration_s`` unless ``laps`` is given."""
        default = {"oval": 1, "loop": 2, "lines": 4}[self.route]
        laps = self.laps
        if laps is None and self.duration_s is not None:
            one = _kind_route(self.route, self.speed_m_s, self.static_s, 1)
            two = _kind_route(self.route, self.speed_m_s, self.static_s, 2)
            per_lap = two.duration_s - one.duration_s
            laps = max(1, math.ceil((self.duration_s - one.duration_s) / per_lap) + 1)
        return _kind_route(self.route, self.speed_m_s, self.static_s, laps or default)


def _count(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        msg = f"drive simulation: {name} must be a whole number >= 1, got {value!r}"
        raise InputError(msg)
    return int(value)


@dataclass(frozen=True, eq=False)
class DriveSimulation:
    """A simulated drive with its ground truth.

    Attributes
    ----------
    config : DriveSimConfig
    route : Route
    truth : DriveTrajectory
        True IMU trajectory at the IMU rate (``truth.csv``).
    imu : ImuData
        IMU samples with errors (``imu.csv``).
    imu_errors : ImuErrorTruth
        Injected sensor errors.
    gnss : GnssData
        Antenna fixes (``gnss.csv``).
    ins_config : InsConfig
        Filter configuration matching the IMU and GNSS models (``ins.toml``).
    truth_doc : dict
        Set-up, seed and injected errors (``truth.json``).
    """

    config: DriveSimConfig
    route: Route
    truth: DriveTrajectory
    imu: ImuData
    imu_errors: ImuErrorTruth
    gnss: GnssData
    ins_config: InsConfig
    truth_doc: dict[str, Any]

    def initial_state(self) -> InitialState:
        """The true state at the first record (to start a mechanisation or filter)."""
        return initial_state(self.truth)


def initial_state(truth: Trajectory, index: int = 0) -> InitialState:
    """The true navigation state of a geodetic trajectory at record ``index``."""
    if truth.lat_lon_h is None or truth.vel_ned_m_s is None:
        msg = "initial_state: the trajectory must be geodetic with velocities"
        raise InputError(msg)
    rpy = truth.euler_rpy_rad()[index]
    lat, lon, h = truth.lat_lon_h[index]
    v = truth.vel_ned_m_s[index]
    return InitialState(
        t_s=float(truth.t_s[index]),
        lat_deg=float(lat),
        lon_deg=float(lon),
        h_m=float(h),
        vel_ned_m_s=(float(v[0]), float(v[1]), float(v[2])),
        rpy_rad=(float(rpy[0]), float(rpy[1]), float(rpy[2])),
    )


def simulate_drive(config: DriveSimConfig | None = None) -> DriveSimulation:
    """Simulate a drive: truth, IMU with errors, GNSS (module docstring).

    Parameters
    ----------
    config : DriveSimConfig, optional
        Set-up; the defaults otherwise.

    Returns
    -------
    DriveSimulation

    Raises
    ------
    InputError
        An invalid set-up.
    """
    c = config or DriveSimConfig()
    route = c.build_route()
    model = c.imu_model()
    truth = simulate_truth(
        route,
        rate_hz=model.rate_hz,
        origin_lat_lon_h=c.origin_lat_lon_h,
        initial_yaw_deg=c.initial_yaw_deg,
        roll_amplitude_deg=c.roll_amplitude_deg,
        roll_period_s=c.roll_period_s,
        pitch_amplitude_deg=c.pitch_amplitude_deg,
        pitch_period_s=c.pitch_period_s,
        undulation_amplitude_m=c.undulation_amplitude_m,
        undulation_wavelength_m=c.undulation_wavelength_m,
        t_start_s=c.t_start_s,
        duration_s=c.duration_s,
    )
    imu, errors = simulate_imu(truth, model, seed=c.seed)
    gnss = simulate_gnss(
        truth,
        rate_hz=c.gnss_rate_hz,
        std_pos_ned_m=c.gnss_std_pos_ned_m,
        std_vel_ned_m_s=c.gnss_std_vel_ned_m_s,
        antenna_lever_arm_body_m=c.antenna_lever_arm_body_m,
        outages=c.gnss_outages,
        seed=c.seed,
    )
    ins_config = model.to_ins_config(
        gnss_std_pos_ned_m=c.gnss_std_pos_ned_m,
        gnss_std_vel_ned_m_s=c.gnss_std_vel_ned_m_s,
        antenna_lever_arm_body_m=c.antenna_lever_arm_body_m,
    )
    doc: dict[str, Any] = {
        "config": asdict(c),
        "seed": c.seed,
        "route": {
            "length_m": route.length_m,
            "duration_s": route.duration_s,
            "segments": [{"type": type(s).__name__, **asdict(s)} for s in route.segments],
            "speed_m_s": route.speed_m_s,
            "max_acc_m_s2": route.max_acc_m_s2,
            "static_s": route.static_s,
            "transition_fraction": route.transition_fraction,
        },
        "t_start_s": truth.t_start_s,
        "t_end_s": truth.t_end_s,
        "n_imu": len(imu),
        "n_gnss": len(gnss),
        "imu_rate_hz": model.rate_hz,
        "imu_errors": errors.to_dict(),
        "antenna_lever_arm_body_m": list(c.antenna_lever_arm_body_m),
        "gnss_outages": [list(o) for o in c.gnss_outages],
        "initial_state": asdict(initial_state(truth)),
        "conventions": (
            "body X forward, Y right, Z down; NED; DIN 9300 roll/pitch/yaw; IMU sample k "
            "= mean rate / specific force over (t[k-1], t[k]]"
        ),
    }
    return DriveSimulation(
        config=c,
        route=route,
        truth=truth,
        imu=imu,
        imu_errors=errors,
        gnss=gnss,
        ins_config=ins_config,
        truth_doc=doc,
    )


DRIVE_FILES = ("imu.csv", "gnss.csv", "truth.csv", "truth.json", "ins.toml")
"""Files `write_drive_simulation` writes."""


def write_drive_simulation(sim: DriveSimulation, out_dir: Path) -> None:
    """Write ``imu.csv``, ``gnss.csv``, ``truth.csv``, ``truth.json``, ``ins.toml``.

    ``imu.csv``: ``t_s,gyro_x_rad_s,gyro_y_rad_s,gyro_z_rad_s,acc_x_m_s2,acc_y_m_s2,
    acc_z_m_s2``. ``gnss.csv``: ``t_s,lat_deg,lon_deg,h_m,std_n_m,std_e_m,std_d_m,
    vn_m_s,ve_m_s,vd_m_s,std_vn_m_s,std_ve_m_s,std_vd_m_s``. ``truth.csv``:
    ``t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg`` (as the
    NaveGo reference set). Floats with ``repr`` precision (exact round trip); each file
    appears only when complete. ``ins.toml``: `kinsync.io.ins_config` format.

    Raises
    ------
    InputError
        ``out_dir`` is an existing file.
    """
    with simulation_folder(out_dir, "drive") as folder:
        write_imu_csv(sim.imu, folder / "imu.csv")
        write_gnss_csv(sim.gnss, folder / "gnss.csv")
        write_truth_csv(sim.truth, folder / "truth.csv")
        atomic_write_text(folder / "truth.json", json.dumps(sim.truth_doc, indent=2) + "\n")
        write_ins_config(sim.ins_config, folder / "ins.toml")
