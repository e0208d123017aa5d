"""How far a mount calibration has got: its stages as `kinsync.progress` reports them.

`kinsync.calibration.calibrate_mount` calls its ``progress`` as every long computation
of kinsync does, ``progress(fraction, stage)`` (`kinsync.progress.Progress`). Its
stages take rough shares of the work (`CALIBRATION_STAGES`): finding the features in
the lines (and searching the boresight yaw), solving (again after a parameter is held:
the fraction then stays where it was, never decreasing), the jackknife's deleted-line
solutions (the fraction advancing with each) and the held parameters' effect. The
label is what runs now ("finding planes in 8 lines", "jackknife: 3 of 8 done (without
line_03.laz)").
"""

from __future__ import annotations

from kinsync.progress import Progress, Stages, part

__all__ = ["CALIBRATION_STAGES", "CalibrationSteps"]

CALIBRATION_STAGES = {
    "finding features": 2.0,
    "solving": 2.0,
    "jackknife": 5.0,
    "held parameters": 1.0,
}
"""The stages of a calibration in the order they run, with their rough shares of its time."""


class CalibrationSteps(Stages):
    """`Stages` of a calibration, reported to ``progress`` (None: nothing is reported).

    Parameters
    ----------
    progress : Progress or None
        The caller's ``progress(fraction, stage)``.
    """

    def __init__(self, progress: Progress | None) -> None:
        super().__init__(progress, CALIBRATION_STAGES)
        self._reporting = progress is not None

    def within(self, stage: str) -> Progress | None:
        """The `Progress` of ``stage`` (its own 0..1 on its share), keeping its labels.

        Reports nothing by itself: the stage's first report starts it.
        """
        lo, hi = self._bounds[stage]
        return part(self._emit if self._reporting else None, lo, hi)

    def finish(self) -> None:
        """Report the calibration done (fraction 1)."""
        self._emit(1.0, "calibrated")
