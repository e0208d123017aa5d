"""``kinsync simulate validation``: control targets and a wall in a turn, with the truth."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from kinsync.cli._output import console, print_json, quantity_table
from kinsync.cli._progress import progress_display
from kinsync.io.atomic import output_folder
from kinsync.progress import Stages

__all__ = ["validation"]

JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


def validation(
    out: Annotated[
        Path,
        typer.Option(
            help=(
                "Output folder (targets_scan.csv, targets_trajectory.csv, control.csv, "
                "wall_scan.csv, wall_trajectory.csv, wall_box.txt, mount.toml, truth.json)."
            )
        ),
    ],
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).")] = 3,
    as_json: JsonOpt = False,
) -> None:
    """Simulate control targets passed at 5-20 m/s both ways and a wall in a 12 m turn.

    The scans are in the scanner frame with times and intensities, ready for
    `kinsync georef`; the mount's latency is the true one (0), so georeferencing with
    --latency-ms X injects a time error X that `kinsync validate` should find.
    """
    from kinsync.sim.validation_files import write_validation_scenes  # noqa: PLC0415
    from kinsync.sim.validation_scene import (  # noqa: PLC0415
        control_target_scene,
        curved_wall_scene,
    )

    output_folder(out, "give a folder for the simulation", create=False, option="--out")
    with progress_display("simulate validation") as progress:
        stages = Stages(progress, {"control targets": 2.0, "wall": 2.0, "writing files": 1.0})
        stages.start("control targets", "simulating the control-target passes")
        targets = control_target_scene(seed=seed)
        stages.start("wall", "simulating the wall")
        wall = curved_wall_scene(seed=seed)
        stages.start("writing files")
        truth = write_validation_scenes(targets, wall, out, seed)
        stages.finish()
    doc: dict[str, Any] = {
        "out": str(out),
        "targets_points": len(targets.scan),
        "wall_points": len(wall.scan),
        "control_points": len(targets.control.names),
        "pass_speeds_m_s": truth["pass_speeds_m_s"],
        "wall_box_ecef_m": truth["wall_box_ecef_m"],
    }
    if as_json:
        print_json(doc)
        return
    table = quantity_table(f"Validation scenes written to {out}")
    table.add_row("target scan points (targets_scan.csv)", str(doc["targets_points"]))
    table.add_row("control points (control.csv)", str(doc["control_points"]))
    speeds = ", ".join(f"{v:g}" for v in sorted(set(truth["pass_speeds_m_s"])))
    table.add_row("pass speeds, both ways (m/s)", speeds)
    table.add_row("wall scan points (wall_scan.csv)", str(doc["wall_points"]))
    console.print(table)
    console.print(f"wall box, ECEF (validate flatness --box): {out / 'wall_box.txt'}")
    console.print(f"truth: {out / 'truth.json'} (true latency 0)")
