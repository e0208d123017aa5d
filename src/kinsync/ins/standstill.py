"""What the filter adds when a run starts with a levelled standstill.

A static alignment (`kinsync.ins.alignment.align_static_gnss_heading`) levels roll and
pitch with the mean specific force and says until when the vehicle stands
(`InitialState.static_until_s`). The levelled tilt is then the horizontal accelerometer
error over g (`kinsync.ins.filter.initial_covariance` correlates them), and the filter

- keeps the levelled attitude in the accelerometer columns of ``F`` until the vehicle
  moves (first-estimates Jacobian), and leaves the horizontal terms of the second-order
  tilt mean out meanwhile (`standstill_params`; both in `kinsync.ins._ekf`);
- carries one more error state for the whole run, ``c``, the second-order vertical
  support of the tilt (`with_vertical_support`; its model in `kinsync.ins._ekf`). At
  rest the vertical channel measures the vertical accelerometer error plus
  ``c = ½ g |φ_h|² = |δf_h|²/(2g)``, 0.25 mg on average for the MEMS preset.

``c`` starts with the mean and variance of ``½ g φ_h^T φ_h`` for ``φ_h`` drawn from the
initial tilt covariance ``P_h`` (2×2): ``½ g tr(P_h)`` and ``½ g² tr(P_h²)``
(`kinsync.ins._ekf.tilt_moments`; a weighted χ² with two degrees of freedom, whose σ
equals its mean when the two axes are alike), uncorrelated with every other initial
error (the third moments of a Gaussian vanish); the mean is its first estimate ``ĉ``.

Over 12 simulated MEMS static starts (60 s at rest, then an oval at 2 m/s, RTK), the
error over its σ, RMS over 5-60 / 60-85 / 85-110 s, before and with ``c``:

=========================  ==================  ==================
error over σ               forward             smoothed
=========================  ==================  ==================
vertical acc. bias before  0.73 / 1.19 / 1.55  12.3 / 4.36 / 1.48
vertical acc. bias with c  1.15 / 0.91 / 1.03  0.84 / 0.94 / 0.85
position before            0.96 / 1.23 / 1.03  1.03 / 1.32 / 1.04
position with c            0.96 / 1.09 / 1.01  1.02 / 1.04 / 1.00
roll/pitch before          0.95 / 1.23 / 1.19  1.09 / 1.03 / 1.00
roll/pitch with c          0.95 / 1.16 / 1.02  1.17 / 1.11 / 1.03
=========================  ==================  ==================

The smoothed vertical bias error at rest went from 0.279 mg RMS (reported σ 0.022 mg)
to 0.065 mg (σ 0.077 mg). Over 24 drives the smoothed roll/pitch figures are the same
before and after (1.16 / 1.14 / 1.08 and 1.17 / 1.15 / 1.07). At rest the forward
vertical bias error is mostly the horizontal accelerometer bias, not yet observed, seen
along the body Z axis, which the levelled attitude tilts by ``δf_h/g`` from the
levelled vertical: an offset of about ``-2c`` that the smoother removes once the turns
show the horizontal bias. Runs without a levelled standstill (a reference attitude, a
moving start) keep 21 or 27 states and the same numbers.

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, sec. 5.6.2 (levelling and its tilt error).
G. P. Huang, A. I. Mourikis, S. I. Roumeliotis, "Analysis and improvement of the
consistency of extended Kalman filter based SLAM", Proc. IEEE ICRA 2008, 473-479
(first-estimates Jacobian).
"""

from __future__ import annotations

import math

import numpy as np

from kinsync._typing import FloatArray
from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins._ekf import N_SUPPORT, P_FEJ_C, P_FEJ_END, tilt_moments
from kinsync.ins.earth import normal_gravity_m_s2
from kinsync.ins.solution import InitialState
from kinsync.ins.strapdown import I_CM, I_CV, I_CVAR

__all__ = [
    "has_levelled_standstill",
    "standstill_params",
    "with_vertical_support",
]


def has_levelled_standstill(init: InitialState) -> bool:
    """True when ``init`` comes from levelling and says until when the vehicle stands."""
    return init.static_until_s is not None and init.levelling_std_rad is not None


def standstill_params(params: FloatArray, init: InitialState) -> FloatArray:
    """``params`` with the initial standstill of a static alignment (`step_matrices`).

    Until ``init.static_until_s`` the accelerometer columns of ``F`` keep the levelled
    attitude (first-estimates Jacobian, `kinsync.ins._ekf`), and the horizontal terms
    of the second-order tilt mean are left out (`kinsync.ins._ekf.remove_support`):
    levelling made the resolved specific force exactly vertical. The vertical term is
    the state ``c`` (`with_vertical_support`) from the start. Unchanged without a
    levelled standstill.
    """
    if not has_levelled_standstill(init):
        return params
    assert init.static_until_s is not None  # for mypy: has_levelled_standstill
    p = params.copy()
    p[P_FEJ_END] = init.static_until_s
    p[P_FEJ_C : P_FEJ_C + 9] = euler_rpy_to_matrix(*init.rpy_rad).ravel()
    return p


def with_vertical_support(
    nominal: FloatArray, P: FloatArray, init: InitialState
) -> tuple[FloatArray, FloatArray]:
    """The starting nominal state and covariance with ``c``, after a levelled standstill.

    Parameters
    ----------
    nominal : ndarray, shape (31,)
        Nominal state (`kinsync.ins.strapdown.initial_state_vector`).
    P : ndarray, shape (n, n)
        Initial covariance without ``c`` (`kinsync.ins.filter.initial_covariance`).
    init : InitialState
        The initial state.

    Returns
    -------
    nominal : ndarray, shape (31,)
        A copy, with ``ĉ`` = the prior mean of ``c``.
    P : ndarray, shape (n + 1, n + 1)
        ``P`` with ``c`` appended, uncorrelated, of the prior variance.

    Both are returned unchanged without a levelled standstill
    (`has_levelled_standstill`): the filter then has no ``c``. The nominal state also
    stores ``c``'s prior mean and variance (``I_CM``, ``I_CVAR``), from which the filter
    propagates it (`kinsync.ins._ekf.propagate_support`).
    """
    if not has_levelled_standstill(init):
        return nominal, P
    g = float(normal_gravity_m_s2(math.radians(init.lat_deg), init.h_m))
    mean, var = tilt_moments(P, g)
    n = P.shape[0]
    out_P = np.zeros((n + N_SUPPORT, n + N_SUPPORT))
    out_P[:n, :n] = P
    out_P[n, n] = var
    out_nominal = np.array(nominal, dtype=np.float64)
    out_nominal[I_CV] = mean
    out_nominal[I_CM] = mean
    out_nominal[I_CVAR] = var
    return out_nominal, out_P
