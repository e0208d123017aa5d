"""Gaps inside a trajectory: points there are never interpolated across the gap.

A 10 s hole in a 100 Hz trajectory, interpolated across, moves points by decimetres;
such points are treated like points outside the span (an error, or rejected), with a
message naming the gap, and ``kinsync trajectory info`` warns about it.
"""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest
from tests._las import las_points

from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference, georeference_numpy
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import max_gap_for, trajectory_gaps

T0 = 1.3e9
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
GAP = (T0 + 3.0, T0 + 5.0)  # records removed strictly between these times
N = 2_000


def _trajectory(gap: bool = True) -> Trajectory:
    t = T0 + np.round(np.arange(0.0, 10.0, 0.01), 2)
    if gap:
        t = t[~((t > GAP[0]) & (t < GAP[1]))]
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s * s])
    return Trajectory.from_euler(
        t, 0.2 * np.sin(s), 0.01 * np.cos(s), 0.3 + 0.3 * np.sin(s), lat_lon_h=llh
    )


def _columns() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    return {
        "t_s": T0 + np.sort(rng.uniform(0.1, 9.9, N)),
        "x_m": rng.uniform(-1, 1, N),
        "y_m": rng.uniform(-20, 20, N),
        "z_m": rng.uniform(-5, 5, N),
    }


def _in_gap(t: np.ndarray) -> np.ndarray:
    return (t > GAP[0]) & (t < GAP[1])


@pytest.fixture
def gap_traj(tmp_path: Path) -> Path:
    path = tmp_path / "gap.csv"
    write_trajectory_csv(_trajectory(), path)
    return path


def _write_las(path: Path, cols: dict[str, np.ndarray]) -> None:
    las_points(cols).write(path)


def test_the_default_threshold_is_ten_median_intervals() -> None:
    t = _trajectory().t_s
    assert max_gap_for(t) == pytest.approx(0.1)
    (gap,) = trajectory_gaps(t, max_gap_for(t))
    assert (gap.t_start_s, gap.t_end_s) == pytest.approx(GAP)
    assert gap.length_s == pytest.approx(2.0)
    assert trajectory_gaps(t, max_gap_for(t, 2.5)) == ()
    with pytest.raises(InputError, match="max-gap-s"):
        max_gap_for(t, 0.0)


def test_the_kernel_and_its_reference_mark_points_in_a_gap_outside() -> None:
    cols = _columns()
    xyz = np.column_stack([cols["x_m"], cols["y_m"], cols["z_m"]])
    gt = GeorefTrajectory.from_trajectory(_trajectory())
    pos, inside = georeference(cols["t_s"], xyz, gt, MOUNT)
    ref, ref_inside = georeference_numpy(cols["t_s"], xyz, gt, MOUNT)
    gap = _in_gap(cols["t_s"])
    assert gap.sum() > 300
    np.testing.assert_array_equal(inside, ~gap)
    np.testing.assert_array_equal(ref_inside, ~gap)
    np.testing.assert_array_equal(gt.contains(cols["t_s"]), ~gap)
    assert np.isnan(pos[gap]).all()
    np.testing.assert_allclose(pos[~gap], ref[~gap], atol=1e-6)
    # a point on a record at either end of the gap is still georeferenced
    edge, edge_inside = georeference(np.array(GAP), np.zeros((2, 3)), gt, MOUNT)
    assert edge_inside.all()
    assert np.isfinite(edge).all()
    # an explicit threshold above the gap interpolates across it, as before
    wide = GeorefTrajectory.from_trajectory(_trajectory(), max_gap_s=3.0)
    assert georeference(cols["t_s"], xyz, wide, MOUNT)[1].all()


@pytest.mark.parametrize("suffix", [".laz", ".csv"])
def test_points_in_a_gap_are_an_error_naming_the_gap(
    tmp_path: Path, gap_traj: Path, suffix: str
) -> None:
    cols = _columns()
    src = tmp_path / f"scan{suffix}"
    if suffix == ".laz":
        _write_las(src, cols)
    else:
        src.write_text(
            "t_s,x_m,y_m,z_m\n"
            + "".join(
                f"{t!r},{x!r},{y!r},{z!r}\n"
                for t, x, y, z in zip(*(c.tolist() for c in cols.values()), strict=True)
            )
        )
    out = tmp_path / f"out{suffix}"
    n_gap = int(_in_gap(cols["t_s"]).sum())
    with pytest.raises(InputError) as err:
        georeference_file(src, gap_traj, MOUNT, out, crs="EPSG:32619", chunk_points=500)
    msg = str(err.value)
    assert f"{n_gap} point(s)" in msg
    assert f"{GAP[0]!r} .. {GAP[1]!r} s (2 s)" in msg
    assert "--max-gap-s" in msg
    assert "--outside reject" in msg
    assert not out.exists()


def test_rejected_gap_points_go_to_the_rejected_file_and_the_counts_add_up(
    tmp_path: Path, gap_traj: Path
) -> None:
    cols = _columns()
    src, out = tmp_path / "scan.laz", tmp_path / "out.laz"
    _write_las(src, cols)
    gap = _in_gap(cols["t_s"])
    summary = georeference_file(
        src, gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject", chunk_points=700
    )
    assert summary.points_rejected == int(gap.sum())
    assert summary.points_out + summary.points_rejected == N
    assert any("gap" in w and f"{GAP[0]!r}" in w for w in summary.warnings)
    rejected = laspy.read(tmp_path / "out.rejected.laz")
    np.testing.assert_allclose(np.sort(rejected.gps_time) + 1e9, cols["t_s"][gap])  # adjusted
    # with --max-gap-s above the gap every point is written, as an interpolation
    summary = georeference_file(
        src, gap_traj, MOUNT, tmp_path / "all.laz", crs="EPSG:32619", max_gap_s=2.5
    )
    assert summary.points_out == N


def test_a_run_that_rejects_nothing_removes_an_earlier_rejected_file(
    tmp_path: Path, gap_traj: Path
) -> None:
    """Otherwise the earlier run's rejects sit beside the new output: counts that do
    not add up."""
    cols = _columns()
    src, out = tmp_path / "scan.laz", tmp_path / "out.laz"
    _write_las(src, cols)
    first = georeference_file(src, gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject")
    assert first.rejected_path == tmp_path / "out.rejected.laz"
    assert first.rejected_path.exists()
    keep = ~_in_gap(cols["t_s"])
    _write_las(src, {k: v[keep] for k, v in cols.items()})
    second = georeference_file(src, gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject")
    assert second.points_rejected == 0
    assert second.rejected_path is None
    assert not (tmp_path / "out.rejected.laz").exists()
    assert any("out.rejected.laz: removed" in w for w in second.warnings)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gap.csv", "out.laz", "scan.laz"]


def _write_csv(path: Path, cols: dict[str, np.ndarray]) -> None:
    rows = np.column_stack([cols[k] for k in ("t_s", "x_m", "y_m", "z_m")])
    lines = ["t_s,x_m,y_m,z_m", *(",".join(repr(float(v)) for v in row) for row in rows)]
    path.write_text("\n".join(lines) + "\n")


def test_a_run_removes_the_rejected_file_of_an_earlier_input_format(
    tmp_path: Path, gap_traj: Path
) -> None:
    """A CSV input to out.laz rejects to out.laz.rejected.csv; a LAZ input to the same
    --out that rejects none left that file there (only out.rejected.laz was looked for)."""
    cols = _columns()
    out = tmp_path / "out.laz"
    _write_csv(tmp_path / "scan.csv", cols)
    first = georeference_file(
        tmp_path / "scan.csv", gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject"
    )
    assert first.rejected_path == tmp_path / "out.laz.rejected.csv"
    keep = ~_in_gap(cols["t_s"])
    _write_las(tmp_path / "scan.laz", {k: v[keep] for k, v in cols.items()})
    second = georeference_file(
        tmp_path / "scan.laz", gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject"
    )
    assert second.points_rejected == 0
    assert not (tmp_path / "out.laz.rejected.csv").exists()
    assert any("out.laz.rejected.csv: removed" in w for w in second.warnings)


def test_a_run_that_rejects_removes_the_rejected_file_of_another_input_format(
    tmp_path: Path, gap_traj: Path
) -> None:
    """Its own rejected file has another name: the earlier one would add points."""
    cols = _columns()
    out = tmp_path / "out.laz"
    _write_csv(tmp_path / "scan.csv", cols)
    georeference_file(
        tmp_path / "scan.csv", gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject"
    )
    _write_las(tmp_path / "scan.laz", cols)
    second = georeference_file(
        tmp_path / "scan.laz", gap_traj, MOUNT, out, crs="EPSG:32619", outside="reject"
    )
    assert second.rejected_path == tmp_path / "out.rejected.laz"
    assert second.rejected_path.exists()
    assert not (tmp_path / "out.laz.rejected.csv").exists()
    assert any(
        "out.laz.rejected.csv: removed" in w and "out.rejected.laz" in w for w in second.warnings
    )


def test_rejected_files_of_other_outputs_are_kept(tmp_path: Path, gap_traj: Path) -> None:
    """Runs to out.csv and out.las from one input keep each their own rejected file."""
    cols = _columns()
    _write_csv(tmp_path / "scan.csv", cols)
    keep = ~_in_gap(cols["t_s"])
    _write_las(tmp_path / "scan.laz", {k: v[keep] for k, v in cols.items()})
    for name in ("out.rejected.csv", "out.csv.rejected.laz", "out.rejected.las", "x.laz"):
        (tmp_path / name).write_text("not this output's")
    run = georeference_file(
        tmp_path / "scan.laz", gap_traj, MOUNT, tmp_path / "out.laz", crs="EPSG:32619"
    )
    assert run.warnings == ()
    for name in ("out.rejected.csv", "out.csv.rejected.laz", "out.rejected.las", "x.laz"):
        assert (tmp_path / name).read_text() == "not this output's"
