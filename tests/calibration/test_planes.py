"""The orientation classes by which the patch finder chooses its planes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinsync.calibration.planes import _capped, _orientation_class


@pytest.mark.parametrize("azimuth_deg", np.arange(0.0, 360.0, 7.0))
@pytest.mark.parametrize("tilt_off_vertical", [1e-9, -1e-9, 0.0, 0.01, -0.01])
def test_a_wall_is_one_class_whatever_the_sign_of_its_normal(
    azimuth_deg: float, tilt_off_vertical: float
) -> None:
    """A wall's fitted normal points either way; its class was set by the sign of its tiny
    vertical component, so the patches of one quay wall fell into two classes by chance
    (each class keeps its largest patches: up to twice a wall's share, depending on where
    the voxel grid fell)."""
    a = math.radians(azimuth_deg)
    n = np.array([math.cos(a), math.sin(a), tilt_off_vertical])
    n /= np.linalg.norm(n)
    flipped = -n
    flipped[2] = n[2]  # the same wall, its normal fitted the other way but for the noise
    assert _orientation_class(n) == _orientation_class(-n) == _orientation_class(flipped)
    assert 1 <= _orientation_class(n) <= 12


@pytest.mark.parametrize("azimuth_deg", np.arange(0.0, 360.0, 11.0))
def test_slopes_and_ground_keep_their_classes(azimuth_deg: float) -> None:
    a = math.radians(azimuth_deg)
    slope = np.array([0.5 * math.cos(a), 0.5 * math.sin(a), -math.sqrt(0.75)])  # 30 deg
    assert _orientation_class(slope) == _orientation_class(-slope)  # oriented by z
    assert _orientation_class(slope) == 13 + int(azimuth_deg // 30.0)
    facing_away = np.array([-slope[0], -slope[1], slope[2]])
    assert _orientation_class(facing_away) != _orientation_class(slope)  # downhill differs
    assert _orientation_class(np.array([0.1, 0.0, math.sqrt(0.99)])) == 0


def test_a_wall_class_keeps_twice_the_patches_of_ground_or_slope() -> None:
    """The cap per class: a wall's sectors span half the circle of a slope's, so a wall
    class keeps twice as many of its largest patches; the order within a class is kept."""
    by_class = {
        0: list(range(30)),  # ground
        5: list(range(100, 130)),  # one wall sector
        14: list(range(200, 230)),  # one slope sector
        12: [300, 301],  # a wall sector with fewer than the cap
    }
    chosen = _capped(by_class, 12)
    assert [p for p in chosen if p < 100] == list(range(12))
    assert [p for p in chosen if 100 <= p < 200] == list(range(100, 124))
    assert [p for p in chosen if 200 <= p < 300] == list(range(200, 212))
    assert [p for p in chosen if p >= 300] == [300, 301]
