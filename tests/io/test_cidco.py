"""CIDCO LidarToolkit pass reader, and sphere fits on the 12 real Port de Québec passes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.fit import SphereFit, segment_sphere
from kinsync.io.cidco import CIDCO_COLUMNS, CidcoPass, read_cidco_pass
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


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("", "no data"),
        ("   \n\n", "no data"),
        (_line([1.0] * 17) + "\n" + _line([1.0] * 16) + "\n", "line 2 has 16 numbers, expected 17"),
        (_line([1.0] * 18) + "\n", "line 1 has 18 numbers, expected 17"),
        (_line([1.0] * 17) + "\n" + "1 " * 16 + "x\n", "line 2, column 17: 'x' is not a number"),
        (_line([1.0] * 17) + "\n" + "1 " * 16 + "nan\n", "line 2, column 17: non-finite"),
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
