"""A trajectory that does not belong to the cloud is refused, never validated.

With the trajectory of another place or height the target's position relative to the
vehicle is hundreds of metres or kilometres long, the rotation term of the time-error
regressor swamps the speed and the time error collapsed to a "not significant" zero.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.control_points import write_control_points
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.pipelines.validation import control_points_file
from kinsync.sim.validation_scene import ControlTargetScene, control_target_scene
from kinsync.trajectory import Trajectory

LATENCY_ERROR_S = 0.002


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, ControlTargetScene]:
    """A late cloud and its control points written as files."""
    scene = control_target_scene(seed=11)
    scan = scene.scan
    mount = scan.mount.with_latency(LATENCY_ERROR_S)
    traj = GeorefTrajectory.from_trajectory(scan.trajectory, mount.latency_s)
    pos, inside = georeference(scan.t_s, scan.xyz_scanner_m, traj, mount)
    assert inside.all()
    root = tmp_path_factory.mktemp("geometry")
    cloud = root / "cloud.csv"
    table = np.column_stack([scan.t_s, pos, scan.intensity])
    np.savetxt(cloud, table, fmt="%.17g", delimiter=",", header="t_s,X,Y,Z,intensity", comments="")
    control = root / "control.csv"
    write_control_points(scene.control, control)
    return cloud, control, scene


def _moved(trajectory: Trajectory, d_lat_deg: float, d_h_m: float) -> Trajectory:
    assert trajectory.lat_lon_h is not None
    llh = np.array(trajectory.lat_lon_h) + np.array([d_lat_deg, 0.0, d_h_m])
    return replace(trajectory, lat_lon_h=llh, _lon_unwrapped_deg=None)


def _validate(files: tuple[Path, Path, ControlTargetScene], trajectory: Trajectory) -> float:
    cloud, control, scene = files
    path = cloud.parent / "trajectory.csv"
    write_trajectory_csv(trajectory, path)
    report = control_points_file(
        cloud, control, path, centre="sphere", target_radius_m=scene.target_radius_m
    )
    return report.time_error.estimate


def test_the_right_trajectory_shows_the_time_error(
    files: tuple[Path, Path, ControlTargetScene],
) -> None:
    tau = _validate(files, files[2].scan.trajectory)
    assert tau == pytest.approx(LATENCY_ERROR_S, abs=3e-4)


@pytest.mark.parametrize(
    ("d_lat_deg", "d_h_m", "fragment"),
    [
        (1.0, 0.0, "111 km from it: no kinematic laser scanner measures that far"),
        (0.0, 500.0, "above them, and every point lies within"),
        (0.0, -500.0, "below them, and every point lies within"),
    ],
)
def test_a_trajectory_of_another_place_or_height_is_refused(
    files: tuple[Path, Path, ControlTargetScene], d_lat_deg: float, d_h_m: float, fragment: str
) -> None:
    moved = _moved(files[2].scan.trajectory, d_lat_deg, d_h_m)
    with pytest.raises(InputError, match=r"trajectory\.csv against .*cloud\.csv") as err:
        _validate(files, moved)
    assert fragment in str(err.value)
    assert "does not belong to the cloud" in str(err.value)
