"""Synchronisation and heading signatures of control-point differences (SPEC section 7).

The signatures are tested in one linear model of the along-track differences with
both regressors at once (`signature_tests`)::

    dY_i = c + tau · s_i - psi · X_i + b_pass(i) + f_i · g_target(i) + e_i

``s_i`` is the along-track (Y) velocity of the target point carried with the vehicle,
``v + omega x r`` in the vehicle frame, at the visit (the vehicle speed when driving
straight; exact rigid-body kinematics in a curve), ``X_i`` the target's lateral
position. A time error ``tau`` (the latency applied minus the true one) moves every
point by ``tau (v + omega x r)``; a heading misorientation ``psi`` (rotation of the
cloud about the vehicle's down axis, DIN 9300 yaw sense) moves it along-track by
``-psi X``: opposite signs left and right. The intercept ``c`` takes a constant
along-track offset (lever arm, survey datum). Fitting both at once keeps each test
free of the other signature. The noise is not assumed independent between visits:
``b`` is an offset shared by the visits of one pass (a GNSS error; passes split by
`pass_labels`) and ``g`` the horizontal survey error of each control point, seen along
the vehicle's forward direction ``f_i`` (driving past a target both ways flips its
survey error and its side together, so a survey error alone looks like a heading
error at that target). The three variances are estimated by restricted maximum
likelihood from the data, the coefficients by generalised least squares, and each
slope gets a two-sided t-test with Satterthwaite's degrees of freedom; a signature is
*significant* when ``p < 1 - level`` (``level = 0.99`` by default). Treating the
visits as independent instead would call pass and survey errors significant
signatures. A term is tested only when the data can tell it: the along-track
velocities must span at least ``MIN_SPEED_SPAN_M_S`` (2 m/s) over at least 3 passes,
and targets must be seen on both sides; otherwise it is reported as not testable and
left out of the model. Drive each speed in both directions.

References
----------
Draper, N. R. & Smith, H., *Applied Regression Analysis*, 3rd ed., Wiley 1998 (t-tests).
Patterson, H. D. & Thompson, R., Biometrika 58(3), 1971, 545-554 (REML); Satterthwaite,
F. E., Biometrics Bulletin 2(6), 1946, 110-114.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from kinsync._typing import FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.validation._common import lstsq
from kinsync.validation.differences import ControlPointDifference

__all__ = [
    "MIN_SPEED_SPAN_M_S",
    "PASS_GAP_S",
    "SignatureTest",
    "SignatureTests",
    "pass_labels",
    "signature_tests",
]

MIN_SPEED_SPAN_M_S = 2.0
"""Least span of along-track velocities for the time-error term to be tested (m/s)."""
PASS_GAP_S = 10.0
"""Time gap between visits (s) that starts a new pass of the vehicle."""
_REML_ITERATIONS = 100


@dataclass(frozen=True)
class SignatureTest:
    """A regression coefficient tested against zero (two-sided t-test).

    Attributes
    ----------
    quantity : str
        ``"time_error"`` or ``"heading_error"``.
    unit : str
        Unit of ``estimate`` and ``std`` (``"s"`` or ``"deg"``).
    estimate, std : float
        Coefficient and its standard deviation (NaN when not testable).
    t_statistic, p_value : float
        ``estimate / std`` and the two-sided p-value (NaN when not testable).
    dof : float
        Degrees of freedom of the t-test (Satterthwaite; 0 when not testable).
    level : float
        Confidence level of the test (e.g. 0.99).
    significant : bool
        ``p_value < 1 - level``.
    testable : bool
        False when the data cannot tell the term (then ``reason`` says why).
    reason : str
        Why it is not testable (empty when testable).
    """

    quantity: str
    unit: str
    estimate: float
    std: float
    t_statistic: float
    p_value: float
    dof: float
    level: float
    significant: bool
    testable: bool
    reason: str = ""

    def as_document(self) -> dict[str, Any]:
        """JSON-ready fields, keys carrying the unit."""
        q, u = self.quantity, self.unit
        return {
            f"{q}_{u}": self.estimate,
            f"{q}_std_{u}": self.std,
            "t_statistic": self.t_statistic,
            "p_value": self.p_value,
            "dof": self.dof,
            "level": self.level,
            "significant": self.significant,
            "testable": self.testable,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class SignatureTests:
    """The two signature tests of one regression and its noise estimates.

    Attributes
    ----------
    time_error, heading_error : SignatureTest
    intercept_m : float
        Constant along-track offset (m).
    residual_std_m : float
        Noise of one difference within a pass (m).
    pass_std_m : float
        Standard deviation of the offset common to a pass (m).
    survey_std_m : float
        Standard deviation of a control point's horizontal survey error, per axis (m).
    n_passes : int
        Passes found (`pass_labels`).
    """

    time_error: SignatureTest
    heading_error: SignatureTest
    intercept_m: float
    residual_std_m: float
    pass_std_m: float
    survey_std_m: float
    n_passes: int


def _untestable(quantity: str, unit: str, level: float, reason: str) -> SignatureTest:
    nan = math.nan
    return SignatureTest(
        quantity=quantity,
        unit=unit,
        estimate=nan,
        std=nan,
        t_statistic=nan,
        p_value=nan,
        dof=0.0,
        level=level,
        significant=False,
        testable=False,
        reason=reason,
    )


def pass_labels(
    differences: tuple[ControlPointDifference, ...], pass_gap_s: float = PASS_GAP_S
) -> IntArray:
    """Number the passes of the vehicle past the control field, per difference.

    In time order, a new pass starts when the time since the previous visit exceeds
    ``pass_gap_s`` or when a target already seen in the current pass comes again.

    Parameters
    ----------
    differences : tuple of ControlPointDifference, length K
        The visits' differences; each visit's time is ``observation.t_s`` (s, the
        cloud's point time scale) and its target ``observation.name``.
    pass_gap_s : float
        Time between consecutive visits (s) that starts a new pass; default
        `PASS_GAP_S` (10 s).

    Returns
    -------
    ndarray of int64, shape (K,)
        Pass number of each difference (0, 1, ...), in the order given.
    """
    order = np.argsort([d.observation.t_s for d in differences], kind="stable")
    labels = np.zeros(len(differences), dtype=np.int64)
    current = -1
    seen: set[str] = set()
    last_t = -math.inf
    for i in order:
        obs = differences[int(i)].observation
        if current < 0 or obs.t_s - last_t > pass_gap_s or obs.name in seen:
            current += 1
            seen = set()
        seen.add(obs.name)
        last_t = obs.t_s
        labels[int(i)] = current
    return labels


@dataclass(frozen=True)
class _MixedFit:
    """GLS coefficients with REML variance components and Satterthwaite dof."""

    coef: FloatArray
    cov: FloatArray
    dof: FloatArray
    sigma_e: float
    sigma_by_kernel: dict[str, float]


@dataclass(frozen=True)
class _Reml:
    """One evaluation of the REML criterion at variances ``theta``."""

    value: float
    grad: FloatArray
    P: FloatArray
    Vi: FloatArray
    C: FloatArray
    beta: FloatArray


def _reml_terms(
    theta: FloatArray, y: FloatArray, design: FloatArray, derivs: list[FloatArray]
) -> _Reml:
    """Minus twice the REML log-likelihood (no constant) and its gradient in theta.

    ``V = sum theta_a D_a`` with ``D_0 = I``; ``-2 l = log|V| + log|X'V^-1X| + y'Py``,
    ``d(-2 l)/d theta_a = tr(P D_a) - y'P D_a P y``, ``P = V^-1 - V^-1 X C X'V^-1``.
    """
    V = sum((t * D for t, D in zip(theta, derivs, strict=True)), np.zeros_like(derivs[0]))
    L = np.linalg.cholesky(V)
    Vi = np.linalg.inv(V)
    ViX = Vi @ design
    M = design.T @ ViX
    C: FloatArray = np.asarray(np.linalg.inv(M), dtype=np.float64)
    beta = C @ (ViX.T @ y)
    P = Vi - ViX @ C @ ViX.T
    Py = P @ y
    _, logdet_m = np.linalg.slogdet(M)
    value = 2.0 * float(np.sum(np.log(np.diag(L)))) + float(logdet_m) + float(y @ Py)
    grad = np.array([float(np.sum(P * D)) - float(Py @ D @ Py) for D in derivs])
    return _Reml(value, grad, P, Vi, C, beta)


def _reml_fit(y: FloatArray, design: FloatArray, named: dict[str, FloatArray]) -> _MixedFit:
    """REML variance components (noise + one per kernel), GLS and Satterthwaite dof.

    ``named`` holds the covariance patterns ``Z Z^T`` of the random effects; the
    variances (>= 0; the noise >= 1e-8 of the OLS residual variance) by projected Fisher
    scoring with step halving.
    """
    n, p = design.shape
    derivs = [np.eye(n), *named.values()]
    resid = y - design @ lstsq(design, y)
    total = max(float(resid @ resid) / max(n - p, 1), 1e-16)
    k = len(derivs)

    floor = np.full(k, 0.0)
    floor[0] = 1e-8 * total  # the noise variance stays positive: V must be invertible
    theta = np.full(k, total / k)
    fit = _reml_terms(theta, y, design, derivs)
    for _ in range(_REML_ITERATIONS):
        # Projected Fisher scoring on theta >= floor: variances at their floor that the
        # score pushes down are held; the step stops where a free one reaches its floor.
        grad = fit.grad
        PD = [fit.P @ D for D in derivs]
        info = np.array([[0.5 * float(np.sum(a * b.T)) for b in PD] for a in PD])
        free = ~((theta <= floor * (1.0 + 1e-12)) & (grad > 0.0))
        step = np.zeros(k)
        step[free] = np.linalg.pinv(info[np.ix_(free, free)]) @ (-0.5 * grad[free])
        down = step < 0.0
        reach = np.min((floor[down] - theta[down]) / step[down], initial=np.inf)
        alpha = min(1.0, float(reach))
        improved = False
        for _halving in range(30):
            trial = np.maximum(theta + alpha * step, floor)
            new = _reml_terms(trial, y, design, derivs)
            if new.value <= fit.value:
                improved = True
                break
            alpha /= 2.0
        if not improved:
            break
        moved = float(np.max(np.abs(trial - theta))) / total
        theta, fit = trial, new
        if moved < 1e-9:
            break
    # Satterthwaite: dof_j = 2 var_j^2 / (g_j' A g_j), A = inverse expected information of
    # the variances (I_ab = tr(P D_a P D_b) / 2), g_j = d var_j / d theta.
    PD = [fit.P @ D for D in derivs]
    info = np.array([[0.5 * float(np.sum(a * b.T)) for b in PD] for a in PD])
    A = np.linalg.pinv(info)
    ViX = fit.Vi @ design
    grads = np.array([np.diag(fit.C @ (ViX.T @ D @ ViX) @ fit.C) for D in derivs])
    var = np.diag(fit.C)
    denom = np.einsum("ap,ab,bp->p", grads, A, grads)
    dof = np.where(denom > 0.0, 2.0 * var**2 / np.where(denom > 0.0, denom, 1.0), n - p)
    sig = np.sqrt(theta)
    return _MixedFit(
        coef=fit.beta,
        cov=fit.C,
        dof=np.clip(dof, 1.0, max(n - p, 1)),
        sigma_e=float(sig[0]),
        sigma_by_kernel={name: float(v) for name, v in zip(named, sig[1:], strict=True)},
    )


def _forward_ne(differences: tuple[ControlPointDifference, ...]) -> FloatArray:
    """Horizontal forward unit vector (north, east) of the vehicle at each visit."""
    h = np.radians([d.heading_deg for d in differences])
    return np.column_stack([np.cos(h), np.sin(h)]).reshape(-1, 2)


def _signature_terms(
    s: FloatArray, x: FloatArray, groups: int
) -> tuple[list[FloatArray], list[str], dict[str, str]]:
    """Design columns (intercept first), the testable terms, why the others are not."""
    n = s.size
    columns = [np.ones(n)]
    names: list[str] = []
    reasons: dict[str, str] = {}
    span = float(np.ptp(s)) if n else 0.0
    if span < MIN_SPEED_SPAN_M_S:
        reasons["time"] = (
            f"along-track speeds span {span:.3g} m/s (< {MIN_SPEED_SPAN_M_S:g}): drive the "
            "targets at several speeds"
        )
    elif groups < 3:
        reasons["time"] = (
            f"{groups} pass(es): the time error rests on the passes and needs at least 3 "
            "(better: each speed in both directions)"
        )
    else:
        columns.append(s)
        names.append("time")
    if n and np.any(x < 0.0) and np.any(x > 0.0):
        columns.append(x)
        names.append("heading")
    else:
        reasons["heading"] = "targets seen on one side only: place targets on both sides"
    return columns, names, reasons


def signature_tests(
    differences: tuple[ControlPointDifference, ...],
    level: float = 0.99,
    pass_gap_s: float = PASS_GAP_S,
) -> SignatureTests:
    """Regress dY on the along-track velocity and the lateral position; t-test each slope.

    The model (a linear mixed model) is::

        dY_i = c + tau s_i - psi X_i + b_pass(i) + f_i . g_target(i) + e_i

    with three independent random terms: ``e`` the noise of one visit (variance
    ``sigma_e^2``), ``b`` an offset common to a pass (``sigma_pass^2``; passes from
    `pass_labels`: a GNSS error shared by the pass) and ``g`` a horizontal error of
    each control point's survey (``sigma_target^2`` per axis), seen along the vehicle's
    forward unit vector ``f_i``. The survey term matters: driving past a target one
    way and then the other flips both its survey error and its lateral side, so a
    survey error looks exactly like a heading error at that target, and only the
    scatter between targets tells them apart. Variance components by restricted
    maximum likelihood, coefficients by generalised least squares, each coefficient's
    t-test with Satterthwaite's degrees of freedom (small for the time error with few
    passes, or for the heading error with few targets: the test stays honest). A pass
    term needs 2 passes, a survey term a target seen twice; the time error needs 3
    passes.

    Parameters
    ----------
    differences : tuple of ControlPointDifference
    level : float
        Confidence level in (0, 1): a slope is significant when ``p < 1 - level``.
    pass_gap_s : float
        Time gap (s) between visits that starts a new pass.

    Returns
    -------
    SignatureTests

    Raises
    ------
    InputError
        ``level`` outside (0, 1), a non-positive ``pass_gap_s``.

    References
    ----------
    Patterson, H. D. & Thompson, R., "Recovery of inter-block information when block
    sizes are unequal", Biometrika 58(3), 1971, 545-554 (REML); Satterthwaite, F. E.,
    "An approximate distribution of estimates of variance components", Biometrics
    Bulletin 2(6), 1946, 110-114; Kuznetsova, A. et al., "lmerTest package", J. Stat.
    Softw. 82(13), 2017 (Satterthwaite's dof for mixed-model coefficients).
    """
    level = finite_number(level, "level")
    if not 0.0 < level < 1.0:
        msg = f"level must lie in (0, 1), e.g. 0.99, got {level}"
        raise InputError(msg)
    positive_number(pass_gap_s, "pass_gap_s")
    dy = np.array([d.diff_vehicle_m[1] for d in differences], dtype=np.float64)
    s = np.array([d.along_speed_m_s for d in differences], dtype=np.float64)
    x = np.array([d.lateral_m for d in differences], dtype=np.float64)
    labels = pass_labels(differences, pass_gap_s)
    n = dy.size
    groups = int(labels.max()) + 1 if n else 0
    columns, names, reasons = _signature_terms(s, x, groups)
    kernels: dict[str, FloatArray] = {}
    if groups >= 2:
        kernels["pass"] = (labels[:, None] == labels[None, :]).astype(np.float64)
    target = np.array([d.observation.name for d in differences])
    if n and np.unique(target).size < n:
        f = _forward_ne(differences)
        kernels["target"] = (target[:, None] == target[None, :]) * (f @ f.T)
    while n - len(columns) < 2 and names:
        dropped = names.pop()
        columns.pop()
        reasons[dropped] = f"{n} observation(s): too few to estimate the noise as well"
    while names and np.linalg.matrix_rank(np.column_stack(columns)) < len(columns):
        dropped = names.pop()
        columns.pop()
        reasons[dropped] = (
            "speed and side are confounded (each side seen at one speed only): drive every "
            "speed past targets on both sides"
        )
    if n < 2:
        reasons.update(dict.fromkeys(names, f"{n} observation(s)"))
        names = []
    fit = _reml_fit(dy, np.column_stack(columns), kernels) if n >= 2 else None
    alpha = 1.0 - level

    def test(name: str, quantity: str, unit: str, scale: float) -> SignatureTest:
        if name not in names or fit is None:
            return _untestable(quantity, unit, level, reasons[name])
        k = 1 + names.index(name)
        est, sd, dof = float(fit.coef[k]), math.sqrt(float(fit.cov[k, k])), float(fit.dof[k])
        t_coef = est / sd if sd > 0.0 else (math.copysign(math.inf, est) if est else 0.0)
        p_val = float(2.0 * stats.t.sf(abs(t_coef), dof))
        t_stat = math.copysign(1.0, scale) * t_coef  # the sign of the reported estimate
        return SignatureTest(
            quantity=quantity,
            unit=unit,
            estimate=scale * est,
            std=abs(scale) * sd,
            t_statistic=t_stat,
            p_value=p_val,
            dof=dof,
            level=level,
            significant=p_val < alpha,
            testable=True,
        )

    nan = math.nan
    return SignatureTests(
        time_error=test("time", "time_error", "s", 1.0),
        heading_error=test("heading", "heading_error", "deg", -math.degrees(1.0)),
        intercept_m=float(fit.coef[0]) if fit is not None else nan,
        residual_std_m=fit.sigma_e if fit is not None else nan,
        pass_std_m=fit.sigma_by_kernel.get("pass", 0.0) if fit is not None else nan,
        survey_std_m=fit.sigma_by_kernel.get("target", 0.0) if fit is not None else nan,
        n_passes=groups,
    )
