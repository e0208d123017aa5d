"""Method A: the fitted sphere centres against the rotation model (SPEC section 2).

Per rate, the centres at +omega and -omega (6 coordinates) are fitted by the latency-free
centre and tau (4 unknowns): the misfit chi2 has 2 degrees of freedom. With input that
matches the model it averages about 2 (1.9 over 396 simulated rates, largest 13.4);
a rotation axis in ``passes.csv`` that is not the table's, or points whose origin is
off the table axis (exported about another origin), move the centres otherwise than a
rotation about the stated axis through the origin: the misfit grows (a North axis for a
vertical table gives chi2 800 to 7600; points 0.3 m off the axis, 5 to 32) and the
latency is wrong (-0.09 ms and 3.57 ms for 4.21 ms), with nothing else to show it.
`check_rotation_model` refuses such input.
"""

from __future__ import annotations

from collections.abc import Sequence

from scipy import stats

from kinsync._text import format_p_value
from kinsync.errors import InputError

__all__ = [
    "MODEL_DOF",
    "MODEL_MISFIT_P",
    "RADIUS_TOLERANCE",
    "check_rotation_model",
    "model_p_value",
    "radius_contradiction",
]

MODEL_DOF = 2
"""Degrees of freedom of one rate's rotation-model chi2 (6 coordinates, 4 unknowns)."""

MODEL_MISFIT_P = 1e-4
"""Below this p-value of a rate's rotation-model chi2 (chi2 above 18.4 on 2 dof), or of
their sum over the rates, the input is refused: among 396 simulated rates with correct
input the largest chi2 was 13.4 (p = 0.0012)."""

_SHOWN_MAX = 4

RADIUS_TOLERANCE = 0.05
"""A given sphere radius that the radius fitted freely to a pool's points differs from by
more than this fraction, and by more than `_RADIUS_SIGMAS` of that fit's sigma, is
contradicted by the data (`radius_contradiction`)."""

_RADIUS_SIGMAS = 5.0
_RADII_SHOWN = 2


def model_p_value(chi2: float, dof: int = MODEL_DOF) -> float:
    """Probability of a rotation-model chi2 at least this large with correct input."""
    return float(stats.chi2.sf(chi2, dof))


def check_rotation_model(rates: Sequence[tuple[float, float]], n_unswept: int = 0) -> None:
    """Raise when the sphere centres do not fit a rotation about the stated axis.

    Parameters
    ----------
    rates : sequence of (float, float)
        Each rate's magnitude (deg/s) and rotation-model chi2 (2 dof).
    n_unswept : int
        Passes whose points have times but do not turn about their stated axis
        (`kinsync.latency.rate_check`): named in the message, as they point the same way.

    Raises
    ------
    InputError
        A rate's chi2, or the sum over rates, with p-value below `MODEL_MISFIT_P`:
        naming the rates, their chi2 and the likely causes.
    """
    if not rates:
        return
    total = sum(chi2 for _, chi2 in rates)
    dof = MODEL_DOF * len(rates)
    worst = [(r, c) for r, c in rates if model_p_value(c) < MODEL_MISFIT_P]
    if not worst and model_p_value(total, dof) >= MODEL_MISFIT_P:
        return
    listed = ", ".join(f"{c:.1f} at {r:g} deg/s" for r, c in rates[:_SHOWN_MAX])
    if len(rates) > _SHOWN_MAX:
        listed += f" and {len(rates) - _SHOWN_MAX} more"
    unswept = (
        f"; the points of {n_unswept} passes have times but do not turn about the stated "
        "axis, which points the same way"
        if n_unswept
        else ""
    )
    msg = (
        "the sphere centres at +omega and -omega do not fit a rotation about the stated "
        f"table axis through the origin (rotation-model chi2 {listed}, {MODEL_DOF} dof each; "
        f"all rates: chi2 {total:.1f} on {dof} dof, {format_p_value(model_p_value(total, dof))}; "
        f"correct input gives about {MODEL_DOF} per rate){unswept}: the latency would be "
        "wrong. Check the rotation axis in passes.csv (axis_n,axis_e,axis_d, NED; default "
        "0,0,1 = Down) and that the points are table-centred: their origin on the table "
        "axis at the scanner, not exported about another origin"
    )
    raise InputError(msg)


def radius_contradiction(given_m: float, pools: Sequence[tuple[float, float, float]]) -> str:
    """The pools whose points contradict the given sphere radius, in words; "" if none.

    A wrong given radius leaves the latency close but its sigma far larger (0.1 m for a
    0.0762 m sphere: 9 times), unseen.

    Parameters
    ----------
    given_m : float
        The given radius (m).
    pools : sequence of (float, float, float)
        Each pool's signed rate (deg/s), the radius fitted freely to its points and that
        radius's sigma (m); nan when that fit failed (not judged).
    """
    off = [
        (rate, r, s)
        for rate, r, s in pools
        if abs(r - given_m) > max(RADIUS_TOLERANCE * given_m, _RADIUS_SIGMAS * s)
    ]
    if not off:
        return ""
    shown = off[:_RADII_SHOWN]
    listed = ", ".join(f"{r:.4f} m (sigma {s:.2g} m) at {rate:+g} deg/s" for rate, r, s in shown)
    if len(off) > _RADII_SHOWN:
        listed += f" and {len(off) - _RADII_SHOWN} more"
    return (
        f"the sphere radius given (radius_m, --radius-m, {given_m:g} m) is contradicted by "
        f"the points: fitted freely, they give {listed} ({len(off)} of {len(pools)} signed "
        "rates); a wrong radius inflates the latency sigma and can bias it: check "
        "--radius-m (a diameter for the radius, inches?) or leave it out to fit it"
    )
