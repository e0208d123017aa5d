"""Method A: errors shared by the points of a pass, measured from the passes' own centres.

Each pool (the passes at one signed rate) gives one sphere centre fitted to all its
points, and that fit's covariance counts the points' range noise only. An error shared
by every point of a pass moves the whole pass: the INS's attitude error drifts between
passes (0.003 deg of heading moves a sphere 1.5 m away by 0.08 mm, as much as a 2 ms
latency at 2 deg/s), the table's regulation, the scanner's warm-up. Averaging more
points of the same pass does not reduce it; averaging more passes does. Left out of the
covariance, it made the latency sigma 1.3-2.4 times too small with 0.002-0.005 deg per
pass, and the rates still "agreed".

Here every pass's own centre is fitted (radius fixed at its pool's, same points, same
range model), and the passes' scatter about their pool is compared with what their own
covariances allow:

- Cochran's Q, ``sum_i (c_i - c_w)^T C_i^-1 (c_i - c_w)`` about each pool's weighted
  mean ``c_w``, summed over the pools, is chi-square with ``3 sum_k (n_k - 1)`` degrees of
  freedom when the passes share no error: the test;
- the between-pass covariance ``B`` (3 x 3, table-centred NED), one for all pools, by
  restricted maximum likelihood (REML): each pass's centre ~ N(pool mean, C_i + B),
  the pool means profiled out, ``B`` parametrised by its log-Cholesky factor (positive
  semi-definite by construction; zero when no positive ``B`` is more likely);
- each rate magnitude's passes are tested against that ``B`` (Q with ``C_i + B``): a
  rate whose passes scatter more (an error that grows with the rate, as a gyro
  scale-factor error's does) gets its own ``B`` from its pools alone;
- each pool's centre covariance then gains ``A (sum_i W_i B W_i) A`` with
  ``W_i = C_i^-1`` and ``A = (sum_i W_i)^-1``: the error of its weighted mean of
  passes that each carry ``B``.

With one pass per pool nothing measures ``B``: the result says so (`PassScatter.measured`)
and the latency sigma counts the points' noise only.

References
----------
DerSimonian, R., Laird, N., "Meta-analysis in clinical trials", Controlled Clinical
Trials 7 (1986) 177-188 (random effects between studies, Q); Jackson, D.,
White, I. R., Thompson, S. G., "Extending DerSimonian and Laird's methodology to
perform multivariate random effects meta-analyses", Stat. Med. 29 (2010) 1282-1297.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize, stats

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._text import format_p_value
from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.errors import ConvergenceError, InputError
from kinsync.fit import fit_sphere

__all__ = [
    "CHECK_UPPER_P",
    "PASS_SCATTER_P",
    "RATE_SCATTER_P",
    "PassCentres",
    "PassScatter",
    "RateScatter",
    "estimate_pass_scatter",
    "fit_pass_centres",
    "pool_scatter_cov_m2",
]

PASS_SCATTER_P = 0.01
"""Below this p-value of the passes' Q test the passes are said to scatter beyond their
points' noise (the covariance is added whatever the p-value)."""


RATE_SCATTER_P = 0.01
"""Below this p-value of one rate's passes against the scatter shared by all rates, that
rate carries its own (`RateScatter`)."""

CHECK_UPPER_P = 1e-3
"""The rotation-model test (`kinsync.latency.model_check`) counts the passes' scatter at
its upper bound at this level (`PassScatter.upper_cov_m2`)."""


@dataclass(frozen=True, eq=False)
class PassCentres(ReadOnlyArrays):
    """The sphere centre of each pass of one pool, fitted on its own.

    Attributes
    ----------
    centers_ned_m : ndarray, shape (N, 3)
        Each pass's centre, table-centred NED (m); NaN where its own fit failed.
    covs_m2 : ndarray, shape (N, 3, 3)
        Their covariances from the points' noise (m^2); NaN where the fit failed.
    """

    centers_ned_m: FloatArray
    covs_m2: FloatArray

    def __post_init__(self) -> None:
        centres = np.asarray(self.centers_ned_m, dtype=np.float64)
        covs = np.asarray(self.covs_m2, dtype=np.float64)
        if centres.ndim != 2 or centres.shape[1] != 3 or covs.shape != (len(centres), 3, 3):
            msg = (
                f"PassCentres: centres of shape {centres.shape} and covariances of shape "
                f"{covs.shape}; expected (N, 3) and (N, 3, 3)"
            )
            raise InputError(msg)
        object.__setattr__(self, "centers_ned_m", readonly_array(centres))
        object.__setattr__(self, "covs_m2", readonly_array(covs))

    @property
    def usable(self) -> BoolArray:
        """Boolean mask (N,): passes whose own fit gave a finite centre and covariance."""
        centre_ok = np.all(np.isfinite(self.centers_ned_m), axis=1)
        cov_ok = np.all(np.isfinite(self.covs_m2.reshape(-1, 9)), axis=1)
        ok: BoolArray = np.logical_and(centre_ok, cov_ok)
        return ok


@dataclass(frozen=True, eq=False)
class PassScatter(ReadOnlyArrays):
    """The passes' scatter about their pools beyond their points' noise.

    Attributes
    ----------
    cov_m2 : ndarray, shape (3, 3)
        Between-pass covariance of a pass's centre, table-centred NED (m^2); zero when
        not measured or not positive.
    chi2 : float
        Cochran's Q summed over the pools (nan when not measured).
    dof : int
        ``3 * sum_k (n_k - 1)`` over the pools' passes with a centre; 0: not measured.
    n_passes : int
        Passes whose own centre entered.
    n_pools : int
        Pools with at least two such passes.
    rates : tuple of RateScatter
        Per rate magnitude, its passes tested against ``cov_m2`` (an error that grows
        with the rate, as a gyro scale-factor error's does, is not one covariance for
        all); empty when not tested.
    """

    cov_m2: FloatArray
    chi2: float
    dof: int
    n_passes: int
    n_pools: int
    rates: tuple[RateScatter, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "cov_m2", readonly_array(self.cov_m2))

    def for_rate(self, rate_deg_s: float) -> PassScatter:
        """The scatter the pools at this rate magnitude carry.

        Their own where their passes rejected the common one (`RateScatter.own`), else
        this one.

        Parameters
        ----------
        rate_deg_s : float
            The pools' rate (deg/s; its magnitude counts).
        """
        for r in self.rates:
            if r.rate_deg_s == abs(rate_deg_s) and r.own is not None:
                return r.own
        return self

    @property
    def measured(self) -> bool:
        """True when at least one pool had two passes with their own centres."""
        return self.dof > 0

    @property
    def p_value(self) -> float:
        """Probability of a Q at least this large if the passes share no error (nan: none)."""
        return float(stats.chi2.sf(self.chi2, self.dof)) if self.measured else math.nan

    @property
    def significant(self) -> bool:
        """True when the Q test rejects "no error shared by a pass" (p < `PASS_SCATTER_P`)."""
        return self.measured and self.p_value < PASS_SCATTER_P

    def upper_cov_m2(self, p: float = CHECK_UPPER_P) -> FloatArray:
        """The covariance scaled to an upper confidence bound, for tests of the model.

        ``cov_m2 * nu / chi2.ppf(p, nu)`` with ``nu = dof / 3`` passes' degrees of
        freedom per direction: with few passes the measured scatter can fall well below
        the true one, and a test of the centres against the rotation model that trusted
        it would refuse correct input whose passes share an error (Monte Carlo: 2 passes
        per rate and direction at 0.003 deg per pass gave a rotation-model chi2 of 43 on
        2 dof). Zero stays zero: no measured scatter, no widening.

        Parameters
        ----------
        p : float
            Lower-tail probability of the chi-square quantile (0 < p < 1).

        Returns
        -------
        ndarray, shape (3, 3)
            NED (m^2).
        """
        if not self.measured:
            return np.array(self.cov_m2)
        nu = self.dof // 3
        out: FloatArray = self.cov_m2 * (nu / float(stats.chi2.ppf(p, nu)))
        return out

    @property
    def std_m(self) -> float:
        """Largest between-pass standard deviation of a centre, over directions (m)."""
        return float(math.sqrt(max(0.0, float(np.linalg.eigvalsh(self.cov_m2)[-1]))))

    @property
    def direction_ned(self) -> FloatArray:
        """Unit vector (3,), NED, of that largest scatter (sign arbitrary; zeros if none)."""
        values, vectors = np.linalg.eigh(self.cov_m2)
        if values[-1] <= 0.0:
            return np.zeros(3)
        d: FloatArray = vectors[:, -1] * np.sign(vectors[np.argmax(np.abs(vectors[:, -1])), -1])
        return d

    def text(self) -> str:
        """The scatter and its test in words.

        E.g. ``passes scatter 0.081 mm beyond their points' noise (Q 96.3 on 54 dof,
        p < 0.001); the sigma includes it``.
        """
        if not self.measured:
            return (
                "pass-to-pass scatter not measured (one pass per rate and direction): the "
                "sigma counts the points' noise only, not an attitude error shared by a pass"
            )
        test = f"Q {self.chi2:.1f} on {self.dof} dof, {format_p_value(self.p_value)}"
        if self.significant:
            text = (
                f"passes scatter {self.std_m * 1e3:.3f} mm beyond their points' noise "
                f"({test}); the sigma includes it"
            )
        else:
            text = f"passes agree with their points' noise ({test})"
        return text + "".join(f"; {r.text()}" for r in self.rates if r.own is not None)

    def as_document(self) -> dict[str, Any]:
        """JSON-ready summary (``pass_scatter`` of ``kinsync latency sphere --json``)."""
        return {
            "measured": self.measured,
            "std_mm": self.std_m * 1e3,
            "direction_ned": self.direction_ned.tolist(),
            "cov_mm2": (self.cov_m2 * 1e6).tolist(),
            "chi2": self.chi2 if self.measured else None,
            "dof": self.dof,
            "p_value": self.p_value if self.measured else None,
            "significant": self.significant,
            "n_passes": self.n_passes,
            "n_pools": self.n_pools,
            "rates": [r.as_document() for r in self.rates],
        }


@dataclass(frozen=True, eq=False)
class RateScatter:
    """The passes at one rate magnitude against the scatter shared by all rates.

    Attributes
    ----------
    rate_deg_s : float
        Rate magnitude (deg/s); its pools of both signs.
    chi2 : float
        Q of its passes about their pools with the points' noise plus the common
        between-pass covariance (``PassScatter.cov_m2``).
    dof : int
        ``3 * sum_k (n_k - 1)`` over its pools.
    own : PassScatter or None
        Its own between-pass scatter (from its pools alone), when ``chi2`` rejects the
        common one (p < `RATE_SCATTER_P`); None when the common one holds.
    """

    rate_deg_s: float
    chi2: float
    dof: int
    own: PassScatter | None

    @property
    def p_value(self) -> float:
        """Probability of a Q at least this large if the common scatter holds here."""
        return float(stats.chi2.sf(self.chi2, self.dof)) if self.dof > 0 else math.nan

    def text(self) -> str:
        """Why this rate carries its own scatter, in words; "" when it does not."""
        if self.own is None:
            return ""
        return (
            f"at {self.rate_deg_s:g} deg/s they scatter more than that (Q {self.chi2:.1f} on "
            f"{self.dof} dof, {format_p_value(self.p_value)}): that rate carries its own, "
            f"{self.own.std_m * 1e3:.3f} mm"
        )

    def as_document(self) -> dict[str, Any]:
        """JSON-ready: rate, Q against the common scatter, dof, p, own scatter (mm) or null."""
        return {
            "rate_deg_s": self.rate_deg_s,
            "chi2": self.chi2,
            "dof": self.dof,
            "p_value": self.p_value if self.dof > 0 else None,
            "own_std_mm": None if self.own is None else self.own.std_m * 1e3,
        }


_MIN_PASS_POINTS = 10


def fit_pass_centres(
    points_ned_m: FloatArray,
    pass_bounds: IntArray,
    used: BoolArray,
    radius_m: float,
    origin_ned_m: FloatArray | None,
) -> PassCentres:
    """Fit each pass's own sphere centre on the points its pool's fit used.

    Parameters
    ----------
    points_ned_m : ndarray, shape (N, 3)
        The pool's points, passes one after the other (table-centred NED, m).
    pass_bounds : ndarray of int, shape (P + 1,)
        Pass k holds rows ``pass_bounds[k]:pass_bounds[k + 1]``.
    used : ndarray of bool, shape (N,)
        The points the pool's final centre fit used.
    radius_m : float
        The pool's radius (given or fitted, m), held fixed: a pass's centre is then
        not traded against its radius along its few viewing directions.
    origin_ned_m : ndarray, shape (3,), optional
        Scanner origin for the range model; None fits orthogonal distances.

    Returns
    -------
    PassCentres
        NaN rows for passes with fewer than 10 used points or whose own fit fails.
    """
    n = len(pass_bounds) - 1
    centres = np.full((n, 3), np.nan)
    covs = np.full((n, 3, 3), np.nan)
    for k in range(n):
        rows = slice(int(pass_bounds[k]), int(pass_bounds[k + 1]))
        pts = points_ned_m[rows][used[rows]]
        if len(pts) < _MIN_PASS_POINTS:
            continue
        try:
            fit = fit_sphere(pts, radius_m=radius_m, origin_m=origin_ned_m)
        except (InputError, ConvergenceError):
            continue
        centres[k] = fit.center_m
        covs[k] = fit.cov_center_m2
    return PassCentres(centres, covs)


def _pool_groups(pools: Sequence[PassCentres]) -> tuple[list[tuple[FloatArray, FloatArray]], int]:
    """Each pool's usable centres (about their plain mean) and covariances; passes used."""
    groups = []
    n_passes = 0
    for pool in pools:
        ok = pool.usable
        n_passes += int(np.count_nonzero(ok))
        if np.count_nonzero(ok) >= 2:
            c = pool.centers_ned_m[ok]
            groups.append((c - c.mean(axis=0), np.array(pool.covs_m2[ok])))
    return groups, n_passes


def _q_statistic(
    groups: Sequence[tuple[FloatArray, FloatArray]], between: FloatArray | None = None
) -> float:
    """Cochran's Q summed over the pools: each pass's centre about its pool's weighted mean.

    With ``between``, each pass's covariance is its own plus it.
    """
    q = 0.0
    for c, cov in groups:
        weights = np.linalg.inv(cov if between is None else cov + between)
        c_w = np.linalg.solve(weights.sum(axis=0), np.einsum("nij,nj->i", weights, c))
        d = c - c_w
        q += float(np.einsum("ni,nij,nj->", d, weights, d))
    return q


@dataclass(frozen=True)
class _Stacked:
    """Every pool's centres and covariances one after the other, for the likelihood."""

    centres: FloatArray  # (N, 3), each pool's about its plain mean
    covs: FloatArray  # (N, 3, 3)
    starts: IntArray  # (P,), first row of each pool

    @classmethod
    def of(cls, groups: Sequence[tuple[FloatArray, FloatArray]], scale: float) -> _Stacked:
        sizes = [len(c) for c, _ in groups]
        return cls(
            np.concatenate([c for c, _ in groups]) / scale,
            np.concatenate([cov for _, cov in groups]) / scale**2,
            np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64),
        )


def _reml_nll(between: FloatArray, data: _Stacked) -> tuple[float, FloatArray]:
    """Restricted negative log-likelihood of the pass centres, and its gradient in ``B``.

    Each pool's mean is a nuisance (profiled out: its GLS estimate and its log-determinant
    term), so the estimate is not biased low by the means fitted (REML). The gradient
    (3 x 3, symmetric) is ``(sum_i W_i - W_i d_i d_i^T W_i - W_i S^-1 W_i) / 2`` with
    ``W_i = (C_i + B)^-1`` and ``S`` the sum of a pool's ``W_i``.
    """
    v = data.covs + between
    sign, logdet_v = np.linalg.slogdet(v)
    if np.any(sign <= 0):
        return math.inf, np.zeros((3, 3))
    w = np.linalg.inv(v)
    sizes = np.diff([*data.starts, len(w)])
    w_sum = np.add.reduceat(w, data.starts, axis=0)
    wc_sum = np.add.reduceat(np.einsum("nij,nj->ni", w, data.centres), data.starts, axis=0)
    means = np.linalg.solve(w_sum, wc_sum[..., None])[..., 0]
    d = data.centres - np.repeat(means, sizes, axis=0)
    total = float(logdet_v.sum()) + float(np.linalg.slogdet(w_sum)[1].sum())
    wd = np.einsum("nij,nj->ni", w, d)
    total += float(np.einsum("ni,ni->", d, wd))
    s_inv = np.repeat(np.linalg.inv(w_sum), sizes, axis=0)
    grad = w.sum(axis=0) - wd.T @ wd - np.einsum("nij,njk,nkl->il", w, s_inv, w)
    return 0.5 * total, 0.5 * (grad + grad.T) / 2.0


def _from_log_cholesky(theta: FloatArray) -> FloatArray:
    low = np.zeros((3, 3))
    low[np.tril_indices(3)] = theta
    low[np.diag_indices(3)] = np.exp(np.diag(low))
    out: FloatArray = low @ low.T
    return out


_LOG_FLOOR = -12.0  # exp(-12) of a pass's own sigma: no scatter


def _moment_start(groups: Sequence[tuple[FloatArray, FloatArray]], scale: float) -> FloatArray:
    """Log-Cholesky start from the method of moments (scaled units).

    The passes' plain scatter about their pools less what their own covariances explain,
    made positive definite.
    """
    scatter = sum(c.T @ c for c, _ in groups)  # centres are about their pool's plain mean
    noise = sum((1.0 - 1.0 / len(c)) * cov.sum(axis=0) for c, cov in groups)
    moment = (scatter - noise) / (sum(len(c) - 1 for c, _ in groups) * scale**2)
    values, vectors = np.linalg.eigh(0.5 * (moment + moment.T))
    pd = (vectors * np.clip(values, 0.05, None)) @ vectors.T
    low = np.linalg.cholesky(pd)
    theta: FloatArray = low[np.tril_indices(3)]
    theta[[0, 2, 5]] = np.log(theta[[0, 2, 5]])
    return theta


def _reml_between(groups: Sequence[tuple[FloatArray, FloatArray]]) -> FloatArray:
    """REML estimate of the between-pass covariance (m^2): log-Cholesky, two starts.

    Starts: small (a twentieth of a pass's own sigma) and the method of moments' estimate
    (which reaches a scatter of thousands of a pass's own sigmas: a quiet scanner on a
    drifting INS). Zero when no positive covariance is more likely than none.
    """
    scale = math.sqrt(float(np.median([np.trace(cov) / 3.0 for _, cov in groups for cov in cov])))
    scaled = _Stacked.of(groups, scale)
    best_b = np.zeros((3, 3))
    best_nll = _reml_nll(best_b, scaled)[0]
    diag = np.array([0, 2, 5])
    diag_rc = np.arange(3)
    small = np.zeros(6)
    small[diag] = -3.0
    moment = _moment_start(groups, scale)
    ceiling = max(float(np.max(moment[diag])), 0.0) + 5.0

    rows, cols = np.tril_indices(3)

    def nll(theta: FloatArray) -> tuple[float, FloatArray]:
        theta = theta.copy()
        theta[diag] = np.clip(theta[diag], _LOG_FLOOR, ceiling)  # no scatter .. huge
        low = np.zeros((3, 3))
        low[rows, cols] = theta
        low[diag_rc, diag_rc] = np.exp(theta[diag])
        value, grad_b = _reml_nll(low @ low.T, scaled)
        grad_low = 2.0 * grad_b @ low  # d/dL of f(L L^T), G symmetric
        grad = grad_low[rows, cols]
        grad[diag] *= np.exp(theta[diag])  # log-diagonal
        return value, grad

    for theta0 in (small, moment):
        res = optimize.minimize(
            nll,
            theta0,
            jac=True,
            method="BFGS",  # scipy's L-BFGS-B costs 1 ms a step here, 20x the likelihood
            options={"gtol": 1e-6},
        )
        if res.fun < best_nll:
            theta = np.array(res.x)
            theta[diag] = np.clip(theta[diag], _LOG_FLOOR, ceiling)
            best_nll, best_b = float(res.fun), _from_log_cholesky(theta)
    out: FloatArray = best_b * scale**2
    return out


def estimate_pass_scatter(
    pools: Sequence[PassCentres], rates_deg_s: Sequence[float] | None = None
) -> PassScatter:
    """The between-pass covariance shared by all pools, with its chi-square test.

    Parameters
    ----------
    pools : sequence of PassCentres
        Each pool's passes' own centres (table-centred NED, m) and covariances (m^2).
    rates_deg_s : sequence of float, optional
        Each pool's rate (deg/s; the magnitude groups them): each rate's passes are
        then tested against the common covariance, and a rate that rejects it (p <
        `RATE_SCATTER_P`) gets its own (`PassScatter.rates`, `PassScatter.for_rate`).

    Returns
    -------
    PassScatter
        ``measured`` False (zero covariance) when no pool has two passes with a centre.
    """
    groups, n_passes = _pool_groups(pools)
    if not groups:
        return PassScatter(np.zeros((3, 3)), math.nan, 0, n_passes, 0)
    dof = 3 * sum(len(c) - 1 for c, _ in groups)
    common = _reml_between(groups)
    rates: tuple[RateScatter, ...] = ()
    if rates_deg_s is not None:
        rates = _rate_scatters(pools, rates_deg_s, common)
    return PassScatter(common, _q_statistic(groups), dof, n_passes, len(groups), rates)


def _rate_scatters(
    pools: Sequence[PassCentres], rates_deg_s: Sequence[float], common: FloatArray
) -> tuple[RateScatter, ...]:
    """Each rate magnitude's passes against the common covariance; their own if rejected."""
    if len(rates_deg_s) != len(pools):
        msg = f"estimate_pass_scatter: {len(pools)} pools but {len(rates_deg_s)} rates"
        raise InputError(msg)
    out = []
    for rate in sorted({abs(float(r)) for r in rates_deg_s}):
        mine = [p for p, r in zip(pools, rates_deg_s, strict=True) if abs(float(r)) == rate]
        groups, _ = _pool_groups(mine)
        if not groups:
            continue
        dof = 3 * sum(len(c) - 1 for c, _ in groups)
        chi2 = _q_statistic(groups, common)
        own = None
        if stats.chi2.sf(chi2, dof) < RATE_SCATTER_P:
            own = estimate_pass_scatter(mine)
        out.append(RateScatter(rate, chi2, dof, own))
    return tuple(out)


def pool_scatter_cov_m2(centres: PassCentres, scatter: PassScatter) -> FloatArray:
    """What the between-pass covariance adds to one pool's centre covariance.

    Parameters
    ----------
    centres : PassCentres
        The pool's passes' own centres and covariances (weights ``W_i = C_i^-1``).
    scatter : PassScatter
        The between-pass covariance ``B`` (NED, m^2).

    Returns
    -------
    ndarray, shape (3, 3)
        ``A (sum_i W_i B W_i) A`` with ``A = (sum_i W_i)^-1`` (m^2), over the passes with
        a centre; ``B`` itself when none has one (the pool's one pass carries it whole).
    """
    ok = centres.usable
    if not np.any(ok):
        return np.array(scatter.cov_m2)
    weights = np.linalg.inv(centres.covs_m2[ok])
    a = np.linalg.inv(weights.sum(axis=0))
    inner = np.einsum("nij,jk,nkl->il", weights, scatter.cov_m2, weights)
    out: FloatArray = a @ inner @ a
    return 0.5 * (out + out.T)
