"""Georeferencing demo section: the velocity check on a 10 Hz export with zero velocities."""

from __future__ import annotations

from kinsync.demo.georef import velocity_check_part
from kinsync.sim.turning_scan import TurningVehicle


def test_velocity_check_part_shows_the_damage_and_the_fallback() -> None:
    table, paragraph, summary, check = velocity_check_part(TurningVehicle())
    rms = {row[0]: float(row[1]) for row in table.rows}
    peak = {row[0]: float(row[2]) for row in table.rows}
    exact, blind, checked = (
        "exact velocities, cubic Hermite",
        "zero velocities used by Hermite (no check)",
        "zero velocities, kinsync: detected, linear",
    )
    assert set(rms) == {exact, blind, checked}
    # Linear at 10 Hz and 20 m/s on a 200 m radius: h^2 a / 8 = 2.5 mm, plus the turn's
    # attitude; Hermite through zero velocities: up to 0.096 h v = 190 mm.
    assert peak[exact] < peak[checked] < 10.0
    assert peak[blind] > 150.0
    assert rms[blind] > 30 * rms[checked]
    assert "the velocities are zero" in paragraph
    assert "interpolated linearly" in paragraph
    assert "detected" in summary
    assert abs(check.value - peak[checked]) <= 0.005
    assert check.passed
    assert check.tolerance.limit == 10.0
