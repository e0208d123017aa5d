"""The orientation classes by which the patch finder chooses its planes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinsync.calibration.planes import _orientation_class


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
