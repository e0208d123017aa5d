"""Honest standard deviations: the jackknife over lines (or passes).

The formal covariance ``sigma0^2 S^-1`` of the adjustment assumes independent errors
from return to return. Real errors are not: a navigation solution's position and
attitude errors are correlated over tens of seconds, so every return of a line (or a
pass over a target) shares most of them, and a range bias is shared by a whole pass.
The formal sigma is then far too small (on the CIDCO vessel passes the heading
boresight's is ~13x smaller than the pass-to-pass scatter).

The delete-one jackknife over lines makes no assumption on the error structure within
a line; it needs the lines' errors to be independent of each other (lines flown
minutes apart, longer than the navigation errors' correlation time)::

    theta_(j)  = the solution without line j          (j = 1 .. m)
    var_jack   = (m - 1) / m * sum_j (theta_(j) - mean_j theta_(j))^2

Each deleted-line solution starts from the full one. With few lines the estimate is
itself uncertain (about m - 1 degrees of freedom); `MIN_JACKKNIFE_GROUPS` lines are
required, else the formal sigma is reported and the output says so.

**Noise scales held.** Each deleted-line solution keeps the full solution's noise
scale of every feature. Re-estimated, they come out smaller (the line-to-line
disagreement they measured left with the line), reweight the features and move the
estimate for reasons that have nothing to do with the deleted line: on the simulated
vehicle patch test that made the jackknife sigma 1.2-1.3x too large (Monte Carlo ratio
of the spread to the sigma 0.59-0.77; 0.74-0.99 with the scales held).

**Leverage.** Lines are not exchangeable: in a patch test with two lines per speed
and direction, deleting one line removes half of what separates the latency from the
lever x, and the plain jackknife (the CR3 estimator of the cluster-robust literature)
then overstates the variance. Each deleted-line deviation is therefore scaled by the
square root of the information that remains (CR2, Bell & McCaffrey 2002;
`_leverage_corrected`): unbiased for independent errors within a line, and equal to
the plain jackknife when the lines are alike (ratio 0.83-1.07 on the vehicle patch
test, `benchmarks/bench_calibration_sigma.py`).

**Its own uncertainty.** From m lines the jackknife variance has at most m - 1
degrees of freedom, fewer when the parameters take up the lines' contrasts (3-6 for
8 lines in the Monte Carlo): honest on average, it can be several times off in one
calibration. Intervals should use Student's t with m - 1 degrees of freedom
(`Jackknife.t95`), which the output gives.

References
----------
Bell, R. M. & McCaffrey, D. F., "Bias reduction in standard errors for linear
regression with multi-stage samples", Survey Methodology 28(2), 2002, 169-181.
Efron, B. & Stein, C., "The jackknife estimate of variance", Ann. Stat. 9(3), 1981,
586-596. Cameron, A. C., Gelbach, J. B. & Miller, D. L., "Bootstrap-based improvements
for inference with clustered errors", Rev. Econ. Stat. 90(3), 2008, 414-427 (clusters).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import t as student_t

from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import (
    Adjustment,
    AdjustmentOptions,
    Observation,
    adjust,
    reduced_normal_matrix,
)
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.errors import KinsyncError

__all__ = ["MIN_JACKKNIFE_GROUPS", "Jackknife", "jackknife"]

MIN_JACKKNIFE_GROUPS = 4
"""Fewest lines (or passes) for a jackknife standard deviation."""


@dataclass(frozen=True, eq=False)
class Jackknife:
    """Delete-one-group estimates and the jackknife covariance.

    Attributes
    ----------
    groups : tuple of str
        The groups deleted in turn (line names).
    estimates : ndarray, shape (m, k)
        The estimated parameters without each group (internal units); NaN rows where
        that solution failed.
    covariance : ndarray, shape (k, k)
        Jackknife covariance with the leverage correction (internal units); NaN when
        it could not be formed.
    covariance_plain : ndarray, shape (k, k)
        The plain delete-one jackknife covariance (no leverage correction).
    failed : tuple of str
        Groups whose deleted-group solution failed (the parameters are then not
        determined without them: a warning, and no jackknife).
    """

    groups: tuple[str, ...]
    estimates: FloatArray
    covariance: FloatArray
    covariance_plain: FloatArray
    failed: tuple[str, ...]

    @property
    def valid(self) -> bool:
        """True when every deleted-group solution succeeded and there are enough groups."""
        return not self.failed and len(self.groups) >= MIN_JACKKNIFE_GROUPS

    @property
    def dof(self) -> int:
        """Degrees of freedom of the variance: groups minus one (at most)."""
        return len(self.groups) - 1

    @property
    def t95(self) -> float:
        """Half-width of a two-sided 95 % interval in sigmas (Student t, `dof`)."""
        return float(student_t.ppf(0.975, max(self.dof, 1)))

    @property
    def std(self) -> FloatArray:
        """Jackknife standard deviations (internal units), shape (k,)."""
        out: FloatArray = np.sqrt(np.diag(self.covariance))
        return out


def _without(
    observations: Sequence[Observation], group: set[int]
) -> tuple[list[Observation], list[int]]:
    """Observations outside ``group``'s lines, features renumbered; the features kept."""
    kept = [o for o in observations if o.line not in group]
    seen = sorted({o.feature for o in kept})
    renumber = {old: new for new, old in enumerate(seen)}
    return [replace(o, feature=renumber[o.feature]) for o in kept], seen


def jackknife(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    solution: Adjustment,
    frame: LocalFrame,
    groups: Sequence[tuple[str, set[int]]],
    options: AdjustmentOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> Jackknife:
    """Re-solve without each group of lines and form the jackknife covariance.

    Parameters
    ----------
    models, observations, frame
        As given to `kinsync.calibration.adjustment.adjust`.
    solution : Adjustment
        The full solution (start of every deleted-group solution).
    groups : sequence of (name, set of line indices)
        The independent units: one line each, or the lines of one pass.
    options : AdjustmentOptions, optional
    progress : callable, optional
        Called with a short message before each deleted-group solution.

    Returns
    -------
    Jackknife
    """
    k = len(solution.estimated)
    features = [f.feature for f in solution.features]
    estimates = np.full((len(groups), k), np.nan)
    normals = np.full((len(groups), k, k), np.nan)
    failed = []
    for j, (name, members) in enumerate(groups):
        if progress is not None:
            progress(f"jackknife: without {name} ({j + 1} of {len(groups)})")
        obs, seen = _without(observations, members)
        feats = [features[i] for i in seen]
        if not obs:
            failed.append(name)
            continue
        try:
            sol = adjust(
                models,
                obs,
                feats,
                solution.values,
                solution.estimated,
                frame,
                options,
                [solution.features[i].sigma_m for i in seen],
            )
        except KinsyncError:
            failed.append(name)
            continue
        estimates[j] = sol.values[list(solution.estimated)]
        # The information left without the group, at the full solution and with its
        # noise scales (a deleted-line solution re-estimates them smaller: the
        # line-to-line disagreement it measured is gone).
        normals[j] = reduced_normal_matrix(
            models,
            obs,
            feats,
            solution.values,
            solution.estimated,
            frame,
            [solution.features[i].sigma_m for i in seen],
        )[0]
    m = len(groups)
    cov = plain = np.full((k, k), np.nan)
    if not failed and m >= 2:
        dev = estimates - estimates.mean(axis=0)
        plain = (m - 1) / m * (dev.T @ dev)
        theta = solution.values[list(solution.estimated)]
        sigmas = [f.sigma_m for f in solution.features]
        S = reduced_normal_matrix(
            models, observations, features, solution.values, solution.estimated, frame, sigmas
        )[0]
        cov = _leverage_corrected(estimates - theta, normals, S)
    return Jackknife(
        groups=tuple(name for name, _ in groups),
        estimates=estimates,
        covariance=cov,
        covariance_plain=plain,
        failed=tuple(failed),
    )


def _sym_power(M: FloatArray, power: float) -> FloatArray:
    """``M^power`` of a symmetric positive semi-definite matrix, a pseudo-power.

    Directions with no information (eigenvalue below 1e-12 of the largest) get 0.
    """
    w, v = np.linalg.eigh(0.5 * (M + M.T))
    keep = w > 1e-12 * max(float(np.max(w)), 1e-300)
    scaled = np.zeros_like(w)
    scaled[keep] = w[keep] ** power
    out: FloatArray = (v * scaled) @ v.T
    return out


def _leverage_corrected(dev: FloatArray, normals: FloatArray, S: FloatArray) -> FloatArray:
    """``sum_j a_j a_j'`` with ``a_j = S^-1/2 (S^-1/2 S_(j) S^-1/2)^1/2 S^1/2 d_j``.

    ``d_j`` is the change of the estimate when group ``j`` is deleted and ``S_(j)`` the
    information left without it. In a linear model ``d_j = -(I - L_j)^-1 u_j`` with
    ``u_j = S^-1 g_j`` group ``j``'s own pull and ``L_j = S^-1 (S - S_(j))`` its
    leverage: the plain jackknife squares ``(I - L_j)^-1 u_j`` (the CR3 estimator),
    which overstates the variance when some groups weigh more than others (the only
    lines at one speed); ``(I - L_j)^-1/2 u_j`` is CR2, unbiased for independent
    errors within a group. With exchangeable groups (``S_(j) = (m - 1)/m S``) it equals
    the plain jackknife.
    """
    root = _sym_power(S, 0.5)
    inv_root = _sym_power(S, -0.5)
    k = S.shape[0]
    cov = np.zeros((k, k))
    for d, Sj in zip(dev, normals, strict=True):
        M = inv_root @ Sj @ inv_root
        a = inv_root @ (_sym_power(M, 0.5) @ (root @ d))
        cov += np.outer(a, a)
    return cov
