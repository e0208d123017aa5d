"""calibrate_mount reports progress as kinsync.progress documents: progress(fraction, stage)."""

from __future__ import annotations

from kinsync.calibration import CalibrationOptions, calibrate_mount
from kinsync.sim.patch_config import PatchTestConfig
from kinsync.sim.patch_test import simulate_patch_test


def test_calibrate_mount_calls_progress_with_a_fraction_and_a_stage() -> None:
    """It called progress(message): a kinsync.progress.Progress raised TypeError."""
    sim = simulate_patch_test(
        PatchTestConfig(scenario="vehicle", density=0.02, passes_per_direction=1, seed=4)
    )
    reports: list[tuple[float, str]] = []

    def progress(fraction: float, stage: str, /) -> None:
        assert isinstance(fraction, float)
        assert isinstance(stage, str)
        reports.append((fraction, stage))

    options = CalibrationOptions(estimate=("boresight",))
    calibrate_mount(sim.lines, sim.mount_nominal, options, progress=progress)
    fractions = [f for f, _ in reports]
    assert fractions == sorted(fractions)
    assert fractions[0] == 0.0
    assert fractions[-1] == 1.0
    assert 0.0 < fractions[len(fractions) // 2] < 1.0
    assert reports[0][1] == "finding planes in 4 lines"
    assert any(s.startswith("solving for ") for _, s in reports)
    assert any(s.startswith("jackknife: 2 of 4 done") for _, s in reports)
