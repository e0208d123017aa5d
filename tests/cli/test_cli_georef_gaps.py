"""``kinsync georef`` and ``kinsync trajectory info`` on a trajectory with a gap."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli.conftest import OneLineError, RunCli
from tests.pipelines.test_georef_gaps import GAP, _columns, _write_las, gap_traj

__all__ = ["gap_traj"]  # the fixture


def test_cli_refuses_points_in_a_gap_and_trajectory_info_warns(
    tmp_path: Path, gap_traj: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    src = tmp_path / "scan.laz"
    _write_las(src, _columns())
    mount = tmp_path / "mount.toml"
    mount.write_text(
        "[mount]\nlever_arm_body_m = [0.5, 0.1, -1.0]\n"
        "boresight_rpy_deg = [0.5, -0.3, 90.0]\nlatency_s = 0.0\n"
    )
    argv = ["georef", "--points", str(src), "--trajectory", str(gap_traj), "--mount", str(mount)]
    code, out, err = run_cli([*argv, "--out", str(tmp_path / "o.laz")])
    assert_one_line_error(code, out, err, "gap", f"{GAP[0]!r}", "--max-gap-s")
    code, out, err = run_cli([*argv, "--out", str(tmp_path / "o.laz"), "--max-gap-s", "2.5"])
    assert code == 0, err
    code, out, err = run_cli(["trajectory", "info", str(gap_traj), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["gaps"] == [{"t_start_s": GAP[0], "t_end_s": GAP[1]}]
    assert any("1 gap(s)" in w for w in doc["warnings"])
    assert "gap" in err
