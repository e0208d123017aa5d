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

**No leverage correction.** Lines are not exchangeable (in a patch test with two
lines per speed and direction, deleting one removes half of what separates the latency
from the lever x), and the cluster-robust literature scales each deleted-line deviation
by the information that remains (CR2, Bell & McCaffrey 2002). That correction assumes
the errors within a line independent, which is exactly what they are not here, and it
was measured worse than the plain jackknife: spread / sigma 0.52-0.96 against
0.83-1.04 on 100 synthetic runs (roll and pitch overstated 1.7-1.9x), 0.80-1.24 against
0.86-1.23 on 140 runs of each simulated patch test. The plain delete-one jackknife is
reported: Monte Carlo (`benchmarks/bench_calibration_sigma.py --runs 100`, navigation
errors correlated over 20 s) 0.84-1.00 on the vehicle, 0.82-1.17 on the vessel (the 95 %
intervals held 92-98 % of the errors), where the formal sigma is 3.2-28x too small;
30 runs each after the latency bound (`kinsync.calibration.estimator`): 0.81-1.01 and
0.82-1.23, the 95 % intervals holding 87-100 %.

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

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import stdtrit

from kinsync._arrays import ReadOnlyArrays
from kinsync._cpus import usable_cpus
from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import (
    Adjustment,
    AdjustmentOptions,
    Observation,
    adjust,
)
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.errors import KinsyncError
from kinsync.progress import Progress, report

__all__ = ["MIN_HONEST_DOF", "MIN_JACKKNIFE_GROUPS", "Jackknife", "jackknife"]

MIN_JACKKNIFE_GROUPS = 4
"""Fewest lines (or passes) for a jackknife standard deviation."""
MIN_HONEST_DOF = 4
"""Fewest degrees of freedom of a jackknife whose sigma an estimate may rest on: with 3
(4 lines) the sigma is itself uncertain by a factor of about 2 either way (the 95 %
interval is +-3.18 sigma), and the parameters take up some of the lines' contrasts, so
fewer lines leave an estimate ``weak`` whatever its sigma
(`kinsync.calibration.estimator`)."""


@dataclass(frozen=True, eq=False)
class Jackknife(ReadOnlyArrays):
    """Delete-one-group estimates and the jackknife covariance.

    Attributes
    ----------
    groups : tuple of str
        The groups deleted in turn (line names).
    estimates : ndarray, shape (m, k)
        The estimated parameters without each group (internal units); NaN rows where
        that solution failed.
    covariance : ndarray, shape (k, k)
        Delete-one jackknife covariance (internal units); NaN when it could not be
        formed.
    failed : tuple of str
        Groups whose deleted-group solution failed (the parameters are then not
        determined without them: a warning, and no jackknife).
    """

    groups: tuple[str, ...]
    estimates: FloatArray
    covariance: FloatArray
    failed: tuple[str, ...]

    @property
    def valid(self) -> bool:
        """True when the jackknife gives a sigma for every parameter.

        Every deleted-group solution succeeded, there are enough groups, and every
        parameter's spread is finite and above zero. A spread of exactly zero is no
        sigma: every deleted-group solution returned the full one's value, i.e. none of
        them moved (a solution stuck where it started).
        """
        return (
            not self.failed
            and len(self.groups) >= MIN_JACKKNIFE_GROUPS
            and bool(np.all(np.isfinite(self.std)) and np.all(self.std > 0.0))
        )

    @property
    def dof(self) -> int:
        """Degrees of freedom of the variance: groups minus one (at most)."""
        return len(self.groups) - 1

    @property
    def honest(self) -> bool:
        """True when `valid` with at least `MIN_HONEST_DOF` degrees of freedom."""
        return self.valid and self.dof >= MIN_HONEST_DOF

    @property
    def t95(self) -> float:
        """Half-width of a two-sided 95 % interval in sigmas (Student t, `dof`)."""
        return float(stdtrit(max(self.dof, 1), 0.975))

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
    progress: Progress | None = None,
    workers: int | None = None,
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
    progress : Progress, optional
        ``progress(fraction, stage)`` (`kinsync.progress.Progress`): at 0 before the
        solutions, then at the share of them done as each one ends (in order).
    workers : int, optional
        Deleted-group solutions run at once, in threads (the georeferencing kernel
        and numpy's array work run outside the interpreter lock); default one per CPU
        the process may use, at most one per group. The result does not depend on it.

    Returns
    -------
    Jackknife
    """
    k = len(solution.estimated)
    features = [f.feature for f in solution.features]

    def without(members: set[int]) -> FloatArray | None:
        obs, seen = _without(observations, members)
        if not obs:
            return None
        try:
            sol = adjust(
                models,
                obs,
                [features[i] for i in seen],
                solution.values,
                solution.estimated,
                frame,
                options,
                [solution.features[i].sigma_m for i in seen],
            )
        except KinsyncError:
            return None
        if sol.at_bound:  # no minimum: the latency ran to the end of the trajectories
            return None
        out: FloatArray = sol.values[list(solution.estimated)]
        return out

    estimates = np.full((len(groups), k), np.nan)
    failed = []
    m = len(groups)
    n_threads = max(1, min(m, workers or usable_cpus()))
    report(progress, 0.0, f"jackknife: {m} solutions, each leaving one out, {n_threads} at once")
    with ThreadPoolExecutor(max_workers=n_threads, thread_name_prefix="kinsync-jk") as pool:
        solved = pool.map(without, [members for _, members in groups])
        for j, ((name, _), values) in enumerate(zip(groups, solved, strict=True)):
            report(progress, (j + 1) / m, f"jackknife: {j + 1} of {m} done (without {name})")
            if values is None:
                failed.append(name)
            else:
                estimates[j] = values
    cov = np.full((k, k), np.nan)
    if not failed and m >= 2:
        dev = estimates - estimates.mean(axis=0)
        cov = (m - 1) / m * (dev.T @ dev)
    return Jackknife(
        groups=tuple(name for name, _ in groups),
        estimates=estimates,
        covariance=cov,
        failed=tuple(failed),
    )
