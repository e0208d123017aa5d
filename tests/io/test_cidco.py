"""CIDCO LidarToolkit pass reader, scan lines for the calibration, and sphere fits on the
12 real Port de Québec passes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from kinsync.calibration.lines import ScanLine
from kinsync.errors import InputError
from kinsync.fit import SphereFit, segment_sphere
from kinsync.frames import (
    ecef_to_geodetic,
    ecef_to_ned,
    euler_rpy_to_matrix,
    geodetic_to_ecef,
    rotation_ned_to_ecef,
)
from kinsync.georef.kernel import georeference
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.io.cidco import (
    ACQUISITION_MOUNT,
    CIDCO_COLUMNS,
    CIDCO_LINE_PERIOD_S,
    DEFAULT_PAD_S,
    CidcoPass,
    cidco_attitude_rpy_rad,
    cidco_return_times,
    cidco_scan_line,
    cidco_vessel_position_ecef_m,
    read_cidco_lines,
    read_cidco_pass,
)
from kinsync.mount import Mount
from kinsync.report.fit_figures import sphere_residual_figure

DATA_DIR = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "cidco-port-de-quebec"
PASS_FILES = sorted(DATA_DIR.glob("sphere*/passage_*.txt")) if DATA_DIR.is_dir() else []
needs_data = pytest.mark.skipif(
    len(PASS_FILES) != 12,
    reason=f"CIDCO Port de Québec data (12 pass files) not found under {DATA_DIR}",
)

RADIUS_BOUNDS_M = (0.1, 0.4)
NOMINAL_RADIUS_M = 0.2


# --------------------------------------------------------------------------- reader


def _line(values: list[float]) -> str:
    return " ".join(f"{v:.10f}" for v in values)


def test_reader_names_every_column(tmp_path: Path) -> None:
    rows = [[float(10 * r + c) for c in range(CIDCO_COLUMNS)] for r in range(3)]
    path = tmp_path / "passage_1.txt"
    path.write_text("\n".join(_line(r) for r in rows) + "\n\n")
    p = read_cidco_pass(path)
    data = np.array(rows)
    assert p.n_points == 3
    assert p.source == str(path)
    np.testing.assert_array_equal(p.points_ecef_m, data[:, 0:3])
    np.testing.assert_array_equal(p.points_local_m, data[:, 3:6])
    np.testing.assert_array_equal(p.intensity, data[:, 6])
    np.testing.assert_array_equal(p.t_lidar_s, data[:, 7])
    np.testing.assert_array_equal(p.points_lidar_m, data[:, 8:11])
    np.testing.assert_array_equal(p.heading_deg, data[:, 11])
    np.testing.assert_array_equal(p.pitch_deg, data[:, 12])
    np.testing.assert_array_equal(p.roll_deg, data[:, 13])
    np.testing.assert_array_equal(p.lat_deg, data[:, 14])
    np.testing.assert_array_equal(p.lon_deg, data[:, 15])
    np.testing.assert_array_equal(p.h_m, data[:, 16])
    np.testing.assert_allclose(p.range_m, np.linalg.norm(data[:, 8:11], axis=1))
    with pytest.raises(ValueError, match="read-only"):
        p.points_ecef_m[0, 0] = 0.0


def test_a_utf8_byte_order_mark_is_skipped(tmp_path: Path) -> None:
    """Windows editors start a file with one; every CSV reader skipped it, this one read
    "line 1, column 1: '\\ufeff1409120.09' is not a number"."""
    rows = [[float(10 * r + c) for c in range(CIDCO_COLUMNS)] for r in range(2)]
    path = tmp_path / "passage_1.txt"
    path.write_bytes(b"\xef\xbb\xbf" + ("\n".join(_line(r) for r in rows) + "\n").encode())
    p = read_cidco_pass(path)
    np.testing.assert_array_equal(p.points_ecef_m, np.array(rows)[:, 0:3])


def test_a_byte_that_is_not_utf8_is_named_by_its_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.txt"
    path.write_bytes((_line([1.0] * 17) + "\n\n").encode() + b"1 " * 16 + b"caf\xe9\n")
    with pytest.raises(InputError) as exc:
        read_cidco_pass(path)
    assert str(exc.value).startswith(f"{path}: line 3: byte 0xE9 is not UTF-8 text")


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("", "no data"),
        ("   \n\n", "no data"),
        (_line([1.0] * 17) + "\n" + _line([1.0] * 16) + "\n", "line 2 has 16 numbers, expected 17"),
        (_line([1.0] * 18) + "\n", "line 1 has 18 numbers, expected 17"),
        (_line([1.0] * 17) + "\n" + "1 " * 16 + "x\n", "line 2, column 17: 'x' is not a number"),
        (_line([1.0] * 17) + "\n" + "1 " * 16 + "nan\n", "line 2, column 17: non-finite"),
        # numpy skipped a '#' line as a comment, and the lines after it were misnumbered
        (_line([1.0] * 17) + "\n# pause\n" + _line([1.0] * 17) + "\n", "line 2"),
    ],
)
def test_reader_bad_files(tmp_path: Path, text: str, fragment: str) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(InputError, match=fragment) as exc:
        read_cidco_pass(path)
    assert str(path) in str(exc.value)


def test_reader_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="file not found"):
        read_cidco_pass(tmp_path / "none.txt")


# --------------------------------------------------------------------------- real data


@dataclass(frozen=True)
class PassFits:
    name: str
    data: CidcoPass
    free: SphereFit
    fixed: SphereFit


@pytest.fixture(scope="module")
def pass_fits() -> list[PassFits]:
    out = []
    for path in PASS_FILES:
        data = read_cidco_pass(path)
        free = segment_sphere(data.points_ecef_m, radius_bounds_m=RADIUS_BOUNDS_M)
        fixed = segment_sphere(data.points_ecef_m, radius_m=NOMINAL_RADIUS_M)
        out.append(PassFits(f"{path.parent.name}/{path.stem}", data, free, fixed))
    return out


def _table(fits: list[PassFits]) -> str:
    head = (
        f"{'pass':<20} {'N':>4} | {'free R (m)':>10} {'sR(mm)':>6} {'n':>4} {'RMS(mm)':>7} "
        f"{'sc(mm)':>6} | {'fixed n':>7} {'RMS(mm)':>7} {'sc(mm)':>6} | {'|dc| (mm)':>9}"
    )
    lines = [head, "-" * len(head)]
    lines.extend(
        f"{f.name:<20} {f.data.n_points:>4} | {f.free.radius_m:>10.4f} "
        f"{f.free.radius_std_m * 1e3:>6.1f} {f.free.n_points:>4} "
        f"{f.free.residual_rms_m * 1e3:>7.1f} "
        f"{np.linalg.norm(f.free.center_std_m) * 1e3:>6.1f} | {f.fixed.n_points:>7} "
        f"{f.fixed.residual_rms_m * 1e3:>7.1f} "
        f"{np.linalg.norm(f.fixed.center_std_m) * 1e3:>6.1f} | "
        f"{np.linalg.norm(f.free.center_m - f.fixed.center_m) * 1e3:>9.1f}"
        for f in fits
    )
    return "\n".join(lines)


@needs_data
def test_every_pass_gets_a_sphere(pass_fits: list[PassFits]) -> None:
    table = _table(pass_fits)
    # The table is this test's report (captured; shown with -rP or on failure).
    print(  # noqa: T201
        "\nCIDCO Port de Québec, ECEF, free radius in (0.1, 0.4) m vs fixed 0.2 m "
        "(sc = norm of the centre standard deviations)\n" + table
    )
    assert len(pass_fits) == 12
    for f in pass_fits:
        for fit in (f.free, f.fixed):
            assert np.all(np.isfinite(fit.center_m)), f.name
            assert np.all(np.isfinite(fit.cov_center_m2)), f.name
            assert np.all(np.linalg.eigvalsh(fit.cov_center_m2) > 0.0), f"{f.name}\n{table}"
            assert fit.n_points >= 0.8 * f.data.n_points, f"{f.name}: too few inliers\n{table}"
        assert f.fixed.radius_m == NOMINAL_RADIUS_M
        assert 0.15 <= f.free.radius_m <= 0.32, f"{f.name}: free radius\n{table}"
        # README: 3-15 mm RMS for a free fit of all returns; after outlier rejection the
        # best passes reach 1.5 mm, and the fixed 0.2 m radius misfits the distorted
        # sphere1/passage_3 (free radius 0.28 m) at ~26 mm.
        assert 0.001 <= f.free.residual_rms_m <= 0.020, f"{f.name}: free RMS\n{table}"
        assert 0.001 <= f.fixed.residual_rms_m <= 0.030, f"{f.name}: fixed RMS\n{table}"


@needs_data
@pytest.mark.parametrize("sphere", ["sphere1", "sphere2"])
@pytest.mark.parametrize("kind", ["free", "fixed"])
def test_passes_of_one_sphere_agree(pass_fits: list[PassFits], sphere: str, kind: str) -> None:
    centres = np.array([getattr(f, kind).center_m for f in pass_fits if f.name.startswith(sphere)])
    assert len(centres) == 6
    median = np.median(centres, axis=0)
    offsets_m = np.linalg.norm(centres - median, axis=1)
    # The mount calibration of the acquisition was not final (README: ~0.2 m scatter):
    # passes in opposite directions are offset by up to ~0.45 m from the median.
    assert offsets_m.max() < 0.5, f"{sphere} {kind}: offsets from the median {offsets_m} m"
    assert np.std(centres, axis=0).max() < 0.3, f"{sphere} {kind}: {np.std(centres, axis=0)}"
    # and the two targets are distinct objects
    other = [getattr(f, kind).center_m for f in pass_fits if not f.name.startswith(sphere)]
    assert np.linalg.norm(np.median(other, axis=0) - median) > 2.0


@needs_data
def test_residual_figure_of_real_passes(pass_fits: list[PassFits]) -> None:
    picked = pass_fits[:2]
    fits = [(f"{f.name} {k}", getattr(f, k)) for f in picked for k in ("free", "fixed")]
    points = [f.data.points_ecef_m for f in picked for _ in ("free", "fixed")]
    png = sphere_residual_figure(fits, points)
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    assert len(png) > 10_000


# --------------------------------------------------------------------------- synthetic passes

_LAT0_DEG, _LON0_DEG, _H0_M = 46.8191, -71.1992, -28.04
_SPEED_N_M_S, _SPEED_E_M_S = -0.5, 2.1
_STEP_DEG = 360.0 / 10240.0


@dataclass(frozen=True)
class SyntheticPass:
    rows: np.ndarray  # (N, 17), as written
    t_true_s: np.ndarray  # (N,)
    line_number: np.ndarray  # (N,)
    vessel_ecef_m: np.ndarray  # (N, 3)


def _f32(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.float32).astype(np.float64)


def _synthetic_pass(
    *,
    t0_s: float = 76900.0123,
    lines: tuple[int, ...] = (0, 1, 2, 4, 5, 6),
    float32_stamps: bool = True,
) -> SyntheticPass:
    """Returns of a profiler (one turn per 20 ms line) georeferenced as the acquisition did.

    The vessel moves at 2.2 m/s, heading 100 deg, trimmed 2 deg and pitching / rolling;
    columns 4-17 are 32-bit floats as in the real files, columns 1-3 full precision.
    """
    n_of, phi_deg = [], []
    for k in lines:
        phi = 10.0 - 0.05 * k + _STEP_DEG * np.arange(25)
        n_of.append(np.full(phi.size, k))
        phi_deg.append(phi)
    n = np.concatenate(n_of)
    phi = np.radians(np.concatenate(phi_deg))
    t = t0_s + CIDCO_LINE_PERIOD_S * (n + np.degrees(phi) / 360.0)
    dt = t - t0_s
    r = 20.0 + 0.05 * np.sin(40.0 * phi)
    lidar = _f32(np.column_stack([2.5e-4 * r, r * np.cos(phi), r * np.sin(phi)]))
    heading = _f32(100.0 + 0.8 * dt)
    pitch = _f32(2.0 + 3.0 * dt - 4.0 * dt**2)
    roll = _f32(0.4 - 1.2 * dt)
    lat = _LAT0_DEG + np.degrees(_SPEED_N_M_S * dt / 6.367e6)
    lon = _LON0_DEG + np.degrees(_SPEED_E_M_S * dt / (6.39e6 * np.cos(np.radians(_LAT0_DEG))))
    h = _f32(_H0_M + 0.01 * np.sin(20.0 * dt))
    vessel = geodetic_to_ecef(lat, lon, h)
    R_bn = euler_rpy_to_matrix(np.radians(roll), -np.radians(pitch), np.radians(heading))
    body = ACQUISITION_MOUNT.lever_arm_body_m_array + lidar @ ACQUISITION_MOUNT.R_scanner_to_body.T
    ned = np.einsum("nij,nj->ni", R_bn, body)
    points = vessel + np.einsum("nij,nj->ni", rotation_ned_to_ecef(lat, lon), ned)
    stamps = _f32(t) if float32_stamps else t
    rows = np.column_stack(
        [
            points,
            _f32(np.zeros((t.size, 3))),
            _f32(np.full(t.size, 1000.0)),
            stamps,
            lidar,
            heading,
            pitch,
            roll,
            _f32(lat),
            _f32(lon),
            h,
        ]
    )
    return SyntheticPass(rows, t, n, vessel)


def _write(path: Path, rows: np.ndarray, head: str = "") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(head + "\n".join(" ".join(repr(float(v)) for v in row) for row in rows) + "\n")
    return path


def test_synthetic_pass_times_trajectory_and_reproduction(tmp_path: Path) -> None:
    syn = _synthetic_pass()
    p = read_cidco_pass(_write(tmp_path / "sphere1" / "passage_1.txt", syn.rows))
    timing = cidco_return_times(p)
    # Times: the true ones up to one constant, which column 8's 32-bit rounding bounds.
    shift = timing.t_s - syn.t_true_s
    assert np.ptp(shift) < 1e-9
    assert abs(shift[0]) <= 2.0**-8
    lo, hi = timing.t0_interval_s
    assert lo <= timing.t0_s <= hi
    np.testing.assert_array_equal(timing.line_number, syn.line_number)  # line 3 is missing
    assert timing.n_lines == 6
    # The vessel reference point is recovered exactly from columns 1-3.
    np.testing.assert_allclose(cidco_vessel_position_ecef_m(p), syn.vessel_ecef_m, atol=1e-6)
    line = cidco_scan_line(p, attitude="acquisition")
    assert isinstance(line, ScanLine)
    assert line.name == "sphere1/passage_1"
    np.testing.assert_array_equal(line.xyz_scanner_m, p.points_lidar_m)
    traj = line.trajectory
    assert traj.t_start_s == pytest.approx(line.t_start_s - DEFAULT_PAD_S)
    assert traj.t_end_s == pytest.approx(line.t_end_s + DEFAULT_PAD_S)
    out, inside = georeference(
        line.t_s, line.xyz_scanner_m, GeorefTrajectory.from_trajectory(traj), ACQUISITION_MOUNT
    )
    assert inside.all()
    np.testing.assert_allclose(out, p.points_ecef_m, rtol=0, atol=2e-5)
    # The DIN attitude is the same but for the sign of the pitch.
    din = cidco_scan_line(p, name="x", pad_s=0.0)
    assert din.name == "x"
    assert din.trajectory.t_start_s == line.t_start_s
    np.testing.assert_array_equal(din.t_s, line.t_s)
    rpy_din = din.trajectory.euler_rpy_rad()
    rpy_acq = traj.euler_rpy_rad()[1:-1]
    np.testing.assert_allclose(rpy_din[:, [0, 2]], rpy_acq[:, [0, 2]], atol=1e-12)
    np.testing.assert_allclose(rpy_din[:, 1], -rpy_acq[:, 1], atol=1e-12)


def test_synthetic_pass_full_precision_stamps(tmp_path: Path) -> None:
    syn = _synthetic_pass(float32_stamps=False)
    p = read_cidco_pass(_write(tmp_path / "passage_1.txt", syn.rows))
    timing = cidco_return_times(p)
    np.testing.assert_allclose(timing.t_s, syn.t_true_s, rtol=0, atol=1e-9)
    assert np.isnan(timing.t0_interval_s[0])


def test_read_cidco_lines_orders_passes_naturally(tmp_path: Path) -> None:
    syn = _synthetic_pass()
    for sphere, passage in (("sphere2", 1), ("sphere1", 10), ("sphere1", 2)):
        _write(tmp_path / sphere / f"passage_{passage}.txt", syn.rows)
    (tmp_path / "sphere1" / "notes.txt").write_text("not a pass\n")
    lines = read_cidco_lines(tmp_path, pad_s=0.05)
    assert [ln.name for ln in lines] == [
        "sphere1/passage_2",
        "sphere1/passage_10",
        "sphere2/passage_1",
    ]
    assert lines[0].trajectory.t_start_s == pytest.approx(lines[0].t_start_s - 0.05)


def _bad_pass_rows(kind: str) -> tuple[np.ndarray, int]:
    """Rows broken in one way, and the index of the row the error must name."""
    syn = _synthetic_pass(float32_stamps=kind != "misfit")
    rows = syn.rows.copy()
    if kind == "origin":
        rows[7, 9:11] = 0.0
        return rows, 7
    if kind == "misfit":
        rows[30, 7] += 0.003
        return rows, 30
    if kind == "order":  # the third line (rows 50-74) before the second
        return np.vstack([rows[:25], rows[50:75], rows[25:50], rows[75:]]), 50
    assert kind == "coarse"
    rows[:, 7] = _f32(rows[:, 7] + 300_000.0)
    return rows, 0


@pytest.mark.parametrize(
    ("kind", "fragment"),
    [
        ("origin", "at the origin: no scan angle"),
        ("misfit", "ms from the time rebuilt for a 50 Hz profiler"),
        ("order", "does not advance by a line period"),
        ("coarse", "too coarse to number 50 Hz scan lines"),
    ],
)
def test_scan_line_bad_passes(tmp_path: Path, kind: str, fragment: str) -> None:
    rows, bad_row = _bad_pass_rows(kind)
    path = _write(tmp_path / "bad.txt", rows, head="\n")  # a blank first line
    p = read_cidco_pass(path)
    with pytest.raises(InputError, match=fragment) as exc:
        cidco_scan_line(p)
    assert str(path) in str(exc.value)
    if kind != "coarse":
        assert f"line {bad_row + 2}:" in str(exc.value)  # file line: blank line + 1-based


def test_scan_line_bad_options(tmp_path: Path) -> None:
    syn = _synthetic_pass()
    p = read_cidco_pass(_write(tmp_path / "passage_1.txt", syn.rows))
    with pytest.raises(InputError, match="attitude must be 'din' or 'acquisition'"):
        cidco_scan_line(p, attitude="ned")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="pad_s must be >= 0"):
        cidco_scan_line(p, pad_s=-0.01)
    with pytest.raises(InputError, match="pad_s must be a finite number"):
        read_cidco_lines(tmp_path, pad_s=float("nan"))
    one = read_cidco_pass(_write(tmp_path / "one.txt", syn.rows[:1]))
    with pytest.raises(InputError, match="two distinct times or pad_s > 0"):
        cidco_scan_line(one, pad_s=0.0)
    assert len(cidco_scan_line(one).trajectory) == 3  # one return, padded both sides
    with pytest.raises(InputError, match="not a folder"):
        read_cidco_lines(tmp_path / "none")
    with pytest.raises(InputError, match="no pass file matches"):
        read_cidco_lines(tmp_path)


# --------------------------------------------------------------------------- real scan lines


@pytest.fixture(scope="module")
def real_passes() -> list[CidcoPass]:
    return [read_cidco_pass(path) for path in PASS_FILES]


@pytest.fixture(scope="module")
def acquisition_lines() -> tuple[ScanLine, ...]:
    return read_cidco_lines(DATA_DIR, attitude="acquisition")


@pytest.fixture(scope="module")
def din_lines() -> tuple[ScanLine, ...]:
    return read_cidco_lines(DATA_DIR)


def _local_ned(points_ecef_m: np.ndarray, p: CidcoPass) -> np.ndarray:
    return ecef_to_ned(points_ecef_m, float(p.lat_deg[0]), float(p.lon_deg[0]), float(p.h_m[0]))


@needs_data
def test_acquisition_lines_reproduce_columns_1_to_3(
    real_passes: list[CidcoPass], acquisition_lines: tuple[ScanLine, ...]
) -> None:
    rows = []
    for p, line in zip(real_passes, acquisition_lines, strict=True):
        assert line.name == p.name
        assert len(line) == p.n_points  # every return kept, clutter included
        traj = GeorefTrajectory.from_trajectory(line.trajectory, ACQUISITION_MOUNT.latency_s)
        out, inside = georeference(line.t_s, line.xyz_scanner_m, traj, ACQUISITION_MOUNT)
        assert inside.all()
        d = _local_ned(out, p) - _local_ned(p.points_ecef_m, p)
        rms, worst = np.sqrt((d**2).mean(axis=0)), np.linalg.norm(d, axis=1).max()
        rows.append(
            f"{p.name:<18} {p.n_points:>4} {rms[0] * 1e3:8.4f} {rms[1] * 1e3:8.4f} "
            f"{rms[2] * 1e3:8.4f} {worst * 1e3:8.4f}"
        )
        # Exact up to the 32-bit rounding of columns 9-14 (the README's model: ~1 mm, max 7).
        assert np.sqrt((d**2).sum(axis=1).mean()) < 5e-5, rows[-1]
        assert worst < 2e-4, rows[-1]
    print(  # noqa: T201
        "\nGeoreferenced with ACQUISITION_MOUNT minus columns 1-3 (mm)\n"
        f"{'pass':<18} {'N':>4} {'N rms':>8} {'E rms':>8} {'D rms':>8} {'max':>8}\n"
        + "\n".join(rows)
    )


@needs_data
def test_vessel_position_is_columns_15_to_17(real_passes: list[CidcoPass]) -> None:
    for p in real_passes:
        llh = ecef_to_geodetic(cidco_vessel_position_ecef_m(p))
        # Height: full precision in column 17 (32-bit float, 2 µm steps).
        assert np.abs(llh[:, 2] - p.h_m).max() < 1e-5, p.name
        # Latitude and longitude: 32-bit floats (printed to 12 decimals), 0.4 / 0.6 m steps.
        np.testing.assert_array_equal(_f32(llh[:, 0]), _f32(p.lat_deg), err_msg=p.name)
        np.testing.assert_array_equal(_f32(llh[:, 1]), _f32(p.lon_deg), err_msg=p.name)


@needs_data
def test_real_times(real_passes: list[CidcoPass], din_lines: tuple[ScanLine, ...]) -> None:
    for p, line in zip(real_passes, din_lines, strict=True):
        timing = cidco_return_times(p)
        np.testing.assert_array_equal(timing.t_s, line.t_s)
        assert np.all(np.diff(line.t_s) > 0.0), p.name
        # Every time rounds (32-bit) to its column 8.
        np.testing.assert_array_equal(_f32(line.t_s), p.t_lidar_s, err_msg=p.name)
        lo, hi = timing.t0_interval_s
        assert lo <= timing.t0_s <= hi
        assert 0.0 < hi - lo < 2e-3
        assert 8 <= timing.n_lines <= 15
        assert np.all(np.diff(timing.line_number[np.r_[True, np.diff(timing.line_index) > 0]]) == 1)
        # Inside the trajectory even with a latency of up to the pad.
        traj = line.trajectory
        assert traj.t_start_s <= line.t_start_s - DEFAULT_PAD_S + 1e-9
        assert traj.t_end_s >= line.t_end_s + DEFAULT_PAD_S - 1e-9
        # Where column 8 steps inside a scan line, t0 is pinned to one return (2 µs).
        straddles = any(
            np.unique(p.t_lidar_s[timing.line_index == k]).size > 1 for k in range(timing.n_lines)
        )
        assert straddles == (hi - lo < 3e-6), p.name
    names = [ln.name for ln in din_lines]
    assert names == [f"sphere{s}/passage_{k}" for s in (1, 2) for k in range(1, 7)]


@needs_data
def test_din_and_acquisition_lines_differ_only_in_pitch(
    real_passes: list[CidcoPass],
    din_lines: tuple[ScanLine, ...],
    acquisition_lines: tuple[ScanLine, ...],
) -> None:
    for p, din, acq in zip(real_passes, din_lines, acquisition_lines, strict=True):
        np.testing.assert_array_equal(din.t_s, acq.t_s)
        np.testing.assert_array_equal(din.trajectory.t_s, acq.trajectory.t_s)
        assert din.trajectory.lat_lon_h is not None
        assert acq.trajectory.lat_lon_h is not None
        np.testing.assert_array_equal(din.trajectory.lat_lon_h, acq.trajectory.lat_lon_h)
        a, b = din.trajectory.euler_rpy_rad(), acq.trajectory.euler_rpy_rad()
        np.testing.assert_allclose(a[:, [0, 2]], b[:, [0, 2]], atol=1e-12)
        np.testing.assert_allclose(a[:, 1], -b[:, 1], atol=1e-12)
        # The vessel is trimmed ~2 deg bow up in the DIN reading.
        assert 1.0 < np.degrees(a[:, 1]).mean() < 3.5, p.name
        np.testing.assert_allclose(
            cidco_attitude_rpy_rad(p), np.radians(np.c_[p.roll_deg, p.pitch_deg, p.heading_deg])
        )


# Boresights (scanner -> body, deg) that make the centres of each sphere's six passes
# agree best (Nelder-Mead on the centre scatter, lever arm and latency of the
# acquisition): one for each reading of column 13.
DIN_FITTED_BORESIGHT_DEG = (180.152, -8.281, 0.487)
ACQUISITION_FITTED_BORESIGHT_DEG = (180.188, -3.341, 0.422)


def _sphere_fits(
    lines: tuple[ScanLine, ...], passes: list[CidcoPass], mount: Mount
) -> list[SphereFit]:
    """Free-radius sphere per pass, in a local NED frame at each sphere's first pass."""
    origin: dict[str, CidcoPass] = {}
    fits = []
    for p, line in zip(passes, lines, strict=True):
        frame = origin.setdefault(p.name.split("/")[0], p)
        traj = GeorefTrajectory.from_trajectory(line.trajectory, mount.latency_s)
        out, _ = georeference(line.t_s, line.xyz_scanner_m, traj, mount)
        fits.append(segment_sphere(_local_ned(out, frame), radius_bounds_m=RADIUS_BOUNDS_M))
    return fits


def _scatter_m(fits: list[SphereFit], passes: list[CidcoPass]) -> dict[str, tuple[float, float]]:
    out = {}
    for sphere in ("sphere1", "sphere2"):
        c = np.array(
            [f.center_m for f, p in zip(fits, passes, strict=True) if p.name.startswith(sphere)]
        )
        d = c - c.mean(axis=0)
        out[sphere] = (
            float(np.sqrt((d[:, :2] ** 2).sum(axis=1).mean())),
            float(np.sqrt((d[:, 2] ** 2).mean())),
        )
    return out


@needs_data
def test_din_attitude_gives_round_spheres_that_agree(
    real_passes: list[CidcoPass],
    din_lines: tuple[ScanLine, ...],
    acquisition_lines: tuple[ScanLine, ...],
) -> None:
    """Why the scan lines carry the DIN attitude: the evidence, as a test."""
    din_mount = Mount(
        lever_arm_body_m=ACQUISITION_MOUNT.lever_arm_body_m,
        boresight_rpy_deg=DIN_FITTED_BORESIGHT_DEG,
    )
    acq_mount = Mount(
        lever_arm_body_m=ACQUISITION_MOUNT.lever_arm_body_m,
        boresight_rpy_deg=ACQUISITION_FITTED_BORESIGHT_DEG,
    )
    runs = {
        "acquisition, its mount (= columns 1-3)": _sphere_fits(
            acquisition_lines, real_passes, ACQUISITION_MOUNT
        ),
        "acquisition, fitted boresight": _sphere_fits(acquisition_lines, real_passes, acq_mount),
        "DIN, fitted boresight": _sphere_fits(din_lines, real_passes, din_mount),
    }
    report = []
    for label, fits in runs.items():
        scatter = _scatter_m(fits, real_passes)
        radii = np.array([f.radius_m for f in fits])
        rms = np.array([f.residual_rms_m for f in fits])
        report.append(
            f"{label:<40} centre scatter RMS horizontal / vertical: "
            + ", ".join(f"{s} {h * 100:.1f} / {v * 100:.1f} cm" for s, (h, v) in scatter.items())
            + f"; free radius {radii.min():.3f}-{radii.max():.3f} m; fit RMS "
            f"{rms.min() * 1e3:.1f}-{rms.max() * 1e3:.1f} mm"
        )
    text = "\n".join(report)
    print("\nCIDCO sphere centres, 6 passes per sphere, local NED\n" + text)  # noqa: T201
    base, _, din = (_scatter_m(f, real_passes) for f in runs.values())
    # The issue's ~28 cm horizontal scatter of the acquisition's own georeferencing.
    assert all(0.2 < h < 0.4 and v < 0.1 for h, v in base.values()), text
    # A boresight alone: the DIN reading brings both spheres under 8 cm / 1.5 cm ...
    assert all(h < 0.08 and v < 0.015 for h, v in din.values()), text
    # ... and every pass gives a round 0.2 m sphere, which no mount achieves with the
    # acquisition's negated pitch (sphere1/passage_3, pitching at 3 deg/s, stays 0.28 m).
    din_fits, acq_fits = runs["DIN, fitted boresight"], runs["acquisition, fitted boresight"]
    assert all(0.18 < f.radius_m < 0.22 and f.residual_rms_m < 0.006 for f in din_fits), text
    assert max(f.radius_m for f in acq_fits) > 0.26, text
    assert max(f.residual_rms_m for f in acq_fits) > 0.012, text
