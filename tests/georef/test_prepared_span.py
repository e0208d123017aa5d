"""Georeferencing prepares only the trajectory records the points need (`GeorefRecords`).

A 10 h, 200 Hz SBET (7.2 million records) under 100 s of points took 65 s and 4 GB,
most of it preparing every record (ECEF positions, attitudes, slerp increments); a
process worker held a copy of it all. The records are now prepared per chunk of points,
over the span they need, and the coordinates must be the very same bits.
"""

from __future__ import annotations

import math
import pickle
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync.frames import wrap_angle_rad
from kinsync.georef import GeorefTrajectory, georeference, georeference_numpy
from kinsync.georef.trajectory import GeorefRecords
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory, VelocityConsistencyWarning

T0 = 1.3e9
MOUNT = Mount(
    lever_arm_body_m=(0.8, -0.3, -1.2), boresight_rpy_deg=(0.4, -0.7, 91.0), latency_s=0.0037
)


def _trajectory(n: int = 20_000, *, velocities: bool = True, gap: bool = True) -> Trajectory:
    """A 100 Hz trajectory, turning and rolling, with a 1 s gap at record 12 000."""
    t = T0 + np.arange(n) * 0.01
    if gap:
        t[12_000:] += 1.0
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, 179.999 + 2e-6 * s, 10.0 + 0.1 * np.sin(s)])
    llh[:, 1] = (llh[:, 1] + 180.0) % 360.0 - 180.0  # crosses the antimeridian
    vel = None
    if velocities:
        vel = np.column_stack([1.113 + 0 * s, 0.152 + 0 * s, -0.01 * np.cos(s)])
    return Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(0.5 * s), wrap_angle_rad(0.3 + 0.05 * s), lat_lon_h=llh,
        vel_ned_m_s=vel,
    )  # fmt: skip


def _points(t0: float, t1: float, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return T0 + rng.uniform(t0, t1, n), rng.uniform(-20, 20, (n, 3))


@pytest.mark.parametrize("position", ["linear", "auto"])
@pytest.mark.parametrize(
    "span", [(50.0, 52.0), (-1.0, 0.5), (119.5, 121.5), (199.0, 203.0), (0.0, 200.0)]
)
def test_a_prepared_span_gives_the_same_bits(position: Any, span: tuple[float, float]) -> None:
    """Inside, before, across a gap, past the end, all of it: every bit the same."""
    traj = _trajectory()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the velocities agree
        whole = GeorefTrajectory.from_trajectory(traj, MOUNT.latency_s)
        records = GeorefRecords.from_trajectory(traj, MOUNT.latency_s)
    t, xyz = _points(*span, 3000, seed=int(span[0]) + 7)
    expected, inside = georeference(t, xyz, whole, MOUNT, position=position)
    got, got_inside = georeference(t, xyz, records, MOUNT, position=position)
    assert np.array_equal(got_inside, inside)
    assert np.array_equal(got.view(np.uint64), expected.view(np.uint64))
    assert records.gaps == whole.gaps
    assert records.max_gap_s == whole.max_gap_s


def test_only_the_records_the_points_need_are_prepared() -> None:
    records = GeorefRecords.from_trajectory(_trajectory(), MOUNT.latency_s)
    t, xyz = _points(50.0, 52.0, 1000, seed=1)
    georeference(t, xyz, records, MOUNT)
    prepared = records.prepared_for(float(t.min()), float(t.max()))
    assert len(prepared) <= 203  # 2 s at 100 Hz and the records bracketing it
    assert records._whole is None


def test_the_numpy_reference_and_a_worker_copy_agree() -> None:
    records = GeorefRecords.from_trajectory(_trajectory(), MOUNT.latency_s)
    t, xyz = _points(10.0, 11.0, 500, seed=2)
    georeference(t, xyz, records, MOUNT)
    copy = pickle.loads(pickle.dumps(records))
    assert copy._last is None  # a worker gets the records, not what was prepared here
    a, _ = georeference(t, xyz, copy, MOUNT)
    b, _ = georeference_numpy(t, xyz, records, MOUNT)
    np.testing.assert_allclose(a, b, atol=1e-6, rtol=0)


def test_velocities_that_disagree_are_dropped_for_the_whole_trajectory() -> None:
    traj = _trajectory(gap=False)
    assert traj.vel_ned_m_s is not None
    bad = Trajectory(
        t_s=traj.t_s, q_body_to_ned=traj.q_body_to_ned, lat_lon_h=traj.lat_lon_h,
        vel_ned_m_s=traj.vel_ned_m_s * 3.0,
    )  # fmt: skip
    with pytest.warns(VelocityConsistencyWarning):
        records = GeorefRecords.from_trajectory(bad, 0.0)
    assert not records.has_velocities
    assert records.velocity_warning is not None
    part = records.prepared_for(T0 + 5.0, T0 + 6.0)
    assert part.vel_ecef_m_s is None


def test_georef_of_a_long_trajectory_prepares_a_short_span(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """georeference_file prepares the records under the points, not all of them."""
    write_trajectory_csv(_trajectory(60_000, gap=False), tmp_path / "traj.csv")
    t, xyz = _points(300.0, 303.0, 2000, seed=3)
    t.sort()
    table = "t_s,x_m,y_m,z_m\n" + "".join(
        f"{a!r},{b!r},{c!r},{d!r}\n" for a, (b, c, d) in zip(t.tolist(), xyz.tolist(), strict=True)
    )
    (tmp_path / "p.csv").write_text(table)
    sizes: list[int] = []
    prepare = GeorefTrajectory.from_trajectory.__func__  # type: ignore[attr-defined]

    def spy(cls: type[GeorefTrajectory], trajectory: Trajectory, *args: Any, **kw: Any) -> Any:
        sizes.append(len(trajectory))
        return prepare(cls, trajectory, *args, **kw)

    monkeypatch.setattr(GeorefTrajectory, "from_trajectory", classmethod(spy))
    summary = georeference_file(
        tmp_path / "p.csv", tmp_path / "traj.csv", MOUNT, tmp_path / "g.csv", crs="EPSG:4978"
    )
    assert summary.points_out == 2000
    assert sizes
    assert max(sizes) < 1000  # of 60 000 records; 3 s is 300


def test_nan_and_infinite_times_keep_their_errors_and_masks() -> None:
    traj = _trajectory(gap=False)
    whole = GeorefTrajectory.from_trajectory(traj, 0.0)
    records = GeorefRecords.from_trajectory(traj, 0.0)
    t = np.array([T0 + 3.0, math.inf, T0 - 1.0])
    xyz = np.zeros((3, 3))
    with pytest.raises(Exception, match="index 1") as a:
        georeference(t, xyz, whole, Mount())
    with pytest.raises(type(a.value), match="index 1"):
        georeference(t, xyz, records, Mount())
