"""The scan and sync-point containers refuse what their file readers refuse."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.sync.scan import ProfileScan, SyncPoints


def test_mirror_angles_in_degrees_are_refused_as_the_reader_does() -> None:
    """The CLI refused angles beyond +-2 pi; the container took degrees and the
    synchronisation failed later on the period prior."""
    profile = np.repeat(np.arange(3), 4)
    angle_deg = np.tile([-90.0, -30.0, 30.0, 90.0], 3)
    ones = np.ones(profile.size)
    ProfileScan(profile, np.radians(angle_deg), ones, ones)
    ProfileScan(profile, np.full(profile.size, 2 * math.pi), ones, ones)  # one turn: kept
    with pytest.raises(InputError, match=r"index 0 \(0-based\), column 'angle_rad': -90.0 is "):
        ProfileScan(profile, angle_deg, ones, ones)


def test_a_single_name_is_not_split_into_letters() -> None:
    """SyncPoints("ab", ...) made points 'a' and 'b'."""
    llh = np.array([[46.8, -71.2, 30.0], [46.8, -71.2001, 30.0]])
    with pytest.raises(InputError, match=r"names: expected a sequence of names, got the single"):
        SyncPoints("ab", llh)  # type: ignore[arg-type]
    assert SyncPoints(["a", "b"], llh).names == ("a", "b")  # type: ignore[arg-type]


def test_float32_sync_points_are_refused_naming_the_argument() -> None:
    """float32 latitudes are up to 0.2 m off near 47 deg: the Method B clock t0 came out
    3.4 sigma off, silently."""
    llh = np.array([[46.8, -71.2, 30.0], [46.8, -71.2001, 30.0]])
    with pytest.raises(
        InputError, match=r"<sync points>: lat_lon_h \(latitude, longitude\): float32 .*float64"
    ):
        SyncPoints(("a", "b"), llh.astype(np.float32))
    assert SyncPoints(("a", "b"), llh).lat_lon_h.dtype == np.float64
