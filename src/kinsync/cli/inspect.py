"""``kinsync mount check`` and ``kinsync trajectory info``: validate and summarise inputs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.table import Table

from kinsync.cli._output import console, print_json
from kinsync.io.mount_file import read_mount
from kinsync.io.trajectory_csv import read_trajectory_csv

mount_app = typer.Typer(help="Mount (system calibration) TOML files.")
trajectory_app = typer.Typer(help="Trajectory files.")


def _print_quantities(title: str, rows: dict[str, str]) -> None:
    table = Table(title=title)
    table.add_column("quantity")
    table.add_column("value", justify="right")
    for key, value in rows.items():
        table.add_row(key, value)
    console.print(table)


JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


@mount_app.command("check")
def mount_check(
    path: Annotated[Path, typer.Argument(help="Mount TOML file.")], as_json: JsonOpt = False
) -> None:
    """Validate a mount TOML file and print its values and boresight matrix."""
    mount = read_mount(path)
    doc: dict[str, Any] = {
        "lever_arm_body_m": list(mount.lever_arm_body_m),
        "boresight_rpy_deg": list(mount.boresight_rpy_deg),
        "antenna_lever_arm_body_m": list(mount.antenna_lever_arm_body_m),
        "latency_s": mount.latency_s,
        "R_scanner_to_body": mount.R_scanner_to_body.tolist(),
    }
    if as_json:
        print_json(doc)
        return
    rows = {
        key: ", ".join(f"{v:g}" for v in doc[key])
        for key in ("lever_arm_body_m", "boresight_rpy_deg", "antenna_lever_arm_body_m")
    }
    _print_quantities(f"Mount {path}", {**rows, "latency_s": f"{mount.latency_s:g}"})


@trajectory_app.command("info")
def trajectory_info(
    path: Annotated[
        Path, typer.Argument(help="Trajectory CSV (t_s,lat_deg,lon_deg,h_m,roll_deg,...).")
    ],
    as_json: JsonOpt = False,
) -> None:
    """Validate a trajectory CSV and print its span, rate and motion."""
    traj = read_trajectory_csv(path)
    dt = np.diff(traj.t_s)
    rate = np.degrees(np.linalg.norm(traj.angular_rate_body_rad_s(), axis=1))
    doc: dict[str, Any] = {
        "records": len(traj),
        "t_start_s": traj.t_start_s,
        "t_end_s": traj.t_end_s,
        "duration_s": traj.duration_s,
        "median_rate_hz": float(1.0 / np.median(dt)),
        "max_gap_s": float(dt.max()),
        "max_angular_rate_deg_s": float(rate.max()),
        "has_velocity": traj.vel_ned_m_s is not None,
    }
    if as_json:
        print_json(doc)
        return
    _print_quantities(
        f"Trajectory {path}",
        {k: f"{v:.10g}" if isinstance(v, float) else str(v) for k, v in doc.items()},
    )
