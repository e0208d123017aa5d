"""The calibration certificate and its overlap figure."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from kinsync.calibration.overlaps import LineOverlap
from kinsync.calibration.result import CalibrationResult, FeatureSummary, ParameterEstimate
from kinsync.mount import Mount
from kinsync.report.calibration import calibration_certificate, overlap_figure, verdict

NAN = math.nan


def _result() -> CalibrationResult:
    params = (
        ParameterEstimate("boresight_roll_deg", 180.15, 180.0, 0.017, 0.0017, "estimated"),
        ParameterEstimate("boresight_pitch_deg", -7.99, 0.0, 0.45, 0.008, "weak"),
        ParameterEstimate("boresight_yaw_deg", 0.48, 0.0, 0.18, 0.004, "weak"),
        ParameterEstimate("lever_x_m", -0.602, -0.602, NAN, NAN, "fixed"),
        ParameterEstimate("lever_y_m", -0.065, -0.065, NAN, NAN, "fixed"),
        ParameterEstimate("lever_z_m", -0.356, -0.356, NAN, NAN, "unobservable"),
        ParameterEstimate("latency_ms", 0.0, 0.0, NAN, NAN, "unobservable"),
    )
    features = (
        FeatureSummary("sphere", "sphere, radius 0.192 m (fitted)", 1413, 6, 0.49, 0.042,
                       (0.657, 0.073), (0.071, 0.004)),
        FeatureSummary("plane", "plane, tilt 90 deg, normal azimuth 300 deg", 800, 4, 0.05,
                       0.01, (0.02, 0.01), (0.005, 0.002)),
    )  # fmt: skip
    rng = np.random.default_rng(0)
    before = tuple(
        LineOverlap(f, f"line {i}", tuple(rng.normal(0, 0.3, 3)), NAN if f == 0 else 0.01 * i)
        for f in (0, 1)
        for i in range(6)
    )
    after = tuple(
        LineOverlap(o.feature, o.line, tuple(0.1 * np.array(o.offset_ned_m)), o.normal_m / 5)
        for o in before
    )
    return CalibrationResult(
        mount=Mount(boresight_rpy_deg=(180.15, -7.99, 0.48)),
        prior=Mount(boresight_rpy_deg=(180.0, 0.0, 0.0)),
        parameters=params,
        sigma_method="jackknife over 6 lines (delete one line at a time)",
        correlation_names=("boresight_roll_deg", "boresight_pitch_deg", "boresight_yaw_deg"),
        correlation=np.array([[1.0, 0.37, -0.72], [0.37, 1.0, -0.56], [-0.72, -0.56, 1.0]]),
        features=features,
        residual_rms_before_m=0.518,
        residual_rms_after_m=0.0346,
        unobservable_reasons=("latency_ms is determined only to +-17.2 by these data",),
        advice=("latency: two speeds in both directions, or turns and roll/pitch dynamics",),
        lines=tuple(f"line {i}" for i in range(6)),
        iterations=7,
        overlaps_before=before,
        overlaps_after=after,
    )


def test_verdict_first_with_sigma_and_status() -> None:
    text = verdict(_result())
    assert text.startswith("Calibrated: boresight_roll_deg 180 -> 180.1500 (+-0.017, estimated)")
    assert "boresight_pitch_deg 0 -> -7.9900 (+-0.45, weak)" in text
    assert "held at their prior values: lever_z_m, latency_ms" in text
    assert "51.80 cm before, 3.46 cm after" in text


def test_certificate_is_one_self_contained_page() -> None:
    html = calibration_certificate(_result())
    assert html.index("Verdict") < html.index("What the data could not determine")
    assert html.index("What the data could not determine") < html.index("Features")
    assert "latency_ms is determined only to +-17.2" in html
    assert "Would determine them: latency: two speeds" in html
    assert "65.7 / 7.3" in html
    assert "7.1 / 0.4" in html
    assert html.count("data:image/png;base64,") == 1
    assert "http://" not in html
    assert "https://" not in html


@pytest.mark.parametrize("kinds", [("sphere", "plane"), ("sphere", "sphere"), ("plane", "plane")])
def test_overlap_figure_for_spheres_planes_or_both(kinds: tuple[str, str]) -> None:
    r = _result()
    png = overlap_figure(r.overlaps_before, r.overlaps_after, ["a", "b"], list(kinds))
    assert png.startswith(b"\x89PNG")


def test_overlap_figure_plane_numbers_do_not_run_together(monkeypatch: pytest.MonkeyPatch) -> None:
    """28 planes: the demo's labels 20-27 ran together once enlarged to be read."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: PLC0415
    from matplotlib.figure import Figure  # noqa: PLC0415

    from kinsync.report import calibration, figures  # noqa: PLC0415

    drawn: list[Figure] = []
    real = figures.png_bytes

    def keep(fig: Figure) -> bytes:
        drawn.append(fig)
        return real(fig)

    monkeypatch.setattr(calibration, "png_bytes", keep)
    rng = np.random.default_rng(1)
    for n in (28, 75):
        drawn.clear()
        before, after = (
            [LineOverlap(k, f"l{j}", (0.0, 0.0, 0.0), float(rng.normal(0, s))) for k in range(n)
             for j in range(4)]
            for s in (0.04, 0.02)
        )  # fmt: skip
        overlap_figure(before, after, [f"plane {k}" for k in range(n)], ["plane"] * n)
        (fig,) = drawn
        renderer = FigureCanvasAgg(fig).get_renderer()  # type: ignore[no-untyped-call]
        for ax in fig.axes:
            labels = [t for t in ax.get_xticklabels() if t.get_text()]
            assert 14 <= len(labels) <= 24, n
            boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
            for left, right in itertools.pairwise(boxes):
                assert left.x1 <= right.x0, (n, left, right)
