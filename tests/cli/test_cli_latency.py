"""``kinsync latency sphere`` and ``kinsync latency plan``: documents, figures, bad input."""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from kinsync.io.mount_file import read_mount, write_mount
from kinsync.io.provenance import software
from kinsync.mount import Mount, MountUncertainty, StdCorrelation
from kinsync.sim.rotating_table import simulate_rotating_table, write_simulation
from kinsync.sim.table_config import RotatingTableConfig
from kinsync.trajectory_gaps import gap_threshold_shown_s

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py
TAU_S = 0.00421


@pytest.fixture(scope="module")
def sim_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("table") / "passes"
    cfg = RotatingTableConfig(latency_s=TAU_S, rates_deg_s=(6.0, 18.0), passes=3, seed=4)
    write_simulation(simulate_rotating_table(cfg), folder)
    return folder


def copy_of(folder: Path, tmp_path: Path) -> Path:
    target = tmp_path / "copy"
    shutil.copytree(folder, target)
    return target


def rewrite_index(
    folder: Path, keep: Callable[[dict[str, str]], bool], *, delete_dropped: bool = True
) -> None:
    """Keep the lines of passes.csv that ``keep`` accepts; delete the other pass files.

    ``delete_dropped=False`` leaves them in the folder (a warning names them).
    """
    index = folder / "passes.csv"
    with index.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    fields = list(rows[0])
    with index.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(r for r in rows if keep(r))
    if delete_dropped:
        for r in rows:
            if not keep(r):
                (folder / r["file"]).unlink()


def test_sphere_json_document_and_figure(run_cli: RunCli, sim_folder: Path, tmp_path: Path) -> None:
    fig = tmp_path / "fig.png"
    code, out, err = run_cli(
        ["latency", "sphere", str(sim_folder), "--radius-m", "0.1", "--figure", str(fig), "--json"]
    )
    assert code == 0, err
    doc = json.loads(out)
    assert set(doc) >= {"latency_ms", "latency_std_ms", "per_rate", "sphere"}
    assert abs(doc["latency_ms"] - TAU_S * 1e3) < 4 * doc["latency_std_ms"]
    assert [r["rate_deg_s"] for r in doc["per_rate"]] == [6.0, 18.0]
    for row in doc["per_rate"]:
        assert set(row) >= {
            "rate_deg_s",
            "n_points",
            "center_std_m",
            "latency_ms",
            "latency_std_ms",
        }
        assert row["n_points"] > 1000
    assert doc["sphere"]["radius_m"] == 0.1
    assert len(doc["sphere"]["center_ned_m"]) == 3
    truth = json.loads((sim_folder / "truth.json").read_text())
    np.testing.assert_allclose(
        doc["sphere"]["center_ned_m"], truth["sphere_center_ned_m"], atol=2e-3
    )
    assert fig.read_bytes().startswith(b"\x89PNG")
    scatter = doc["pass_scatter"]
    assert scatter["measured"] is True
    assert scatter["dof"] == 3 * 4 * 2  # 4 signed rates of 3 passes
    assert set(scatter) >= {"std_mm", "chi2", "p_value", "significant", "cov_mm2"}


def test_sphere_reports_the_passes_scatter_and_warns_when_it_cannot(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path
) -> None:
    code, out, _ = run_cli(["latency", "sphere", str(sim_folder), "--no-figure"])
    assert code == 0
    assert re.search(r"passes (agree with their points' noise|scatter .* mm beyond)", out), out
    one = tmp_path / "one"
    cfg = RotatingTableConfig(latency_s=TAU_S, rates_deg_s=(6.0, 18.0), passes=1, seed=4)
    write_simulation(simulate_rotating_table(cfg), one)
    code, out, err = run_cli(["latency", "sphere", str(one), "--no-figure"])
    assert code == 0, err
    assert "pass-to-pass scatter not measured" in out
    assert "one pass per rate and direction" in err
    assert "scan at least 2 passes per rate and direction" in err


def test_sphere_table_default_figure_and_no_figure(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    code, out, _ = run_cli(["latency", "sphere", str(folder)])
    assert code == 0
    assert "Method A" in out
    assert "latency" in out
    assert (folder / "latency_sphere.png").exists()
    (folder / "latency_sphere.png").unlink()
    code, _, _ = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert code == 0
    assert not (folder / "latency_sphere.png").exists()


def _flip_rates(folder: Path, which: Callable[[dict[str, str]], bool]) -> None:
    """Negate, in passes.csv, the signed rates of the lines that ``which`` picks."""
    index = folder / "passes.csv"
    with index.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        if which(row):
            row["rate_deg_s"] = str(-float(row["rate_deg_s"]))
    with index.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _rewrite_rows(path: Path, change: Callable[[dict[str, str]], None]) -> None:
    """Apply ``change`` to each row of a CSV pass file, in place."""
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        change(row)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _to_enu(row: dict[str, str]) -> None:
    row["x_m"], row["y_m"] = row["y_m"], row["x_m"]
    row["z_m"] = repr(-float(row["z_m"]))


def _to_millimetres(row: dict[str, str]) -> None:
    for c in ("x_m", "y_m", "z_m"):
        row[c] = repr(float(row[c]) * 1000.0)


def _drop_times(path: Path) -> None:
    """Keep only the x_m,y_m,z_m columns of a CSV pass file."""
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=["x_m", "y_m", "z_m"], extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def test_sphere_refuses_passes_that_turn_against_their_rate(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """A sign or unit of rate_deg_s that the points contradict is an error, not a latency.

    Every rate negated (a controller with the opposite convention) gave -tau with "rates
    agree"; one pass negated was pooled with the other sign; rad/s gave 57 x tau.
    """
    folder = copy_of(sim_folder, tmp_path)
    argv = ["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure"]
    _flip_rates(folder, lambda _row: True)
    code, out, err = run_cli(argv)
    assert_one_line_error(
        code, out, err, "every pass turns the other way", "pass_000.csv", "stated -6 deg/s",
        "shows +5.", "opposite of kinsync's", "negate rate_deg_s", "ENU",
    )  # fmt: skip
    _flip_rates(folder, lambda _row: True)
    _flip_rates(folder, lambda row: row["file"] == "pass_007.csv")  # one -18 deg/s pass
    code, out, err = run_cli(argv)
    assert_one_line_error(
        code, out, err, "1 of 12 passes turns the other way", "pass_007.csv",
        "stated +18 deg/s", "shows -1",
    )  # fmt: skip
    assert "pass_000.csv" not in err
    index = folder / "passes.csv"
    original = (sim_folder / "passes.csv").read_text(encoding="utf-8").splitlines()
    rad = [original[0]]
    for line in original[1:]:
        cells = line.split(",")
        cells[1] = repr(float(cells[1]) * np.pi / 180.0)
        rad.append(",".join(cells))
    index.write_text("\n".join(rad) + "\n", encoding="utf-8")
    code, out, err = run_cli(argv)
    assert_one_line_error(code, out, err, "look like rad/s", "give rate_deg_s in deg/s")


def test_sphere_refuses_points_in_enu(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """Points exported East-North-Up turn the other way about +Down: an error, not -tau."""
    folder = copy_of(sim_folder, tmp_path)
    for path in folder.glob("pass_*.csv"):
        _rewrite_rows(path, _to_enu)
    code, out, err = run_cli(["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure"])
    assert_one_line_error(code, out, err, "every pass turns the other way", "ENU")


def _raw_set(tmp_path: Path) -> tuple[Path, list[str]]:
    """A raw pass folder (10 deg/s, 2 passes each way) and the --raw command on it."""
    folder = tmp_path / "raw_set"
    sim = simulate_rotating_table(RotatingTableConfig(rates_deg_s=(10.0,), passes=2, seed=3))
    write_simulation(sim, folder, raw=True)
    return folder, ["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure", "--raw"]


def test_sphere_raw_refuses_an_attitude_that_turns_against_the_rates(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """With --raw the attitude log shows the table rate: a flipped sign or radians say so."""
    folder, argv = _raw_set(tmp_path)
    _flip_rates(folder, lambda _row: True)
    code, out, err = run_cli(argv)
    assert_one_line_error(
        code, out, err, "every pass turns the other way", "attitude.csv", "stated -10 deg/s",
        "shows +10 deg/s", "negate rate_deg_s",
    )  # fmt: skip
    _flip_rates(folder, lambda _row: True)
    log = folder / "raw" / "attitude.csv"
    lines = log.read_text(encoding="utf-8").splitlines()
    in_rad = [lines[0]]
    for line in lines[1:]:
        t, *angles = line.split(",")
        in_rad.append(",".join([t, *(repr(float(a) * np.pi / 180.0) for a in angles)]))
    log.write_text("\n".join(in_rad) + "\n", encoding="utf-8")
    code, out, err = run_cli(argv)
    assert_one_line_error(
        code, out, err, "57 times smaller", "radians", "shows +0.17", "stated +10 deg/s"
    )
    assert len(err) < 1000, err


def test_sphere_warns_when_the_rates_disagree(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    _flip_rates(
        folder, lambda row: abs(float(row["rate_deg_s"])) == 6.0
    )  # the 6 deg/s passes the wrong way
    for path in folder.glob("pass_*.csv"):  # without point times the sign cannot be checked
        _drop_times(path)
    code, out, err = run_cli(["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure"])
    assert code == 0, err
    assert "rates DISAGREE: chi2 " in out
    assert "rates agree" not in out
    warning = [line for line in err.splitlines() if "warning" in line]
    assert len(warning) == 2, err
    assert str(folder) in warning[0]
    assert "passes.csv" in warning[0]
    assert "the sign and unit of the table rates were not checked on 12 of 12" in warning[1]
    code, out, err = run_cli(
        ["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure", "--json"]
    )
    doc = json.loads(out)
    assert doc["consistency"]["rates_disagree"] is True
    assert doc["sigma_scale"] > 1.0
    assert doc["latency_std_ms"] == pytest.approx(
        doc["sigma_scale"] * doc["latency_formal_std_ms"], rel=1e-12
    )
    assert "the table rates disagree" in err


def test_sphere_missing_folder(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    code, out, err = run_cli(["latency", "sphere", str(tmp_path / "nowhere")])
    assert_one_line_error(code, out, err, "nowhere")


def test_sphere_only_one_rotation_sign(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    rewrite_index(folder, lambda r: float(r["rate_deg_s"]) > 0)
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(code, out, err, "both signs")


def test_sphere_zero_and_non_numeric_rate(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    text = (folder / "passes.csv").read_text().splitlines()
    first = text[1].split(",")
    first[1] = "0"
    (folder / "passes.csv").write_text("\n".join([text[0], ",".join(first), *text[2:]]) + "\n")
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(code, out, err, "passes.csv", "line 2")
    first[1] = "fast"
    (folder / "passes.csv").write_text("\n".join([text[0], ",".join(first), *text[2:]]) + "\n")
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(code, out, err, "passes.csv", "line 2", "fast")


def test_sphere_non_numeric_point(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    pass_file = sorted(folder.glob("pass_*.csv"))[0]
    lines = pass_file.read_text().splitlines()
    cells = lines[5].split(",")
    cells[0] = "x"
    lines[5] = ",".join(cells)
    pass_file.write_text("\n".join(lines) + "\n")
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(code, out, err, pass_file.name, "line 6")


def test_sphere_truncated_laz_pass(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = tmp_path / "laz"
    cfg = RotatingTableConfig(latency_s=TAU_S, rates_deg_s=(18.0,), passes=1, seed=4)
    write_simulation(simulate_rotating_table(cfg), folder, file_format="laz")
    path = folder / "pass_001.laz"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(code, out, err, "passes.csv: line 3", "pass_001.laz", "copy it again")


def test_sphere_pass_listed_twice(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    index = folder / "passes.csv"
    lines = index.read_text().splitlines()
    index.write_text("\n".join([*lines, lines[1]]) + "\n")
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(
        code, out, err, "passes.csv", f"listed twice (lines 2 and {len(lines) + 1})"
    )


def test_sphere_warns_of_unlisted_pass_files(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    left_out = Path(next(r["file"] for r in csv.DictReader((folder / "passes.csv").open())))
    rewrite_index(folder, lambda r: r["file"] != str(left_out), delete_dropped=False)
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure", "--json"])
    assert code == 0, err
    json.loads(out)
    assert f"kinsync: warning: {folder}: 1 file not listed in passes.csv" in err, err
    assert left_out.name in err


def test_sphere_reports_a_pass_without_the_sphere(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    centre = np.array(json.loads((folder / "truth.json").read_text())["sphere_center_ned_m"])
    rows = list(csv.DictReader((folder / "passes.csv").open()))
    name = next(r["file"] for r in rows if float(r["rate_deg_s"]) == -18.0)
    lines = (folder / name).read_text().splitlines()
    xyz = np.array([[float(v) for v in line.split(",")[:3]] for line in lines[1:]])
    far = np.linalg.norm(xyz - centre, axis=1) > 0.2
    (folder / name).write_text("\n".join([lines[0], *np.array(lines[1:])[far]]) + "\n")
    args = ["latency", "sphere", str(folder), "--no-figure", "--radius-m", "0.1"]
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["n_passes"] == len(rows)
    assert doc["n_passes_used"] == len(rows) - 1
    [rejected] = doc["rejected_passes"]
    assert rejected["file"] == str(folder / name)
    assert rejected["rate_deg_s"] == -18.0
    assert "no usable sphere" in rejected["reason"]
    code, out, err = run_cli(args)
    assert code == 0, err
    text = " ".join(out.split())
    assert f"rejected: {folder / name} (-18 deg/s): no usable sphere" in text, out
    assert f"passes used: {len(rows) - 1} of {len(rows)}" in text, out


def _strip_sphere(path: Path, centre: np.ndarray) -> None:
    """Remove every return within 0.2 m of the sphere centre from a CSV pass file."""
    lines = path.read_text().splitlines()
    xyz = np.array([[float(v) for v in line.split(",")[:3]] for line in lines[1:]])
    far = np.linalg.norm(xyz - centre, axis=1) > 0.2
    path.write_text("\n".join([lines[0], *np.array(lines[1:])[far]]) + "\n")


@pytest.mark.parametrize("case", ["no-sphere-at-minus", "radius-5"])
def test_sphere_failure_speaks_of_options_not_parameters(
    run_cli: RunCli,
    sim_folder: Path,
    tmp_path: Path,
    assert_one_line_error: OneLineError,
    case: str,
) -> None:
    # Were: "... did not converge in 50 iterations; raise max_iterations ..." and
    # "segment_sphere: origin_m lies inside the fitted sphere" (no such options).
    folder = copy_of(sim_folder, tmp_path)
    radius = "0.1"
    if case == "radius-5":
        radius = "5"
    else:
        centre = np.array(json.loads((folder / "truth.json").read_text())["sphere_center_ned_m"])
        for row in csv.DictReader((folder / "passes.csv").open()):
            if float(row["rate_deg_s"]) < 0:
                _strip_sphere(folder / row["file"], centre)
    code, out, err = run_cli(
        ["latency", "sphere", str(folder), "--no-figure", "--radius-m", radius]
    )
    assert_one_line_error(code, out, err, "no sphere", f"--radius-m, {radius} m", "in view")
    for internal in ("max_iterations", "origin_m", "segment_sphere", "fit_sphere"):
        assert internal not in err, err


def test_sphere_axis_pointing_at_the_sphere(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = copy_of(sim_folder, tmp_path)
    centre = np.array(json.loads((folder / "truth.json").read_text())["sphere_center_ned_m"])
    axis = centre / np.linalg.norm(centre)
    index = folder / "passes.csv"
    with index.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    with index.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["file", "rate_deg_s", "axis_n", "axis_e", "axis_d"])
        for r in rows:
            writer.writerow([r["file"], r["rate_deg_s"], *axis.tolist()])
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure", "--radius-m", "0.1"])
    assert_one_line_error(code, out, err, "unobservable")


def test_sphere_no_sphere_in_the_passes(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    folder = tmp_path / "floor"
    folder.mkdir()
    rng = np.random.default_rng(2)
    for name in ("a.csv", "b.csv"):
        pts = np.column_stack(
            [rng.uniform(1, 2, 2000), rng.uniform(-0.5, 0.5, 2000), np.full(2000, 0.4)]
        )
        np.savetxt(folder / name, pts, delimiter=",", header="x_m,y_m,z_m", comments="")
    (folder / "passes.csv").write_text("file,rate_deg_s\na.csv,6\nb.csv,-6\n")
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure", "--radius-m", "0.1"])
    assert_one_line_error(code, out, err, "sphere")


def _points_outside(folder: Path, box: list[float]) -> dict[str, int]:
    """Per pass file of ``folder``: its points outside ``box`` (xmin,...,zmax)."""
    out = {}
    for row in csv.DictReader((folder / "passes.csv").open()):
        xyz = np.loadtxt(folder / row["file"], delimiter=",", skiprows=1, usecols=(0, 1, 2))
        inside = np.all((xyz >= box[:3]) & (xyz <= box[3:]), axis=1)
        out[str(folder / row["file"])] = int((~inside).sum())
    return out


def test_sphere_region_of_interest_counts_the_points_it_leaves_out(
    run_cli: RunCli, sim_folder: Path
) -> None:
    centre = json.loads((sim_folder / "truth.json").read_text())["sphere_center_ned_m"]
    box = [*(np.array(centre) - 0.13), *(np.array(centre) + 0.13)]
    roi = ",".join(f"{v:.4f}" for v in box)
    box = [float(v) for v in roi.split(",")]
    args = ["latency", "sphere", str(sim_folder), "--no-figure", "--radius-m", "0.1"]
    code, out, err = run_cli([*args, "--roi-m", roi, "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert abs(doc["latency_ms"] - TAU_S * 1e3) < 4 * doc["latency_std_ms"]
    outside = _points_outside(sim_folder, box)
    assert doc["roi"]["box_ned_m"] == {"min": box[:3], "max": box[3:]}
    assert {p["file"]: p["n_points_excluded"] for p in doc["roi"]["passes"]} == outside
    assert doc["roi"]["n_points_excluded"] == sum(outside.values()) > 0
    n_read = doc["roi"]["n_points"]
    assert sum(r["n_points_in"] for r in doc["per_rate"]) == n_read - sum(outside.values())
    code, out, err = run_cli([*args, "--roi-m", roi])
    assert code == 0, err
    text = " ".join(out.split())
    assert "region of interest (--roi-m, table-centred NED)" in text, out
    assert f"{sum(outside.values())} of {n_read} points outside it, excluded" in text, out


@pytest.mark.parametrize(
    ("roi", "fragment"),
    [
        ("1,2,3", "expected 6 comma-separated numbers"),
        ("0,0,0,1,x,1", "item 5 ('x') is not a number"),
        ("0,2,0,1,1,1", "ymin 2.0 must be below ymax 1.0"),
        ("50,50,50,51,51,51", "keeps 0 of its"),
    ],
)
def test_sphere_bad_region_of_interest(
    run_cli: RunCli,
    sim_folder: Path,
    assert_one_line_error: OneLineError,
    roi: str,
    fragment: str,
) -> None:
    code, out, err = run_cli(
        ["latency", "sphere", str(sim_folder), "--no-figure", "--roi-m", roi, "--radius-m", "0.1"]
    )
    assert_one_line_error(code, out, err, "--roi-m", fragment)
    if fragment.startswith("keeps"):  # names a pass, and what to do
        assert "pass_000" in err
        assert "move or widen the box" in err


def test_sphere_no_admissible_sphere_names_the_region_of_interest_option(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    # Was: "... check the radius or the region of interest", which the command did not
    # offer.
    folder = tmp_path / "sparse"
    folder.mkdir()
    rng = np.random.default_rng(3)
    for name in ("a.csv", "b.csv"):
        pts = rng.uniform(0.0, 10.0, (40, 3))
        np.savetxt(folder / name, pts, delimiter=",", header="x_m,y_m,z_m", comments="")
    (folder / "passes.csv").write_text("file,rate_deg_s\na.csv,6\nb.csv,-6\n")
    args = ["latency", "sphere", str(folder), "--no-figure", "--radius-m", "0.1"]
    code, out, err = run_cli(args)
    assert_one_line_error(
        code,
        out,
        err,
        "admissible sphere",
        "give a region of interest around the sphere (roi_ned_m, --roi-m)",
    )
    code, out, err = run_cli([*args, "--roi-m", "0,0,0,10,10,10"])
    assert_one_line_error(
        code, out, err, "check that the region of interest (roi_ned_m, --roi-m) holds the sphere"
    )


def test_plan_json_and_figure(run_cli: RunCli, tmp_path: Path) -> None:
    fig = tmp_path / "plan.png"
    argv = ["latency", "plan", "--range-m", "1.5", "--radius-m", "0.1", "--range-noise-m", "0.002"]
    code, out, err = run_cli(
        [*argv, "--rates-deg-s", "2,6,18", "--passes", "15", "--figure", str(fig), "--json"]
    )
    assert code == 0, err
    doc = json.loads(out)
    sig = [r["latency_std_ms"] for r in doc["per_rate"]]
    assert sig[0] > sig[1] > sig[2]
    assert doc["latency_std_ms"] < 0.1
    assert doc["passes_for_target"] >= 1
    assert fig.read_bytes().startswith(b"\x89PNG")
    code, out, _ = run_cli([*argv, "--rates-deg-s", "2,6,18"])
    assert code == 0
    # what the centre sigma is (it was "centre σ (mm)" alone)
    assert "centre σ RMS (mm)" in out
    assert "one direction's passes pooled, RMS of 3 axes" in " ".join(out.split())
    assert re.search(
        r"\b(1 pass per rate and direction reaches|\d+ passes per rate and direction reach)\b", out
    )


def test_plan_counts_an_attitude_error_shared_by_a_pass(run_cli: RunCli) -> None:
    base = ["latency", "plan", "--rates-deg-s", "2,6,18", "--passes", "5", "--json"]
    code, out, _ = run_cli(base)
    assert code == 0
    plain = json.loads(out)
    code, out, _ = run_cli([*base, "--pass-attitude-error-deg", "0.003"])
    assert code == 0
    shared = json.loads(out)
    assert shared["pass_attitude_error_deg"] == 0.003
    # 200 simulated experiments of this design gave a spread of 0.071 ms (0.039 without).
    assert shared["latency_std_ms"] == pytest.approx(0.066, abs=0.005)
    assert plain["latency_std_ms"] == pytest.approx(0.040, abs=0.003)
    assert shared["passes_for_target"] > plain["passes_for_target"]


def test_plan_says_when_passes_alone_cannot_reach_the_target(run_cli: RunCli) -> None:
    """Was: "393258 passes per rate and direction reach 0.0001 ms", though --passes
    accepts at most 1000: the plan now says so and names the other levers."""
    argv = ["latency", "plan", "--rates-deg-s", "2,6,18"]
    code, out, err = run_cli([*argv, "--target-ms", "0.0001"])
    assert code == 0, err
    last = " ".join(out.split())
    assert "0.0001 ms cannot be reached by passes alone" in last
    assert "--passes allows at most 1000" in last
    for lever in ("closer or larger sphere", "finer angular step", "faster profile rate"):
        assert lever in last
    assert "faster table rates (--rates-deg-s, up to 369 deg/s here)" in last
    assert "per rate and direction reach 0.0001 ms" not in last
    code, out, err = run_cli([*argv, "--target-ms", "0.0001", "--json"])
    doc = json.loads(out)
    assert doc["passes_for_target"] > doc["passes_limit"] == 1000
    assert doc["target_within_passes_limit"] is False
    code, out, err = run_cli([*argv, "--target-ms", "0.05", "--json"])
    doc = json.loads(out)
    assert doc["target_within_passes_limit"] is True
    assert 1 <= doc["passes_for_target"] <= 1000


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--rates-deg-s", "2,,x"], "empty"),
        (["--rates-deg-s", "2,x"], "not a number"),
        (["--range-noise-m", "-0.002"], "--range-noise-m"),
        (["--passes", "0"], "passes"),
        (["--radius-m", "3"], "smaller"),
        # was "sphere_radius_m must be smaller than sphere_range_m"
        (["--range-m", "0.1"], "--radius-m 0.1 must be smaller than --range-m 0.1"),
        # was "range_noise_m must be positive", though the span said 0 to 1 m
        (["--range-noise-m", "0"], "--range-noise-m 0: outside the span kinsync accepts, 0.0001"),
    ],
)
def test_plan_bad_input(
    run_cli: RunCli, extra: list[str], fragment: str, assert_one_line_error: OneLineError
) -> None:
    code, out, err = run_cli(["latency", "plan", *extra])
    assert_one_line_error(code, out, err, fragment)


def test_sphere_raw_applies_the_mount_latency(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """--raw georeferences raw/ with the latency of raw/mount.toml: none is left to find.

    The latency reported is the total, the mount's plus what is left on top of it (it
    was the residual alone, printed as "latency").
    """
    folder = tmp_path / "raw_set"
    sim = simulate_rotating_table(RotatingTableConfig(rates_deg_s=(10.0,), passes=2, seed=3))
    write_simulation(sim, folder, raw=True)
    tau = float(sim.truth["latency_s"])
    mount_path = folder / "raw" / "mount.toml"
    write_mount(read_mount(mount_path).with_latency(tau), mount_path)
    argv = ["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure", "--json"]
    code, out, err = run_cli(argv)
    assert code == 0, err
    as_logged = json.loads(out)
    assert abs(as_logged["latency_ms"] - tau * 1e3) < 4 * as_logged["latency_std_ms"]
    code, out, err = run_cli([*argv, "--raw"])
    assert code == 0, err
    corrected = json.loads(out)
    assert abs(corrected["residual_latency_ms"]) < 4 * corrected["latency_std_ms"]
    assert tau * 1e3 > 10 * corrected["latency_std_ms"]
    assert corrected["mount_latency_ms"] == tau * 1e3
    total = corrected["mount_latency_ms"] + corrected["residual_latency_ms"]
    assert corrected["latency_ms"] == pytest.approx(total, rel=1e-12)
    assert abs(corrected["latency_ms"] - tau * 1e3) < 4 * corrected["latency_std_ms"]
    code, out, err = run_cli([*argv[:-1], "--raw"])
    assert code == 0, err
    assert f"latency {corrected['latency_ms']:.4f} ± " in out
    assert f"latency_s {tau * 1e3:.4f} ms was applied before the fit" in out
    code, out, err = run_cli(["latency", "sphere", str(sim_folder), "--raw", "--no-figure"])
    assert_one_line_error(code, out, err, "raw folder not found")


def test_sphere_raw_refuses_points_in_a_hole_of_the_attitude_log(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """Half a second of attitude missing in a pass: exit 2 naming the gap, no estimate."""
    folder = tmp_path / "raw_set"
    write_simulation(
        simulate_rotating_table(RotatingTableConfig(rates_deg_s=(10.0,), passes=2, seed=3)),
        folder,
        raw=True,
    )
    log = folder / "raw" / "attitude.csv"
    lines = log.read_text(encoding="utf-8").splitlines()
    t = np.array([float(ln.split(",")[0]) for ln in lines[1:]])
    mid = float(np.median(t[: t.size // 4]))  # inside the first pass
    kept = [ln for ln, tk in zip(lines[1:], t, strict=True) if abs(tk - mid) > 0.25]
    log.write_text("\n".join([lines[0], *kept]) + "\n", encoding="utf-8")
    argv = ["latency", "sphere", str(folder), "--raw", "--no-figure"]
    code, out, err = run_cli(argv)
    # the threshold used (10 median intervals of the log) and the option that sets it
    limit = 10.0 * float(np.median(np.diff(t[np.abs(t - mid) > 0.25])))
    assert_one_line_error(
        code, out, err, "pass_000.csv", "data gap of the attitude log", str(log),
        f"record intervals longer than {gap_threshold_shown_s(limit):.6g} s", "--max-gap-s",
    )  # fmt: skip
    # the half-second hole is legitimate here: a threshold above it reads across it
    code, out, err = run_cli([*argv, "--max-gap-s", "0.6", "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["n_passes_used"] == doc["n_passes"] >= 2
    # a threshold for the attitude log needs the attitude log
    code, out, err = run_cli([*argv[:3], "--no-figure", "--max-gap-s", "0.6"])
    assert_one_line_error(code, out, err, "--max-gap-s", "--raw")


@pytest.mark.parametrize(
    ("options", "fragments"),
    [
        (["--range-m", "100"], ("too few or too narrow a cap", "0.1 m at 100 m")),
        # 2 deg/s puts 11.5 returns on the sphere a pass on average, but a pass can miss it
        (["--profile-rate-hz", "0.1"], ("at 2 deg/s", "largest usable rate is 0.739 deg/s")),
        # as simulate rotating-table refuses it (it was planned, 0.0058 ms)
        (["--rates-deg-s", "2,400"], ("at 400 deg/s", "fewer than 10 returns", "369 deg/s")),
        (
            ["--angular-step-deg", "0.001", "--profile-rate-hz", "10000"],
            ("rays over the sphere", "too fine"),
        ),
    ],
)
def test_plan_refuses_designs_it_cannot_compute(
    run_cli: RunCli,
    assert_one_line_error: Callable[..., None],
    options: list[str],
    fragments: tuple[str, ...],
) -> None:
    """Within each option's span, a combination may still give a singular fit or an
    allocation of gigabytes: the planner says which before it allocates."""
    code, out, err = run_cli(["latency", "plan", *options])
    assert_one_line_error(code, out, err, *fragments)


def test_sphere_figure_and_no_figure_contradict(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    # --no-figure won silently: the figure asked for was not written.
    fig = tmp_path / "f1.png"
    argv = ["latency", "sphere", str(sim_folder), "--figure", str(fig), "--no-figure"]
    assert_one_line_error(*run_cli(argv), "--no-figure contradict")
    assert not fig.exists()


def test_a_pass_listed_twice_under_another_name_is_refused(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """A hard link (and a copy, a symbolic link) of a pass file listed as another pass was
    read as one more pass, exit 0: the latency moved by 9 us, or every pass twice
    made its sigma sqrt(2) too small."""
    folder = copy_of(sim_folder, tmp_path)
    index = (folder / "passes.csv").read_text(encoding="utf-8").splitlines()
    first = index[1].split(",")
    os.link(folder / first[0], folder / f"again_{first[0]}")
    rows = [*index, ",".join([f"again_{first[0]}", *first[1:]])]
    (folder / "passes.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    code, out, err = run_cli(["latency", "sphere", str(folder), "--no-figure"])
    assert_one_line_error(code, out, err, "recorded at the same time", f"again_{first[0]}")


def test_sphere_writes_the_latency_into_a_mount(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """--mount-out: the acquisition mount with the total latency and its sigma, for a
    calibration that holds the latency (`calibrate mount --estimate boresight`)."""
    acquisition = tmp_path / "acq.toml"
    # An earlier calibration's correlations: the latency's no longer hold once the
    # sphere measures it on its own; the lever arm's own do.
    names = ("lever_x_m", "lever_y_m", "latency_ms")
    rows = ((1.0, 0.3, -0.8), (0.3, 1.0, 0.1), (-0.8, 0.1, 1.0))
    lever = MountUncertainty(
        lever_arm_body_m=(0.01, 0.01, 0.02),
        latency_s=0.003,
        correlation=StdCorrelation(names, rows),
    )
    given = Mount(lever_arm_body_m=(0.1, 0.0, 0.2), latency_s=0.0, uncertainty=lever)
    write_mount(given, acquisition)
    header = "# Vehicle VX-12, scanner S/N 4711\n# surveyed 2026-11-02\n\n"
    acquisition.write_text(header + acquisition.read_text(encoding="utf-8"), encoding="utf-8")
    out = tmp_path / "measured.toml"
    argv = ["latency", "sphere", str(sim_folder), "--no-figure", "--mount", str(acquisition)]
    code, stdout, err = run_cli([*argv, "--mount-out", str(out), "--json"])
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["mount_out"] == str(out)
    # what produced it, and the acquisition mount's own header (it was dropped)
    first = out.read_text(encoding="utf-8").splitlines()[:7]
    assert first[0] == f"# written by {software()} at 2023-11-14T22:13:20Z"
    assert first[1] == f"# from {acquisition}"
    assert first[2].startswith("# command: kinsync latency sphere ")
    assert first[3] == f"# in {Path.cwd()}"
    assert first[4:7] == [
        "# acq.toml's header:", "# Vehicle VX-12, scanner S/N 4711", "# surveyed 2026-11-02"
    ]  # fmt: skip
    # With a mount, the split is always given (the README's keys), zero latency or not.
    assert doc["mount_latency_ms"] == 0.0
    assert doc["residual_latency_ms"] == doc["latency_ms"]
    measured = read_mount(out)
    assert measured.latency_s * 1e3 == pytest.approx(doc["latency_ms"], rel=1e-12)
    assert measured.uncertainty is not None
    std_s = measured.uncertainty.latency_s
    assert std_s is not None
    assert std_s * 1e3 == pytest.approx(doc["latency_std_ms"])
    assert measured.uncertainty.lever_arm_body_m == (0.01, 0.01, 0.02)  # kept
    kept = StdCorrelation(("lever_x_m", "lever_y_m"), ((1.0, 0.3), (0.3, 1.0)))
    assert measured.uncertainty.correlation == kept
    assert measured.lever_arm_body_m == given.lever_arm_body_m
    assert abs(measured.latency_s - TAU_S) < 4 * std_s
    # The passes georeferenced with 1 ms applied: the total adds it to the fitted latency.
    write_mount(replace(given, latency_s=0.001), acquisition)
    code, stdout, err = run_cli([*argv, "--json"])
    assert code == 0, err
    shifted = json.loads(stdout)
    assert shifted["mount_latency_ms"] == pytest.approx(1.0)
    assert shifted["latency_ms"] == pytest.approx(doc["latency_ms"] + 1.0, rel=1e-12)
    code, stdout, err = run_cli([*argv[:4], "--mount-out", str(tmp_path / "m.toml")])
    assert_one_line_error(code, stdout, err, "--mount-out", "give --mount")
    code, stdout, err = run_cli([*argv, "--raw"])
    assert_one_line_error(code, stdout, err, "with --raw that is FOLDER/raw/mount.toml")
    code, stdout, err = run_cli([*argv, "--mount-out", str(tmp_path / "m.json")])
    assert_one_line_error(code, stdout, err, "--mount-out", "TOML")
    code, stdout, err = run_cli([*argv, "--mount-out", str(acquisition)])
    assert_one_line_error(code, stdout, err, "acq.toml")
    assert read_mount(acquisition).latency_s == 0.001  # the input is never replaced


def test_sphere_points_in_millimetres_get_a_unit_hint_and_a_short_message(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """Points in mm: the reason names the unit, once per rate for two rates, then a count."""
    folder = copy_of(sim_folder, tmp_path)
    for path in folder.glob("pass_*.csv"):
        _rewrite_rows(path, _to_millimetres)
    code, out, err = run_cli(["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure"])
    assert_one_line_error(code, out, err, "millimetres or feet", "and 2 more signed rates")
    assert err.count("millimetres or feet") == 2, err


def test_sphere_says_when_the_rates_could_not_be_checked(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path
) -> None:
    # Without point times every rate negated gave -tau, and rad/s 57 times tau, each
    # with "rates agree": nothing said that the rates had not been checked.
    folder = copy_of(sim_folder, tmp_path)
    for path in folder.glob("pass_*.csv"):
        _drop_times(path)
    argv = ["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure"]
    code, out, err = run_cli(argv)
    assert code == 0, err
    assert "per-rate latencies agree: chi2 " in out
    assert "(rates' sign and unit not checked)" in out
    assert "rates agree" not in out
    (warning,) = [line for line in err.splitlines() if "warning" in line]
    assert "the sign and unit of the table rates were not checked on 12 of 12 passes" in warning
    code, out, err = run_cli([*argv, "--json"])
    doc = json.loads(out)
    assert doc["consistency"]["n_passes_rate_checked"] == 0
    assert any("were not checked on 12 of 12" in w for w in doc["warnings"])
    code, out, err = run_cli(
        ["latency", "sphere", str(sim_folder), "--radius-m", "0.1", "--no-figure", "--json"]
    )
    doc = json.loads(out)
    assert doc["consistency"]["n_passes_rate_checked"] == 12
    assert not any("not checked" in w for w in doc["warnings"])


def test_sphere_refuses_a_wrong_axis_and_shows_the_model_chi2(
    run_cli: RunCli, sim_folder: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    # A North axis for the vertical table gave -0.09 +- 0.04 ms (truth 4.21), "per-rate
    # latencies agree" and exit 0: the centres' misfit to the rotation (chi2 ~800 on
    # 2 dof) was computed but neither tested nor shown.
    argv = ["latency", "sphere", "--radius-m", "0.1", "--no-figure"]
    code, out, err = run_cli([*argv[:2], str(sim_folder), *argv[2:]])
    assert code == 0, err
    assert "model χ²" in out
    folder = copy_of(sim_folder, tmp_path)
    index = folder / "passes.csv"
    lines = index.read_text(encoding="utf-8").splitlines()
    north = [
        lines[0],
        *(",".join([*line.split(",")[:2], "1.0", "0.0", "0.0"]) for line in lines[1:]),
    ]
    index.write_text("\n".join(north) + "\n", encoding="utf-8")
    code, out, err = run_cli([*argv[:2], str(folder), *argv[2:]])
    assert_one_line_error(
        code, out, err, "do not fit a rotation about the stated table axis",
        "rotation-model chi2", "at 6 deg/s", "axis in passes.csv", "table-centred",
    )  # fmt: skip


def _scale_rates(folder: Path, factor: float) -> None:
    """Multiply every signed rate in passes.csv by ``factor``."""
    index = folder / "passes.csv"
    lines = index.read_text(encoding="utf-8").splitlines()
    scaled = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        cells[1] = repr(float(cells[1]) * factor)
        scaled.append(",".join(cells))
    index.write_text("\n".join(scaled) + "\n", encoding="utf-8")


def test_sphere_raw_refuses_a_rate_the_attitude_log_contradicts_by_a_few_percent(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    # Rates in gon/s (11 % high) gave 3.84 +- 0.04 ms for 4.21 with exit 0: only a factor 2
    # was refused, though the log measures each pass's rate to about 0.01 %.
    folder, argv = _raw_set(tmp_path)
    _scale_rates(folder, 400.0 / 360.0)
    code, out, err = run_cli(argv)
    assert_one_line_error(
        code, out, err, "more than 2 % off the rate the attitude log attitude.csv shows",
        "stated +11.11 deg/s, shows +10 deg/s (+11.1 %)", "gon/s", "passes.csv",
    )  # fmt: skip
    _scale_rates(folder, 1.01 * 360.0 / 400.0)  # 1 % off: within the tolerance
    code, out, err = run_cli(argv)
    assert code == 0, err


def test_sphere_warns_of_a_radius_the_points_contradict(run_cli: RunCli, sim_folder: Path) -> None:
    argv = ["latency", "sphere", str(sim_folder), "--no-figure", "--json", "--radius-m"]
    code, out, err = run_cli([*argv, "0.13"])  # the sphere's radius is 0.1 m
    assert code == 0, err
    warnings = json.loads(out)["warnings"]
    assert any("--radius-m, 0.13 m) is contradicted by the points" in w for w in warnings)
    code, out, err = run_cli([*argv, "0.1"])
    assert not any("radius" in w for w in json.loads(out)["warnings"])
