"""``kinsync simulate rotating-table``: JSON, table, files written and bad input."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from kinsync.cli._options import parse_rates
from kinsync.errors import InputError
from kinsync.io.passes import read_passes

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py

BASE = ["simulate", "rotating-table", "--rates-deg-s", "6", "--passes", "1"]


def test_json_summary_and_files(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "sim"
    code, stdout, _ = run_cli([*BASE, "--seed", "2", "--out", str(out), "--json"])
    assert code == 0
    doc = json.loads(stdout)
    assert doc["n_passes"] == 2
    assert doc["latency_s"] == pytest.approx(4.21e-3)
    assert doc["fifo_delay_s"] == 0.0
    assert doc["format"] == "csv"
    assert 1500 <= doc["mean_sphere_points_per_pass_by_rate"]["+6"] <= 2500
    passes = read_passes(out)
    assert [p.rate_deg_s for p in passes] == [6.0, -6.0]
    assert sum(p.n_points for p in passes) == doc["n_points"]
    truth = json.loads((out / "truth.json").read_text())
    assert truth["seed"] == 2
    assert truth["config"]["range_noise_m"] == 0.002


def test_table_output(run_cli: RunCli, tmp_path: Path) -> None:
    code, stdout, _ = run_cli([*BASE, "--out", str(tmp_path / "t")])
    assert code == 0
    assert "passes written" in stdout
    assert "truth latency (ms)" in stdout
    assert "4.21" in stdout


def test_laz_raw_fifo_and_options(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "laz"
    argv = [*BASE, "--out", str(out), "--format", "laz", "--raw", "--json"]
    argv += ["--latency-ms", "2.5", "--fifo-bytes", "14", "--baud", "115200"]
    code, stdout, _ = run_cli([*argv, "--range-noise-m", "0.001"])
    assert code == 0
    doc = json.loads(stdout)
    assert doc["latency_s"] == pytest.approx(2.5e-3 + 14 * 10 / 115200)
    assert doc["imu_latency_s"] == pytest.approx(2.5e-3)
    assert (out / "pass_000.laz").is_file()
    assert (out / "raw" / "attitude.csv").is_file()
    assert (out / "raw" / "mount.toml").is_file()
    assert (out / "raw" / "pass_001.csv").is_file()
    assert len(read_passes(out)) == 2


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--passes", "-1"], "--passes must be at least 1"),
        (["--rates-deg-s", "2,,x"], "item 2 is empty"),
        (["--rates-deg-s", "2,x"], "'x') is not a number"),
        (["--rates-deg-s", ""], "--rates-deg-s is empty"),
        (["--rates-deg-s", "0"], "must be a rate magnitude > 0"),
        (["--rates-deg-s", "-2"], "must be a rate magnitude > 0"),
        (["--format", "ply"], "--format must be csv, las or laz"),
        (["--fifo-bytes", "-3"], "fifo_bytes"),
        (["--range-noise-m", "-0.1"], "range_noise_m"),
        (["--passes", "two"], "--passes"),
    ],
)
def test_bad_input_exits_2_with_one_line(
    run_cli: RunCli, tmp_path: Path, extra: list[str], fragment: str
) -> None:
    code, stdout, stderr = run_cli([*BASE, "--out", str(tmp_path / "o"), *extra])
    assert code == 2
    assert stdout == ""
    assert stderr.startswith("kinsync: error:")
    assert stderr.count("\n") == 1
    assert fragment in stderr
    assert not (tmp_path / "o").exists()


def test_out_is_an_existing_file(run_cli: RunCli, tmp_path: Path) -> None:
    f = tmp_path / "file.txt"
    f.write_text("keep me")
    code, _, stderr = run_cli([*BASE, "--out", str(f)])
    assert code == 2
    assert "exists and is not a folder" in stderr
    assert f.read_text() == "keep me"


def test_out_is_required(run_cli: RunCli) -> None:
    code, _, stderr = run_cli(BASE)
    assert code == 2
    assert "--out" in stderr


def test_parse_rates() -> None:
    assert parse_rates(" 2, 4.5 ,18") == (2.0, 4.5, 18.0)
    with pytest.raises(InputError, match="inf"):
        parse_rates("2,inf")
