"""`kinsync simulate validation` writes data on which `georef` + `validate` find a known
time error (and none without it)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from kinsync.cli import main
from kinsync.io.control_points import read_control_points
from kinsync.sim.validation_files import VALIDATION_FILES
from kinsync.validation.targets import nearest_control

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py


def _georef(folder: Path, scene: str, out: Path) -> list[str]:
    """`kinsync georef` of one scene's scan ("targets" or "wall") into ``out``."""
    return [
        "georef", "--points", str(folder / f"{scene}_scan.csv"), "--trajectory",
        str(folder / f"{scene}_trajectory.csv"), "--mount", str(folder / "mount.toml"),
        "--out", str(out), "--point-columns", "xyz",
    ]  # fmt: skip


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("val") / "val"
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "validation", "--out", str(out), "--json"])
    assert exc.value.code in (0, None)
    return out


def test_the_files_are_written(folder: Path) -> None:
    assert sorted(p.name for p in folder.iterdir()) == sorted(VALIDATION_FILES)
    truth = json.loads((folder / "truth.json").read_text())
    assert truth["latency_s"] == 0.0
    assert (folder / "wall_box.txt").read_text().strip() == truth["wall_box_ecef_m"]


@pytest.mark.parametrize("latency_ms", [0.0, 2.0])
def test_validate_finds_the_injected_time_error(
    folder: Path, tmp_path: Path, run_cli: RunCli, latency_ms: float
) -> None:
    cloud = tmp_path / "cloud.csv"
    code, _, err = run_cli(
        [*_georef(folder, "targets", cloud), "--latency-ms", str(latency_ms), "--json"]
    )
    assert code == 0, err
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(cloud), "--control",
         str(folder / "control.csv"), "--trajectory", str(folder / "targets_trajectory.csv"),
         "--centre", "sphere", "--target-radius-m", "0.2", "--json"]
    )  # fmt: skip
    assert code == 0, err
    test = json.loads(out)["time_error"]
    error_s = test["time_error_s"] - latency_ms * 1e-3
    assert abs(error_s) < 4 * test["time_error_std_s"] + 1e-5
    assert abs(error_s) < 3e-4
    assert test["significant"] is (latency_ms != 0.0)


def test_flatness_sees_the_wall_bend_with_a_time_error(
    folder: Path, tmp_path: Path, run_cli: RunCli
) -> None:
    box = (folder / "wall_box.txt").read_text().strip()
    verdicts = []
    for latency_ms in ("0", "5"):
        cloud = tmp_path / f"wall_{latency_ms}.csv"
        code, _, err = run_cli([*_georef(folder, "wall", cloud), "--latency-ms", latency_ms])
        assert code == 0, err
        code, out, err = run_cli(
            ["validate", "flatness", "--cloud", str(cloud), "--box", box, "--json"]
        )
        assert code == 0, err
        verdicts.append(json.loads(out)["curvature_significant"])
    assert verdicts == [False, True]


def test_targets_bright_throughout_their_radius_are_found_in_a_file(
    folder: Path, tmp_path: Path, run_cli: RunCli
) -> None:
    """The file is cropped to the targets' neighbourhoods as it streams: the survey's
    typical intensity must come from every chunk, not from the cropped points."""
    cloud = tmp_path / "cloud.parquet"
    code, _, err = run_cli(_georef(folder, "targets", cloud))
    assert code == 0, err
    table = pq.read_table(cloud)
    xyz = np.column_stack([table[c].to_numpy() for c in ("X", "Y", "Z")])
    near = nearest_control(xyz, read_control_points(folder / "control.csv"), 0.5) >= 0
    bright = table.set_column(
        table.schema.get_field_index("intensity"), "intensity",
        pa.array(np.where(near, 500.0, 100.0)),
    )  # fmt: skip
    pq.write_table(bright, cloud)
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(cloud), "--control",
         str(folder / "control.csv"), "--trajectory", str(folder / "targets_trajectory.csv"),
         "--centre", "sphere", "--target-radius-m", "0.2", "--json"]
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert not [m for m in doc["missing"] if "no intensity contrast" in m["reason"]]
