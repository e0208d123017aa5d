"""Validation figures: the wall residual map and the control-point differences."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from kinsync.demo.validation import validation_section
from kinsync.errors import InputError
from kinsync.frames import ned_to_ecef
from kinsync.report.validation_figures import (
    control_point_figure,
    plus_minus,
    wall_residual_figure,
)
from kinsync.validation import (
    ControlPointDifference,
    ControlPointReport,
    TargetObservation,
    fit_wall,
    signature_tests,
)


def _image(png: bytes) -> np.ndarray:
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    return np.asarray(mpimg.imread(io.BytesIO(png), format="png"))


def _report(tau_s: float, psi_deg: float, *, both_sides: bool = True) -> ControlPointReport:
    rng = np.random.default_rng(0)
    diffs = []
    lateral = (-7.0, -5.5, 6.0, 8.0) if both_sides else (-7.0, -5.5, -6.0, -8.0)
    for k, (v, direction) in enumerate((v, d) for v in (5.0, 12.0, 20.0) for d in (1, -1)):
        for j, x0 in enumerate(lateral):
            x = x0 * direction if both_sides else x0  # the targets' side in the vehicle frame
            dy = tau_s * v - math.radians(psi_deg) * x + rng.normal(0.0, 0.002)
            obs = TargetObservation(f"T{j}", k, 60.0 * k + j, (0, 0, 0), (0, 0, 0), 40, 900.0)
            diffs.append(
                ControlPointDifference(
                    observation=obs,
                    diff_vehicle_m=(0.001, dy, -0.002),
                    diff_ned_m=(direction * dy, 0.0, 0.002),
                    speed_m_s=v,
                    along_speed_m_s=v,
                    heading_deg=0.0 if direction > 0 else 180.0,
                    yaw_rate_deg_s=0.0,
                    lateral_m=x,
                    forward_m=0.0,
                    up_m=0.5,
                )
            )
    tests = signature_tests(tuple(diffs))
    return ControlPointReport(
        differences=tuple(diffs),
        missing=(),
        time_error=tests.time_error,
        heading_error=tests.heading_error,
        intercept_m=tests.intercept_m,
        residual_std_m=tests.residual_std_m,
        pass_std_m=tests.pass_std_m,
        survey_std_m=tests.survey_std_m,
        n_passes=tests.n_passes,
        level=0.99,
        n_control_points=4,
    )


def test_control_point_figure() -> None:
    report = _report(0.002, 0.1)
    assert report.time_error.significant
    assert report.heading_error.significant
    img = _image(control_point_figure(report))
    assert img.shape[1] > 1.5 * img.shape[0] > 300  # two panels side by side
    assert float(np.std(img[..., :3])) > 0.05
    # One side only: the heading term is not testable; the figure is still drawn.
    one_side = _report(0.002, 0.0, both_sides=False)
    assert not one_side.heading_error.testable
    assert _image(control_point_figure(one_side)).shape[0] > 300


def test_control_point_figure_needs_differences() -> None:
    empty = _report(0.0, 0.0)
    empty = ControlPointReport(
        differences=(),
        missing=empty.missing,
        time_error=empty.time_error,
        heading_error=empty.heading_error,
        intercept_m=math.nan,
        residual_std_m=math.nan,
        pass_std_m=math.nan,
        survey_std_m=math.nan,
        n_passes=0,
        level=0.99,
        n_control_points=4,
    )
    with pytest.raises(InputError, match="no control-point differences"):
        control_point_figure(empty)


def test_wall_residual_figure_shows_the_bend() -> None:
    rng = np.random.default_rng(1)
    n = 70_000  # more than the scatter draws: a fixed subset is shown
    u = rng.uniform(-10, 10, n)
    v = rng.uniform(0, 4, n)
    w = 1e-4 * u**2 + rng.normal(0.0, 0.004, n)
    pts = ned_to_ecef(np.column_stack([u, w, -v]), 46.8, -71.2, 20.0)
    result = fit_wall(pts)
    assert result.curvature_significant
    img = _image(wall_residual_figure(result, title="test wall"))
    assert img.shape[1] > 2 * img.shape[0] > 400
    # The residual map is coloured (red and blue), not grey.
    rgb = img[..., :3]
    assert float(np.max(rgb[..., 0] - rgb[..., 2])) > 0.3
    assert float(np.max(rgb[..., 2] - rgb[..., 0])) > 0.3


@pytest.mark.parametrize(
    ("value", "std", "text"),
    [
        (2.14123, 0.0571, "2.141 ± 0.057"),
        (-0.000093, 0.0039, "-0.0001 ± 0.0039"),
        (123.4, 12.0, "123 ± 12"),
        (1.0, 0.0, "1 ± 0"),
        (math.nan, 1.0, "nan ± 1"),
    ],
)
def test_plus_minus(value: float, std: float, text: str) -> None:
    assert plus_minus(value, std) == text


def test_demo_validation_section(tmp_path: Path) -> None:
    summary: list[tuple[str, str, str]] = []
    section = validation_section(tmp_path, summary)
    assert "Validation" in section.title
    assert len(section.tables) == 2
    assert len(section.figures) == 3
    for fig in section.figures:
        assert _image(fig.png).shape[0] > 300
    assert [row[0] for row in section.tables[0].rows] == [
        "correct calibration",
        "latency error 2 ms",
        "boresight yaw error 0.1 deg",
    ]
    doc = json.loads((tmp_path / "validation.json").read_text())
    cp = doc["control_points"]
    assert cp["correct calibration"]["time_error"]["significant"] is False
    assert cp["correct calibration"]["heading_error"]["significant"] is False
    late = cp["latency error 2 ms"]["time_error"]
    assert late["significant"] is True
    assert late["time_error_s"] == pytest.approx(0.002, rel=0.2)
    yaw = cp["boresight yaw error 0.1 deg"]["heading_error"]
    assert yaw["significant"] is True
    assert yaw["heading_error_deg"] == pytest.approx(0.1, rel=0.2)
    wall = doc["wall"]
    assert wall["correct clock"]["curvature_significant"] is False
    assert wall["5 ms time error"]["curvature_significant"] is True
    assert {s[0] for s in summary} == {"validation"}
    for name in ("validation_control_points.png", "validation_wall_5ms.png"):
        assert (tmp_path / name).read_bytes().startswith(b"\x89PNG")
