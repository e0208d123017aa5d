"""Reading a survey's files into scan lines for the mount calibration, and writing its
outputs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from kinsync.calibration.estimator import CalibrationOptions
from kinsync.errors import InputError
from kinsync.io.mount_file import read_mount
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.pipelines.calibration import calibrate_files, read_scan_lines
from kinsync.sim.patch_config import PatchTestConfig
from kinsync.sim.patch_test import PatchTestSimulation, simulate_patch_test, write_patch_test

CIDCO = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "cidco-port-de-quebec"


@pytest.fixture(scope="module")
def survey(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, PatchTestSimulation]:
    sim = simulate_patch_test(
        # density 0.02: at 0.01 lines 3 and 4 shared no patch with another line (the
        # jackknife over "4 lines" then had two that contributed nothing)
        PatchTestConfig(scenario="vehicle", density=0.02, passes_per_direction=1, seed=4)
    )
    folder = tmp_path_factory.mktemp("survey")
    write_patch_test(sim, folder)
    return folder, sim


def test_las_lines_and_sbet_come_back_on_gps_time(survey: tuple[Path, PatchTestSimulation]) -> None:
    folder, sim = survey
    laz = sorted(folder.glob("line_*.laz"))
    lines = read_scan_lines(laz, [folder / "trajectory.out"], gps_week=sim.gps_week)
    assert [ln.name for ln in lines] == [p.name for p in laz]
    for got, want in zip(lines, sim.lines, strict=True):
        assert np.allclose(got.t_s, want.t_s, atol=1e-6, rtol=0.0)
        assert np.allclose(got.xyz_scanner_m, want.xyz_scanner_m, atol=1e-4, rtol=0.0)
        assert got.trajectory is lines[0].trajectory  # one trajectory read once


def test_csv_and_parquet_lines_with_one_trajectory_each(
    survey: tuple[Path, PatchTestSimulation], tmp_path: Path
) -> None:
    _, sim = survey
    a, b = sim.lines[0], sim.lines[1]
    csv = tmp_path / "a.csv"
    np.savetxt(csv, np.column_stack([a.t_s, a.xyz_scanner_m]), delimiter=",",
               header="t_s,x_m,y_m,z_m", comments="", fmt="%.9f")  # fmt: skip
    parquet = tmp_path / "b.parquet"
    table = {"t_s": b.t_s, "x_m": b.xyz_scanner_m[:, 0], "y_m": b.xyz_scanner_m[:, 1],
             "z_m": b.xyz_scanner_m[:, 2]}  # fmt: skip
    pq.write_table(pa.table(table), parquet)
    trajs = []
    for i, line in enumerate((a, b)):
        path = tmp_path / f"traj{i}.csv"
        write_trajectory_csv(line.trajectory, path)
        trajs.append(path)
    lines = read_scan_lines([csv, parquet], trajs)
    assert np.allclose(lines[0].xyz_scanner_m, a.xyz_scanner_m, atol=1e-8)
    assert np.array_equal(lines[1].t_s, b.t_s)
    assert lines[0].trajectory is not lines[1].trajectory


def test_same_file_names_in_two_folders_stay_apart(
    survey: tuple[Path, PatchTestSimulation], tmp_path: Path
) -> None:
    folder, sim = survey
    for sub in ("day1", "day2"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "line.laz").write_bytes((folder / "line_01.laz").read_bytes())
    lines = read_scan_lines(
        [tmp_path / "day1" / "line.laz", tmp_path / "day2" / "line.laz"],
        [folder / "trajectory.out"],
        gps_week=sim.gps_week,
    )
    assert lines[0].name != lines[1].name


@pytest.mark.parametrize(
    ("case", "words"),
    [("no points", "at least one points file"), ("two of three", "2 trajectories for 3"),
     ("empty", "no returns"), ("suffix", "unknown points file type")],
)  # fmt: skip
def test_bad_files(
    survey: tuple[Path, PatchTestSimulation], tmp_path: Path, case: str, words: str
) -> None:
    folder, sim = survey
    laz = sorted(folder.glob("line_*.laz"))
    sbet = folder / "trajectory.out"
    empty = tmp_path / "empty.csv"
    empty.write_text("t_s,x_m,y_m,z_m\n")
    args = {
        "no points": ([], [sbet]),
        "two of three": (laz[:3], [sbet, sbet]),
        "empty": ([empty, laz[0]], [sbet]),
        "suffix": ([tmp_path / "x.ply"], [sbet]),
    }[case]
    with pytest.raises(InputError, match=words):
        read_scan_lines(*args, gps_week=sim.gps_week)


def test_calibrate_files_writes_the_mount_and_the_report(
    survey: tuple[Path, PatchTestSimulation], tmp_path: Path
) -> None:
    folder, sim = survey
    written: list[Path] = []
    reports: list[tuple[float, str]] = []

    def report(_result: object, path: Path) -> None:
        path.write_text("certificate")
        written.append(path)

    run = calibrate_files(
        sorted(folder.glob("line_*.laz")),
        [folder / "trajectory.out"],
        read_mount(folder / "mount.toml"),
        CalibrationOptions(estimate=("boresight",)),
        gps_week=sim.gps_week,
        mount_out=tmp_path / "new.toml",
        report_out=tmp_path / "cert.html",
        write_report=report,
        progress=lambda fraction, stage: reports.append((fraction, stage)),
    )
    assert run.n_points == sum(len(ln) for ln in sim.lines)
    assert read_mount(tmp_path / "new.toml") == run.result.mount
    assert written == [tmp_path / "cert.html"]
    fractions, stages = [f for f, _ in reports], [s for _, s in reports]
    assert fractions == sorted(fractions)  # kinsync.progress: never decreasing, 1 at the end
    assert (fractions[0], fractions[-1]) == (0.0, 1.0)
    assert stages[0].startswith("reading 4 point files")
    assert run.result.rejected_lines == ()
    assert "jackknife: 4 solutions, each leaving one out, " in "".join(stages)
    assert [s for s in stages if " done (without " in s] == [
        f"jackknife: {j} of 4 done (without line_0{j}.laz)" for j in range(1, 5)
    ]
    in_jackknife = [f for f, s in reports if " done (without " in s]
    assert in_jackknife == sorted(set(in_jackknife))  # each deleted-line solution advances


@pytest.mark.skipif(not CIDCO.is_dir(), reason="CIDCO data not in ../shared")
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan])
def test_a_gap_threshold_that_is_no_positive_number_is_refused(bad: float) -> None:
    with pytest.raises(InputError, match="max-gap-s"):
        CalibrationOptions(max_gap_s=bad)


def test_cidco_pass_files_carry_their_trajectory() -> None:
    paths = sorted(CIDCO.glob("sphere*/passage_*.txt"))[:3]
    lines = read_scan_lines(paths, [])
    assert [ln.name for ln in lines] == [f"{p.parent.name}/{p.stem}" for p in paths]
    for line in lines:
        assert line.trajectory.t_start_s <= line.t_s.min() <= line.t_s.max()
        assert line.t_s.max() <= line.trajectory.t_end_s
    with pytest.raises(InputError, match="carry their own trajectory"):
        read_scan_lines(paths, [paths[0]])


def test_a_non_finite_return_is_named_by_its_file_line_or_row(
    survey: tuple[Path, PatchTestSimulation], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """It was "line 'a.csv': return 1 has a non-finite ..." (0-based, no column)."""
    from kinsync.pipelines import calibration  # noqa: PLC0415

    monkeypatch.setattr(calibration, "_CHUNK", 3)  # the bad row lies past the first chunk
    folder, sim = survey
    a = sim.lines[0]
    table = np.column_stack([a.t_s[:8], a.xyz_scanner_m[:8]]).tolist()
    rows = [",".join(repr(v) for v in row) for row in table]
    rows[6] = rows[6].rsplit(",", 1)[0] + ",nan"
    path = tmp_path / "a.csv"
    path.write_text("t_s,x_m,y_m,z_m\n" + rows[0] + "\n\n" + "\n".join(rows[1:]) + "\n")
    sbet = [folder / "trajectory.out"]
    with pytest.raises(InputError, match=r"a\.csv: line 9, column 'z_m': nan is not finite; 1 "):
        read_scan_lines([path], sbet, gps_week=sim.gps_week)
    cols = {"t_s": a.t_s[:8], **{c: a.xyz_scanner_m[:8, j] for j, c in enumerate(("x_m", "y_m"))}}
    z = a.xyz_scanner_m[:8, 2].copy()
    z[7] = np.inf
    pq.write_table(pa.table(cols | {"z_m": z}), tmp_path / "b.parquet", row_group_size=3)
    with pytest.raises(InputError, match=r"b\.parquet: row 8 of 8, column 'z_m': inf is not"):
        read_scan_lines([tmp_path / "b.parquet"], sbet, gps_week=sim.gps_week)


def test_a_georeferenced_las_line_is_named_by_its_file_point_and_column(
    survey: tuple[Path, PatchTestSimulation], tmp_path: Path
) -> None:
    """UTM coordinates where scanner ones belong: it was "georeference: point at index 0
    (0-based, of N), x: ..." from deep in the solve, naming no file."""
    import laspy  # noqa: PLC0415
    import pyproj  # noqa: PLC0415

    folder, sim = survey
    src = sorted(folder.glob("line_*.laz"))[0]
    las = laspy.read(src)
    x, y, z = np.asarray(las.x) + 330_000.0, np.asarray(las.y) + 5_190_000.0, np.asarray(las.z)
    las.header.offsets = np.array([330_000.0, 5_190_000.0, 0.0])
    las.header.add_crs(pyproj.CRS.from_epsg(32619))
    las.x, las.y, las.z = x, y, z
    utm = tmp_path / "utm.laz"
    las.write(utm)
    with pytest.raises(InputError) as err:
        read_scan_lines([utm], [folder / "trajectory.out"], gps_week=sim.gps_week)
    text = str(err.value)
    assert text.startswith(f"{utm}: point 1 of {len(x)}, column 'x': scanner coordinates [")
    assert "beyond the 100000 m any laser scanner reaches" in text
    assert f"{len(x)} such point(s) in the file" in text
    assert text.endswith(
        "this file is already georeferenced (EPSG:32619); --points takes points in the "
        "scanner frame"
    )
