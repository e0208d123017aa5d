"""``kinsync georef`` and ``kinsync trajectory info`` on a trajectory with a gap."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from tests.cli.conftest import OneLineError, RunCli
from tests.pipelines.test_georef_gaps import GAP, _columns, _trajectory, _write_las, gap_traj

from kinsync.trajectory_gaps import max_gap_for

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
    limit = max_gap_for(_trajectory().t_s)  # 10 median intervals: 0.0999999 s used
    assert limit != 0.1
    threshold = "record intervals longer than 0.1 s (the gap threshold: --max-gap-s"
    assert threshold in err
    # a threshold given is named as such, not as "default 10 median record intervals"
    code, out, err = run_cli([*argv, "--out", str(tmp_path / "o.laz"), "--max-gap-s", "0.5"])
    assert_one_line_error(
        code,
        out,
        err,
        "record intervals longer than 0.5 s (the gap threshold given with --max-gap-s)",
    )
    assert "default" not in err
    code, out, err = run_cli(
        [*argv, "--out", str(tmp_path / "o.laz"), "--max-gap-s", "2.5", "--json"]
    )
    assert code == 0, err
    assert json.loads(out)["gap_threshold_s"] == 2.5
    code, out, err = run_cli(["trajectory", "info", str(gap_traj), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["gaps"] == [{"t_start_s": GAP[0], "t_end_s": GAP[1]}]
    # shown rounded to 1 us (the threshold used is 0.09999990463256836 s: time noise)
    assert doc["gap_threshold_s"] == 0.1 == pytest.approx(limit, abs=1e-6)
    # the hole itself, not a threshold: no key to mistake for --max-gap-s
    assert doc["longest_interval_s"] == pytest.approx(GAP[1] - GAP[0])
    assert "max_gap_s" not in doc
    (warning,) = [w for w in doc["warnings"] if "1 gap(s)" in w]
    assert threshold in warning
    assert "gap" in err


def test_trajectory_info_lists_the_gaps_at_the_threshold_given(
    gap_traj: Path, run_cli: RunCli
) -> None:
    """The 2 s hole is no gap at --max-gap-s 2.5; every interval over 0.005 s is one."""
    code, out, err = run_cli(["trajectory", "info", str(gap_traj), "--max-gap-s", "2.5", "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["gap_threshold_s"] == 2.5
    assert doc["gaps"] == []
    assert doc["warnings"] == []
    assert err == ""
    code, out, err = run_cli(["trajectory", "info", str(gap_traj), "--max-gap-s", "0.005"])
    assert code == 0, err
    assert "gap_threshold_s" in out
    assert "kinsync: warning:" in err
    assert f"{len(_trajectory().t_s) - 1} gap(s)" in err
