"""Tukey's weights on a plane: returns are set aside for lying off their own line's
surface, never for their line's navigation error (an offset, or a drift while the line
crosses the plane)."""

from __future__ import annotations

import numpy as np

from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import FeatureReturns, _robust_factors
from kinsync.calibration.features import PlaneFeature

GROUND = PlaneFeature(normal=np.array([0.0, 0.0, 1.0]), offset_m=0.0, reference_m=np.zeros(3))


def _line(
    rng: np.random.Generator, n: int, height_m: float, drift_m_per_m: float = 0.0
) -> FloatArray:
    """``n`` returns of one line on the ground over 10 m x 10 m, 1 mm range noise,
    ``height_m`` up plus ``drift_m_per_m`` times x."""
    xy = rng.uniform(-5.0, 5.0, (n, 2))
    z = rng.normal(0.0, 0.001, n) + height_m + drift_m_per_m * xy[:, 0]
    out: FloatArray = np.column_stack([xy, z])
    return out


def _returns(lines: list[FloatArray]) -> FeatureReturns:
    x = np.concatenate(lines)
    group = np.concatenate([np.full(len(p), i) for i, p in enumerate(lines)]).astype(np.int64)
    beam = np.tile([0.0, 0.0, -1.0], (len(x), 1))
    return FeatureReturns(x=x, jac=np.zeros((len(x), 3, 1)), beam=beam, group=group)


def test_a_line_drifting_across_the_plane_keeps_its_weight_and_outliers_do_not() -> None:
    # A 1 mm scanner: two lines flat on the ground, a third 3 cm up and drifting 8 mm
    # from one end of the plane to the other (its height error changes while it crosses
    # the plane), with eight returns on a car 30 cm up. About the line's median the ends
    # of the drift lay beyond Tukey's band (weight 0): 1 % of a patch test's returns,
    # but the ones that told the roll boresight, whose spread was 2.8 times that of
    # plain least squares on the simulated vehicle.
    rng = np.random.default_rng(5)
    flat = [_line(rng, 800, 0.0), _line(rng, 800, 0.0)]
    drifting = _line(rng, 400, 0.03, drift_m_per_m=0.0016)
    car = _line(rng, 8, 0.30)
    ret = _returns([*flat, np.concatenate([drifting, car])])
    w = _robust_factors(GROUND, ret, sigma=0.02, robust=True)
    on_drift, on_flat = w[1600:2000], w[:1600]
    assert np.all(on_drift > 0.0), np.sort(on_drift)[:5]
    assert abs(np.mean(on_drift) - np.mean(on_flat)) < 0.03, (np.mean(on_drift), np.mean(on_flat))
    assert np.all(on_flat > 0.0)
    assert np.all(w[2000:] == 0.0), w[2000:]


def test_a_short_line_on_the_plane_is_centred_on_its_median() -> None:
    # Too few returns to fit a line's own plane: the median is its centre, so a line
    # 3 cm off keeps its weight and a return 30 cm off its line is set aside.
    rng = np.random.default_rng(6)
    short = np.concatenate([_line(rng, 8, 0.03), _line(rng, 1, 0.33)])
    ret = _returns([_line(rng, 500, 0.0), short])
    w = _robust_factors(GROUND, ret, sigma=0.02, robust=True)
    assert np.all(w[:508] > 0.0)
    assert w[508] == 0.0
