"""Warnings of mount values few mounts have: the likely unit slips (`kinsync.mount`).

A latency beyond `WARN_LATENCY_S`, a lever arm component beyond `WARN_LEVER_ARM_M` or an
``[uncertainty]`` value beyond `WARN_STD` is read with a `KinsyncWarning` naming the
likely slip (5 written for 5 ms, 150 for 150 cm). Values no mount has are refused by
the `~kinsync.mount.Mount` container itself.

The latency warning is the container's own (`warn_latency_slip`, from
``Mount.__post_init__``), so that a mount built in Python gets it as a mount file does.
A mount made from another one (the file's mount, a calibration's moved values) is built
within `derived_mounts`, which leaves the warning out: it was given for the mount it
came from, and the program prints each warning once.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar

from kinsync.errors import KinsyncWarning

__all__ = [
    "STD_UNITS",
    "WARN_LATENCY_S",
    "WARN_LEVER_ARM_M",
    "WARN_STD",
    "derived_mounts",
    "latency_slip",
    "warn_latency_slip",
    "warn_unit_slips",
]

WARN_LATENCY_S = 1.0
"""A mount latency beyond this (s, either sign) is read with a warning: sensor, serial
and buffering delays are milliseconds, and 5 written for 5 ms gives 5 s."""

WARN_LEVER_ARM_M = 100.0
"""A lever arm component beyond this (m, either sign) is read with a warning: larger
than most survey vehicles and vessels, and what 150 cm written as 150 gives."""

WARN_STD = {"lever_arm_body_m": 1.0, "boresight_rpy_deg": 5.0, "latency_s": 0.1}
"""An ``[uncertainty]`` value beyond these (m, deg, s) is read with a warning: a unit
mistake (centimetres or milliseconds written as metres or seconds), or a value so poorly
known that a calibration's linearisation about it means little."""

STD_UNITS = {"lever_arm_body_m": "m", "boresight_rpy_deg": "deg", "latency_s": "s"}
"""The unit of each ``[uncertainty]`` key."""

_UNIT_SLIPS = {
    "lever_arm_body_m": "centimetres written as metres?",
    "boresight_rpy_deg": "arc-minutes or milliradians written as degrees?",
    "latency_s": "milliseconds written as seconds?",
}
"""The likely slip behind an ``[uncertainty]`` value beyond `WARN_STD`, per key."""

_DERIVED: ContextVar[bool] = ContextVar("kinsync_derived_mounts", default=False)


@contextmanager
def derived_mounts() -> Iterator[None]:
    """Within it, a `~kinsync.mount.Mount` built gives no latency warning.

    For kinsync's own mounts made from another one (``dataclasses.replace``, a
    calibration's parameter values): the mount they come from was warned of.
    """
    token = _DERIVED.set(True)
    try:
        yield
    finally:
        _DERIVED.reset(token)


def latency_slip(latency_s: float) -> str:
    """What a latency beyond `WARN_LATENCY_S` likely is, or "" for a usual one.

    Parameters
    ----------
    latency_s : float
        A mount's latency (s).

    Returns
    -------
    str
        ``"latency_s = 5.0 s is beyond +-1 s, ..."``; "" within `WARN_LATENCY_S`.
    """
    if abs(latency_s) <= WARN_LATENCY_S:
        return ""
    return (
        f"latency_s = {latency_s!r} s is beyond +-{WARN_LATENCY_S:g} s, longer than any "
        f"sensor or serial delay: latency_s is in seconds ({latency_s!r} ms would be "
        f"{latency_s / 1e3!r})"
    )


def warn_latency_slip(latency_s: float, stacklevel: int) -> None:
    """Warn of a mount latency beyond `WARN_LATENCY_S` (not within `derived_mounts`).

    Parameters
    ----------
    latency_s : float
        The mount's latency (s).
    stacklevel : int
        Frames above this function's caller that the warning names.
    """
    slip = latency_slip(latency_s)
    if slip and not _DERIVED.get():
        warnings.warn(f"mount {slip}", KinsyncWarning, stacklevel=stacklevel + 1)


def warn_unit_slips(
    source: str,
    latency_s: float,
    lever_arms_m: Mapping[str, tuple[float, float, float]],
    stds: Mapping[str, float | tuple[float, float, float] | None],
) -> None:
    """Warn of a mount file's values few mounts have, naming the file.

    Parameters
    ----------
    source : str
        The file (or other source) the values were read from.
    latency_s : float
        Its ``[mount] latency_s`` (s).
    lever_arms_m : mapping of str to tuple of 3 float
        Its lever arms by key (``lever_arm_body_m``, ``antenna_lever_arm_body_m``), m.
    stds : mapping of str to float, tuple of 3 float or None
        Its ``[uncertainty]`` values by key (`WARN_STD`'s keys), None where not given.
    """
    slip = latency_slip(latency_s)
    if slip:
        warnings.warn(f"{source}: [mount] {slip}", KinsyncWarning, stacklevel=3)
    for name, values in lever_arms_m.items():
        big = [i for i, value in enumerate(values) if abs(value) > WARN_LEVER_ARM_M]
        if big:
            warnings.warn(
                f"{source}: [mount] {name}[{big[0]}] = {values[big[0]]!r} m is "
                f"beyond +-{WARN_LEVER_ARM_M:g} m, larger than most vehicles and vessels: "
                "lever arms are in metres (centimetres give 100 times too much)",
                KinsyncWarning,
                stacklevel=3,
            )
    for key, limit in WARN_STD.items():
        value = stds.get(key)
        sigmas = () if value is None else (value,) if isinstance(value, float) else value
        if any(v > limit for v in sigmas):
            unit = STD_UNITS[key]
            warnings.warn(
                f"{source}: [uncertainty] {key} = {value!r} {unit}: a standard deviation "
                f"beyond {limit:g} {unit} is a unit mistake ({_UNIT_SLIPS[key]}) or a "
                "value too poorly known for a calibration to hold it: its effect is "
                "linearised about the prior",
                KinsyncWarning,
                stacklevel=3,
            )
