"""Fixtures shared by the Method B tests."""

from __future__ import annotations

import pytest

from kinsync.sim.profiler import (
    DriveScanConfig,
    DriveScanSimulation,
    ProfilerConfig,
    simulate_drive_scan,
)
from kinsync.sim.scene import SceneLayout


@pytest.fixture(scope="module")
def cheap() -> DriveScanSimulation:
    """The oval with 25 Hz records, no control targets, scanned over 50-100 deg: fast."""
    return simulate_drive_scan(
        DriveScanConfig(
            rate_hz=25.0,
            near_targets_only=True,
            profiler=ProfilerConfig(range_noise_m=0.003, angle_min_deg=50.0, angle_max_deg=100.0),
            layout=SceneLayout(n_control=0),
        )
    )
