"""Write the validation scenes (control targets, wall in a turn) as a survey would hold them.

The files are what `kinsync georef` and `kinsync validate` read, so the validation
commands can be tried on data with a known answer: scanner-frame points with times and
intensities, the trajectory, the mount (true latency 0), the surveyed control points and
the box around the wall.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from kinsync.io.atomic import atomic_write_text
from kinsync.io.control_points import write_control_points
from kinsync.io.mount_file import write_mount
from kinsync.io.tables import write_numeric_csv
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.sim.folder import simulation_folder
from kinsync.sim.validation_scene import ControlTargetScene, SimulatedScan, WallScene

__all__ = ["VALIDATION_FILES", "validation_truth", "write_validation_scenes"]

VALIDATION_FILES = (
    "targets_scan.csv",
    "targets_trajectory.csv",
    "control.csv",
    "wall_scan.csv",
    "wall_trajectory.csv",
    "wall_box.txt",
    "mount.toml",
    "truth.json",
)
"""The files `write_validation_scenes` writes, in order."""


def _write_scan(scan: SimulatedScan, path: Path) -> None:
    xyz = scan.xyz_scanner_m
    write_numeric_csv(
        path,
        {
            "t_s": scan.t_s,
            "x_m": xyz[:, 0],
            "y_m": xyz[:, 1],
            "z_m": xyz[:, 2],
            "intensity": scan.intensity,
        },
    )


def validation_truth(targets: ControlTargetScene, wall: WallScene, seed: int) -> dict[str, Any]:
    """The set-up and the true values (``truth.json``).

    Parameters
    ----------
    targets, wall : ControlTargetScene, WallScene
        The scenes.
    seed : int
        Their random seed.

    Returns
    -------
    dict
        JSON-ready: seed, true latency (0 s), target shape and radius, pass speeds (m/s),
        the true target centres (ECEF, m), the wall box as ``--box`` text (ECEF, m), the
        turn radius (m) and speed (m/s).
    """
    return {
        "seed": seed,
        "latency_s": 0.0,
        "target_shape": targets.target_shape,
        "target_radius_m": targets.target_radius_m,
        "pass_speeds_m_s": list(targets.speeds_m_s),
        "targets_ecef_m": {
            name: [float(v) for v in row]
            for name, row in zip(targets.control.names, targets.truth_ecef_m, strict=True)
        },
        "wall_box_ecef_m": ",".join(f"{v:.3f}" for v in wall.box_ecef_m),
        "wall_turn_radius_m": wall.radius_m,
        "wall_speed_m_s": wall.speed_m_s,
    }


def write_validation_scenes(
    targets: ControlTargetScene, wall: WallScene, out_dir: Path, seed: int
) -> dict[str, Any]:
    """Write both scenes into ``out_dir`` (`VALIDATION_FILES`), as one whole.

    Parameters
    ----------
    targets : ControlTargetScene
        Control targets passed at several speeds both ways.
    wall : WallScene
        A wall on the outside of a tight turn.
    out_dir : Path
        Output folder: missing, empty or holding an earlier validation simulation,
        replaced as a whole once the new one is complete (`simulation_folder`).
    seed : int
        The scenes' seed, recorded in ``truth.json``.

    Returns
    -------
    dict
        The truth written to ``truth.json`` (`validation_truth`).

    Raises
    ------
    ValueError
        The two scenes do not share one mount (one ``mount.toml`` serves both).
    """
    if targets.scan.mount != wall.scan.mount:
        msg = "write_validation_scenes: the two scenes must share one mount"
        raise ValueError(msg)
    truth = validation_truth(targets, wall, seed)
    with simulation_folder(out_dir, "validation") as out:
        _write_scan(targets.scan, out / "targets_scan.csv")
        write_trajectory_csv(targets.scan.trajectory, out / "targets_trajectory.csv")
        write_control_points(targets.control, out / "control.csv")
        _write_scan(wall.scan, out / "wall_scan.csv")
        write_trajectory_csv(wall.scan.trajectory, out / "wall_trajectory.csv")
        atomic_write_text(out / "wall_box.txt", truth["wall_box_ecef_m"] + "\n")
        write_mount(targets.scan.mount, out / "mount.toml")
        atomic_write_text(out / "truth.json", json.dumps(truth, indent=2) + "\n")
    return truth
