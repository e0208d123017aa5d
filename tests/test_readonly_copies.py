"""Containers' read-only arrays stay read-only in pickled and deep-copied containers.

numpy pickles an array without its flags: a `Trajectory` unpickled (or deep-copied,
or sent to a worker process) held writeable times, which could then be made to go
backwards after ``__post_init__`` had checked them, and every later result was wrong
without an error. `kinsync._arrays.ReadOnlyArrays` restores the flags.
"""

from __future__ import annotations

import copy
import dataclasses
import pickle
from collections.abc import Callable, Iterator
from functools import cache

import numpy as np
import pytest
from tests._dataclasses import dataclasses_with_arrays

from kinsync import Mount, Trajectory
from kinsync._arrays import ReadOnlyArrays
from kinsync.calibration import ScanLine
from kinsync.clock import ClockModel, fit_clock
from kinsync.fit import fit_sphere
from kinsync.frames import geodetic_to_ecef, ned_to_ecef
from kinsync.georef import GeorefTrajectory
from kinsync.ins import GnssData, ImuData
from kinsync.latency import SpherePass, estimate_latency_sphere
from kinsync.messages import NmeaLog
from kinsync.sim.clock import ClockSimConfig, simulate_clock
from kinsync.sim.rotating_table import simulate_rotating_table
from kinsync.sim.table_config import RotatingTableConfig
from kinsync.sync import ProfileScan, SyncPoints
from kinsync.validation import CloudPoints, ControlPoints, fit_wall


def _frozen_dataclasses_with_arrays() -> dict[str, type]:
    """Public frozen dataclasses with an array field, in core, the algorithms and io."""
    return dataclasses_with_arrays(
        skip_prefixes=(
            "kinsync.cli",
            "kinsync.pipelines",
            "kinsync.sim",
            "kinsync.demo",
            "kinsync.report",
        ),
        frozen_only=True,
    )


def test_every_frozen_container_with_arrays_keeps_them_read_only_in_copies() -> None:
    found = _frozen_dataclasses_with_arrays()
    assert "kinsync.trajectory.Trajectory" in found  # the scan sees the containers
    assert "kinsync.latency.sphere.SphereLatencyResult" in found
    assert "kinsync.io.smrmsg.SmrmsgData" in found
    missing = sorted(name for name, cls in found.items() if not issubclass(cls, ReadOnlyArrays))
    assert missing == [], f"derive these from kinsync._arrays.ReadOnlyArrays: {missing}"
    assert issubclass(Mount, ReadOnlyArrays)  # its cached R_scanner_to_body


def _arrays(
    obj: object, path: str = "", seen: set[int] | None = None
) -> Iterator[tuple[str, np.ndarray]]:
    """Every array reachable from ``obj`` through kinsync objects' attributes and tuples."""
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        yield path, obj
    elif isinstance(obj, tuple | list):
        for i, item in enumerate(obj):
            yield from _arrays(item, f"{path}[{i}]", seen)
    elif type(obj).__module__.startswith("kinsync") and hasattr(obj, "__dict__"):
        for name, value in vars(obj).items():
            yield from _arrays(value, f"{path}.{name}", seen)


def _trajectory() -> Trajectory:
    n = 50
    t = 1.4e9 + np.arange(n) * 0.1
    llh = np.column_stack([46.8 + 1e-5 * np.arange(n), np.full(n, -71.2), np.full(n, 10.0)])
    vel = np.column_stack([np.full(n, 11.1), np.zeros(n), np.zeros(n)])
    return Trajectory.from_euler(
        t, np.zeros(n), np.zeros(n), np.linspace(0, 0.9, n), lat_lon_h=llh, vel_ned_m_s=vel
    )


def _mount() -> Mount:
    mount = Mount(boresight_rpy_deg=(0.1, 0.2, 0.3), profiler_azimuth_deg=0.0)
    assert mount.R_scanner_to_body.shape == (3, 3)  # cached on the instance
    return mount


def _clock_fit() -> object:
    sim = simulate_clock(ClockSimConfig(duration_s=20.0, seed=2))
    return fit_clock(sim.pps_t_local_s, sim.zda_t_local_s, sim.zda_gps_s, sim.zda_n_bytes)


def _sphere_points(n: int = 400) -> np.ndarray:
    d: np.ndarray = np.random.default_rng(3).normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.array([1.5, 0.3, -0.2]) + 0.1 * d


@cache
def _sphere_latency() -> object:
    cfg = RotatingTableConfig(latency_s=0.004, rates_deg_s=(18.0,), passes=1, seed=4)
    return estimate_latency_sphere(simulate_rotating_table(cfg).passes, radius_m=0.1)


def _wall() -> object:
    rng = np.random.default_rng(5)
    u, v = rng.uniform(-5, 5, 2000), rng.uniform(0, 3, 2000)
    ned = np.column_stack([u, 10.0 + rng.normal(0, 0.003, 2000), -v])
    return fit_wall(ned_to_ecef(ned, 46.8, -71.2, 10.0))


_ECEF = geodetic_to_ecef(np.full(3, 46.8), np.full(3, -71.2), np.arange(3.0))


def _n(n: int = 10) -> np.ndarray:
    return 1.4e9 + np.arange(n) * 0.1


FACTORIES: dict[str, Callable[[], object]] = {
    "Trajectory": _trajectory,
    "TrajectorySample": lambda: _trajectory().interpolate(_n(3) + 0.05),
    "Mount": _mount,
    "ClockModel": lambda: ClockModel(
        10.0, 1.4e9, 2.0, (10.0, 20.0), np.array([10.0, 20.0]), np.array([1.4e9, 1.4e9 + 10.0])
    ),
    "ClockFit": _clock_fit,
    "GeorefTrajectory": lambda: GeorefTrajectory.from_trajectory(_trajectory(), latency_s=0.003),
    "SpherePass": lambda: SpherePass("p", 6.0, _sphere_points(), t_s=_n(400)),
    "SphereLatencyResult": _sphere_latency,
    "RateLatency": lambda: _sphere_latency().per_rate[0],  # type: ignore[attr-defined]
    "ScanLine": lambda: ScanLine("a", _n(5) + 0.01, np.ones((5, 3)), _trajectory()),
    "ImuData": lambda: ImuData(_n(), np.zeros((10, 3)), np.tile([0.0, 0.0, -9.8], (10, 1))),
    "GnssData": lambda: GnssData(
        _n(), np.full(10, 46.8), np.full(10, -71.2), np.full(10, 10.0), np.full((10, 3), 0.02)
    ),
    "ProfileScan": lambda: ProfileScan(
        np.arange(4), np.zeros(4), np.ones(4), np.zeros(4), source="s"
    ),
    "SyncPoints": lambda: SyncPoints(("a", "b"), np.array([[46.8, -71.2, 10.0]] * 2)),
    "ControlPoints": lambda: ControlPoints(("a",), _ECEF[:1]),
    "CloudPoints": lambda: CloudPoints(_ECEF, t_s=_n(3)),
    "NmeaLog": lambda: NmeaLog("n", np.array([]), (), (), ()),
    "SphereFit": lambda: fit_sphere(_sphere_points(), radius_m=0.1),
    "FlatnessResult": _wall,
}


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
@pytest.mark.parametrize("name", sorted(FACTORIES))
def test_read_only_arrays_stay_read_only_in_copies(name: str, how: str) -> None:
    original = FACTORIES[name]()
    read_only = {path: a for path, a in _arrays(original) if not a.flags.writeable}
    assert read_only, "no read-only array: the test would see nothing"
    copied = pickle.loads(pickle.dumps(original)) if how == "pickle" else copy.deepcopy(original)
    assert type(copied) is type(original)
    after = dict(_arrays(copied))
    for path, a in read_only.items():
        assert not after[path].flags.writeable, f"{name}{path} is writeable after {how}"
        np.testing.assert_array_equal(after[path], a)
        assert not np.shares_memory(after[path], a)


def test_a_copied_trajectory_cannot_be_made_to_run_backwards() -> None:
    traj = _trajectory()
    for copied in (pickle.loads(pickle.dumps(traj)), copy.deepcopy(traj)):
        with pytest.raises(ValueError, match="read-only"):
            copied.t_s[5] = copied.t_s[2]


def test_writeable_arrays_stay_writeable() -> None:
    """Only the flags the original had come back: a writeable array is not frozen."""

    @dataclasses.dataclass(frozen=True, eq=False)
    class Holder(ReadOnlyArrays):
        free: np.ndarray
        fixed: tuple[np.ndarray, np.ndarray]

    fixed = np.zeros(2)
    fixed.setflags(write=False)
    h = copy.deepcopy(Holder(np.zeros(3), (np.ones(2), fixed)))
    assert h.free.flags.writeable
    assert h.fixed[0].flags.writeable
    assert not h.fixed[1].flags.writeable
