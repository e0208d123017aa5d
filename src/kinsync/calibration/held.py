"""What the parameters a calibration holds do to those it estimates.

A calibration holds some mount parameters at their prior values: those not asked for
(``fixed``) and those the data cannot determine (``unobservable``). The estimates are
then right only if those priors are. A lever arm taped 3 cm off aliases into the
latency and the boresight (on the simulated vehicle patch test, 3/-2/4 cm moved the
latency from 5 to 7-11 ms with ``--estimate boresight,latency``), and the jackknife
over lines cannot see it: every line shares the error.

Linearised at the solution, with the features eliminated as in the adjustment
(`kinsync.calibration.adjustment`), the reduced normal matrix over all seven
parameters, split into the estimated (e) and the held (h) ones, gives how the estimates
follow a change of the held values (the "consider" parameters of orbit determination,
Schmidt 1966; Bierman 1977, ch. VI)::

    D       = -S_ee^-1 S_eh                 (k x 7; zero columns for the estimated)
    C_held  = D Sigma_h D'                  (Sigma_h from the mount's [uncertainty])
    C_total = C_data + C_held

``C_data`` is the jackknife over lines (or the formal covariance); the held priors'
errors are independent of the lines' errors, so the two add. ``Sigma_h`` holds the
stated standard deviations and, where ``[uncertainty.correlation]`` gives them, their
correlations: a calibration's estimates are correlated, and a later calibration that
holds several of them must not take their errors as independent. The calibrated
mount's ``[uncertainty]`` carries the joint covariance of every value it states: the
estimates' ``C_total``, the held values' ``Sigma_h`` and between them ``D Sigma_h``
(an estimate follows the held values' errors). A held parameter whose
standard deviation the mount does not give is taken as exact: its column of ``D`` is
still reported (per `REFERENCE_ERRORS`), and the calibration's advice names it where
that error would move an estimate by more than half its sigma.

References
----------
Schmidt, S. F., "Application of state-space methods to navigation problems", Advances
in Control Systems 3, 1966, 293-340. Bierman, G. J., Factorization Methods for Discrete
Sequential Estimation, Academic Press, 1977 (consider covariance, ch. VI).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import Adjustment, Observation, reduced_normal_matrix
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.calibration.observability import (
    UNOBSERVABLE_THRESHOLDS,
    HeldAfterSolution,
    correlation,
    hold_after_solution,
)
from kinsync.calibration.parameters import (
    BORESIGHT,
    LATENCY,
    LEVER,
    PARAMETER_NAMES,
    REPORT_SCALE,
)
from kinsync.mount import (
    MAX_ANGLE_DEG,
    MAX_LATENCY_S,
    MAX_LEVER_ARM_M,
    Mount,
    MountUncertainty,
    StdCorrelation,
    nearest_correlation,
)

__all__ = [
    "REFERENCE_ERRORS",
    "REFERENCE_TEXT",
    "HeldEffect",
    "covariance_of_uncertainty",
    "effect_of_held",
    "held_covariance",
    "held_effect",
    "held_std",
    "hold_too_uncertain",
    "joint_covariance",
    "std_of_uncertainty",
    "uncertainty_from_covariance",
    "uncertainty_from_std",
    "uncertainty_notes",
]

REFERENCE_ERRORS: FloatArray = np.array([0.1, 0.1, 0.1, 0.01, 0.01, 0.01, 1.0])
"""A plausible error of a held value with no stated sigma (report units: deg, m, ms):
what a tape, a drawing or an earlier calibration leaves. The sensitivities are given per
this much, and the advice names a held value whose this much moves an estimate by more
than `ADVICE_SHARE` of its sigma."""
REFERENCE_TEXT = ("0.1 deg",) * 3 + ("1 cm",) * 3 + ("1 ms",)
"""`REFERENCE_ERRORS` in words."""
ADVICE_SHARE = 0.5
"""Share of an estimate's sigma that a held value's reference error must move it by for
the advice to name that value."""


def held_std(mount: Mount) -> FloatArray:
    """The seven parameters' standard deviations from ``mount.uncertainty``, shape (7,).

    Internal units (rad, m, s); NaN where the mount does not give one.
    """
    return std_of_uncertainty(mount.uncertainty)


def std_of_uncertainty(unc: MountUncertainty | None) -> FloatArray:
    """The seven parameters' standard deviations from ``unc``, shape (7,).

    Internal units (rad, m, s); NaN where it does not give one.
    """
    out = np.full(7, np.nan)
    if unc is None:
        return out
    if unc.boresight_rpy_deg is not None:
        out[list(BORESIGHT)] = np.radians(unc.boresight_rpy_deg)
    if unc.lever_arm_body_m is not None:
        out[list(LEVER)] = unc.lever_arm_body_m
    if unc.latency_s is not None:
        out[LATENCY] = unc.latency_s
    return out


def held_covariance(mount: Mount) -> FloatArray:
    """The covariance of the mount's values from ``mount.uncertainty``, shape (7, 7).

    Internal units (rad, m, s); see `covariance_of_uncertainty`.
    """
    return covariance_of_uncertainty(mount.uncertainty)


def covariance_of_uncertainty(unc: MountUncertainty | None) -> FloatArray:
    """The seven parameters' covariance from ``unc``, shape (7, 7), internal units.

    The stated variances on the diagonal (NaN where not known, with that row and
    column 0 elsewhere), the stated correlations times the standard deviations off it
    (0 where none is stated: independent).
    """
    std = std_of_uncertainty(unc)
    known = np.isfinite(std)
    s = np.where(known, std, 0.0)
    corr = np.eye(7)
    if unc is not None and unc.correlation is not None:
        idx = [PARAMETER_NAMES.index(n) for n in unc.correlation.names]
        corr[np.ix_(idx, idx)] = np.asarray(unc.correlation.matrix)
    out: FloatArray = corr * np.outer(s, s)
    out[~known, ~known] = np.nan
    return out


def joint_covariance(
    estimated_cov: FloatArray, effect: HeldEffect, prior_cov: FloatArray
) -> FloatArray:
    """The covariance of all seven values after a calibration, shape (7, 7).

    Parameters
    ----------
    estimated_cov : ndarray, shape (k, k)
        The estimates' covariance (data and held parts), order ``effect.estimated``.
    effect : HeldEffect
        The held values' effect (its ``sensitivity`` D).
    prior_cov : ndarray, shape (7, 7)
        The given mount's covariance (`held_covariance`); NaN diagonal where unknown.

    Returns
    -------
    ndarray, shape (7, 7)
        Estimated block ``estimated_cov``; held block the prior's; between them
        ``D Sigma_h`` over the held values with a known sigma. NaN on the diagonal of a
        held value with no sigma, its row and column 0.
    """
    out = np.zeros((7, 7))
    est = list(effect.estimated)
    held = list(effect.held)
    out[np.ix_(held, held)] = prior_cov[np.ix_(held, held)]
    out[np.ix_(est, est)] = estimated_cov
    known = [h for h in held if math.isfinite(float(prior_cov[h, h]))]
    if est and known:
        cross = effect.sensitivity[:, known] @ prior_cov[np.ix_(known, known)]
        out[np.ix_(est, known)] = cross
        out[np.ix_(known, est)] = cross.T
    return out


def uncertainty_from_covariance(cov: FloatArray) -> MountUncertainty | None:
    """A `MountUncertainty` from the seven values' covariance (internal units), (7, 7).

    The standard deviations as `uncertainty_from_std` writes them (NaN diagonal:
    unknown), and the correlations among the values written when any is not zero.
    """
    c = np.asarray(cov, dtype=np.float64)
    unc = uncertainty_from_std(np.sqrt(np.where(np.diag(c) >= 0.0, np.diag(c), np.nan)))
    if unc is None:
        return None
    written = np.isfinite(std_of_uncertainty(unc))
    idx = [i for i in range(7) if written[i] and float(c[i, i]) > 0.0]
    if len(idx) < 2:
        return unc
    corr = np.clip(correlation(c[np.ix_(idx, idx)]), -1.0, 1.0)
    corr = 0.5 * (corr + corr.T)
    np.fill_diagonal(corr, 1.0)
    corr = nearest_correlation(corr)  # a computed covariance's rounding is no user error
    if not np.any(np.abs(corr - np.eye(len(idx))) > 0.0):
        return unc
    names = tuple(PARAMETER_NAMES[i] for i in idx)
    rows = tuple(tuple(float(v) for v in row) for row in corr)
    return replace(unc, correlation=StdCorrelation(names, rows))


def uncertainty_from_std(std: FloatArray) -> MountUncertainty | None:
    """A `MountUncertainty` from seven standard deviations (internal units), shape (7,).

    A vector (boresight, lever arm) is given only when all three of its components are
    known; NaN is unknown. A sigma beyond what a mount file may state (`MAX_ANGLE_DEG`,
    `MAX_LEVER_ARM_M`, `MAX_LATENCY_S`) says nothing and is left out too. None when
    nothing is known.
    """
    s = np.asarray(std, dtype=np.float64)

    def vec(part: FloatArray, limit: float) -> tuple[float, float, float] | None:
        if not np.all(np.isfinite(part) & (part <= limit)):
            return None
        return (float(part[0]), float(part[1]), float(part[2]))

    latency = float(s[LATENCY])
    unc = MountUncertainty(
        boresight_rpy_deg=vec(np.degrees(s[list(BORESIGHT)]), MAX_ANGLE_DEG),
        lever_arm_body_m=vec(s[list(LEVER)], MAX_LEVER_ARM_M),
        latency_s=latency if math.isfinite(latency) and latency <= MAX_LATENCY_S else None,
    )
    return unc if unc.known else None


_GROUPS = (("boresight_rpy_deg", BORESIGHT), ("lever_arm_body_m", LEVER), ("latency_s", (LATENCY,)))


def uncertainty_notes(
    prior_std: FloatArray,
    new_std: FloatArray,
    estimated: tuple[int, ...],
    honest: bool,
    exact: Sequence[tuple[int, int, float]] = (),
    requested: tuple[int, ...] = (),
) -> tuple[str, ...]:
    """What the calibrated mount's ``[uncertainty]`` leaves out or states worse, in words.

    Parameters
    ----------
    prior_std : ndarray, shape (7,)
        The given mount's standard deviations (internal units; NaN unknown).
    new_std : ndarray, shape (7,)
        The calibrated mount's, before `uncertainty_from_std` (NaN unknown).
    estimated : tuple of int
        The parameters estimated.
    honest : bool
        Whether the estimates' sigma is honest (else none is written).
    exact : sequence of (int, int, float)
        `HeldEffect.exact_that_matter` with ``j`` as a parameter index: held values taken
        as exact that move an estimate by more than half its sigma (that estimate's
        sigma is not written).
    requested : tuple of int
        The parameters asked for: a held one among them is one the data could not
        determine (estimating it is no remedy).
    """
    out = []
    written = uncertainty_from_std(new_std)
    for key, idx in _GROUPS:
        if getattr(written, key, None) is not None or not any(i in estimated for i in idx):
            continue
        limits = [(h, e, share) for h, e, share in exact if e in idx]
        if not honest:
            why = "the calibration's sigma is not honest (fewer than 5 lines)"
        elif limits:
            h, e, share = max(limits, key=lambda x: x[2])
            vector = next(k for k, group in _GROUPS if h in group)
            why = (
                f"its sigma takes the held {PARAMETER_NAMES[h]} as exact, and "
                f"{REFERENCE_TEXT[h]} of error in it would move {PARAMETER_NAMES[e]} by "
                f"{share:.1f} sigma; give {vector}'s standard deviation in the input "
                f"mount's [uncertainty]{'' if h in requested else ' (or estimate it)'} and "
                "calibrate again"
            )
        elif np.all(np.isfinite(new_std[list(idx)])):
            why = "its sigma is beyond what a mount file may state"
        else:
            unknown = [PARAMETER_NAMES[i] for i in idx if not math.isfinite(float(new_std[i]))]
            why = (
                f"the sigma of {', '.join(unknown)} is not known (held, none stated); give "
                f"{key}'s in the input mount's [uncertainty] to have it written, with its "
                "correlations"
            )
        out.append(f"{key} is left out of the written [uncertainty]: {why}")
    for i in estimated:
        before, after = float(prior_std[i]), float(new_std[i])
        if honest and math.isfinite(before) and math.isfinite(after) and after > before:
            scale = float(REPORT_SCALE[i])
            out.append(
                f"{PARAMETER_NAMES[i]}: these data give +-{after * scale:.3g}, less well than "
                f"the mount's stated +-{before * scale:.3g}; the calibration does not combine "
                "them, and the written sigma is the calibration's (to keep the mount's value "
                "and sigma, leave its group out of --estimate: it is then held with its sigma)"
            )
    return tuple(out)


@dataclass(frozen=True, eq=False)
class HeldEffect(ReadOnlyArrays):
    """How the held parameters' errors reach the estimates.

    Attributes
    ----------
    estimated : tuple of int
        The estimated parameters (rows of ``sensitivity``).
    held : tuple of int
        The held parameters (the other columns are zero).
    sensitivity : ndarray, shape (k, 7)
        ``d estimate / d held value`` (internal units: rad, m, s per rad, m, s).
    held_std : ndarray, shape (7,)
        The held values' standard deviations (internal units); NaN where not given,
        and for the estimated parameters.
    covariance : ndarray, shape (k, k)
        What the held values with a known sigma add to the estimates' covariance.
    held_covariance : ndarray, shape (7, 7)
        The held values' covariance ``Sigma_h`` (internal units; the stated correlations
        off the diagonal), zero outside the held values with a known sigma.
    """

    estimated: tuple[int, ...]
    held: tuple[int, ...]
    sensitivity: FloatArray
    held_std: FloatArray
    covariance: FloatArray
    held_covariance: FloatArray

    def __post_init__(self) -> None:
        # Own read-only copies, as every result's arrays: a result never changes.
        for name in ("sensitivity", "held_std", "covariance", "held_covariance"):
            object.__setattr__(self, name, readonly_array(getattr(self, name)))

    @property
    def std(self) -> FloatArray:
        """The estimates' standard deviation from the held values alone, shape (k,)."""
        out: FloatArray = np.sqrt(np.maximum(np.diag(self.covariance), 0.0))
        return out

    @property
    def std_if_independent(self) -> FloatArray:
        """The held part's standard deviation with the held errors taken as independent.

        Their stated correlations ignored, shape (k,), internal units: what a mount
        file without correlations gave.
        """
        variances = np.diag(self.held_covariance)
        out: FloatArray = np.sqrt(self.sensitivity**2 @ variances)
        return out

    @property
    def unknown(self) -> tuple[int, ...]:
        """Held parameters with no stated standard deviation (taken as exact)."""
        return tuple(i for i in self.held if not math.isfinite(float(self.held_std[i])))

    def per_reference(self) -> FloatArray:
        """Shift of each estimate (report units) per `REFERENCE_ERRORS` of each held value.

        Shape (k, 7): row ``j`` estimate ``estimated[j]``, column a held parameter (zero
        for the estimated ones).
        """
        rows = REPORT_SCALE[list(self.estimated)][:, None]
        return np.asarray(self.sensitivity * rows / REPORT_SCALE * REFERENCE_ERRORS)

    def document(self) -> dict[str, object]:
        """``--json``: per held parameter, its sigma and each estimate's shift.

        ``{name: {"std", "reference_error", "per_reference_error": {name: shift}}}``,
        report units (deg, m, ms); ``std`` null when not given (taken as exact).
        """
        shifts = self.per_reference()
        out: dict[str, object] = {}
        for h in self.held:
            s = float(self.held_std[h])
            out[PARAMETER_NAMES[h]] = {
                "std": s * float(REPORT_SCALE[h]) if math.isfinite(s) else None,
                "reference_error": float(REFERENCE_ERRORS[h]),
                "per_reference_error": {
                    PARAMETER_NAMES[e]: float(shifts[j, h]) for j, e in enumerate(self.estimated)
                },
            }
        return out

    def lines(self) -> tuple[str, ...]:
        """One line per held parameter: its sigma and what its error does, in words."""
        shifts = self.per_reference()
        out = []
        for h in self.held:
            s = float(self.held_std[h])
            unit = PARAMETER_NAMES[h].rsplit("_", 1)[-1]
            known = (
                f"sigma {s * float(REPORT_SCALE[h]):.2g} {unit}"
                if math.isfinite(s)
                else "taken as exact"
            )
            moves = ", ".join(
                f"{PARAMETER_NAMES[e]} {shifts[j, h]:+.3g}" for j, e in enumerate(self.estimated)
            )
            out.append(f"{PARAMETER_NAMES[h]} ({known}): {REFERENCE_TEXT[h]} moves {moves}")
        return tuple(out)

    def exact_that_matter(self, std: FloatArray) -> tuple[tuple[int, int, float], ...]:
        """Held values taken as exact whose error would matter: ``(h, j, share)``.

        Every pair of a held value with no stated sigma and an estimate
        ``estimated[j]`` that its reference error (`REFERENCE_ERRORS`) moves by more
        than `ADVICE_SHARE` of the estimate's sigma ``std``, and by how many sigma. Such
        an estimate's sigma holds no part of that error. An estimate with no finite,
        positive sigma is passed over.

        Parameters
        ----------
        std : ndarray, shape (k,)
            The estimates' sigma (internal units): the data's for the advice, the total
            (with the held part) for what is written.
        """
        shifts = self.per_reference()
        sigma = np.asarray(std, dtype=np.float64) * REPORT_SCALE[list(self.estimated)]
        usable = np.isfinite(sigma) & (sigma > 0.0)
        out = []
        for h in self.unknown:
            share = np.divide(np.abs(shifts[:, h]), sigma, out=np.zeros_like(sigma), where=usable)
            out += [(h, int(j), float(share[j])) for j in np.flatnonzero(share > ADVICE_SHARE)]
        return tuple(out)

    def advice(self, data_std: FloatArray, requested: tuple[int, ...] = ()) -> tuple[str, ...]:
        """The held values whose error matters, in words.

        A value taken as exact whose reference error would move an estimate by more
        than `ADVICE_SHARE` of its data sigma; a value whose stated sigma moves an
        estimate by more than the data leave (the held value limits that estimate):
        its share ``|(D Sigma_h)[j, h]| / sigma_h``, the error knowing it exactly would
        take out, with the stated correlations.

        Parameters
        ----------
        data_std : ndarray, shape (k,)
            The estimates' sigma from the data (jackknife or formal), internal units.
        requested : tuple of int
            The parameters asked for: a held one among them is one the data could not
            determine (estimating it is no remedy).
        """
        shifts = self.per_reference()
        out = []
        largest: dict[int, tuple[int, float]] = {}
        for h, j, share in self.exact_that_matter(data_std):
            if h not in largest or share > largest[h][1]:
                largest[h] = (j, share)
        for h, (j, share) in largest.items():
            e = self.estimated[j]
            remedy = "" if h in requested else ", or estimate it"
            out.append(
                f"{PARAMETER_NAMES[h]} is held as exact (the mount gives no [uncertainty] "
                f"for it): {REFERENCE_TEXT[h]} of error moves {PARAMETER_NAMES[e]} by "
                f"{shifts[j, h]:+.3g} ({share:.1f} sigma); give the standard deviation of "
                f"its vector in the mount file's [uncertainty] table so the sigma holds "
                f"it{remedy}"
            )
        # Each held value's share: what knowing it exactly would take out of an
        # estimate's sigma, |(D Sigma_h)[:, h]| / sigma_h (|D[:, h]| sigma_h when the
        # held errors are independent; with correlations the others' share moves too).
        sigma = np.asarray(data_std) * REPORT_SCALE[list(self.estimated)]
        d_sigma = self.sensitivity @ self.held_covariance
        for h in self.held:
            if h in self.unknown:
                continue
            part = np.abs(d_sigma[:, h]) / self.held_std[h] if self.held_std[h] > 0.0 else 0.0
            part = np.asarray(part * REPORT_SCALE[list(self.estimated)])
            j = int(np.argmax(part / sigma))
            if not part[j] > sigma[j]:
                continue
            e = self.estimated[j]
            partner = self._partner(j, h)
            if partner is None:
                remedy = (
                    "knowing it better" if h in requested else "estimating it or knowing it better"
                )
                out.append(
                    f"{PARAMETER_NAMES[h]}'s stated sigma moves {PARAMETER_NAMES[e]} by "
                    f"+-{part[j]:.3g}, more than the data leave (+-{sigma[j]:.3g}): {remedy} "
                    f"would narrow {PARAMETER_NAMES[e]}'s sigma"
                )
                continue
            k, rho = partner
            remedy = "measuring it anew" if h in requested else "estimating it or measuring it anew"
            out.append(
                f"knowing {PARAMETER_NAMES[h]} exactly would take +-{part[j]:.3g} out of "
                f"{PARAMETER_NAMES[e]}'s sigma (its own effect and, through its stated "
                f"correlation {rho:+.2f} with {PARAMETER_NAMES[k]}, that value's), more than the "
                f"data leave (+-{sigma[j]:.3g}): {remedy} would narrow it (a smaller sigma "
                "written by hand beside the same correlations would not)"
            )
        return tuple(out)

    def _partner(self, j: int, h: int) -> tuple[int, float] | None:
        """The held value whose correlation carries most of ``h``'s share in estimate ``j``.

        With that correlation; None when ``h``'s own effect is most of it (its share
        within 10 % of ``|D[j, h]| sigma_h``).
        """
        s = self.held_std
        own = float(self.sensitivity[j, h]) * float(s[h])
        terms = {
            k: float(self.sensitivity[j, k] * self.held_covariance[k, h] / s[h])
            for k in self.held
            if k != h and math.isfinite(float(s[k])) and self.held_covariance[k, h] != 0.0
        }
        total = own + sum(terms.values())
        if not terms or abs(total - own) <= 0.1 * max(abs(own), abs(total)):
            return None
        k = max(terms, key=lambda x: abs(terms[x]))
        return k, float(self.held_covariance[k, h] / (s[k] * s[h]))


def held_effect(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    solution: Adjustment,
    frame: LocalFrame,
    prior_cov: FloatArray,
) -> HeldEffect:
    """The sensitivity of the estimates to the held values, and the covariance it adds.

    Parameters
    ----------
    models, observations, frame
        As given to `kinsync.calibration.adjustment.adjust`.
    solution : Adjustment
        The solution (its features, noise scales and values are the linearisation
        point).
    prior_cov : ndarray, shape (7, 7)
        Covariance of the held values (internal units, `held_covariance`); NaN on the
        diagonal where not known (taken as exact).

    Returns
    -------
    HeldEffect
    """
    estimated = tuple(solution.estimated)
    if len(estimated) == 7:
        return effect_of_held(np.zeros((7, 7)), estimated, prior_cov)
    fitted = [f.feature for f in solution.features]
    scales = [f.sigma_m for f in solution.features]
    S, _, _ = reduced_normal_matrix(
        models, observations, fitted, solution.values, tuple(range(7)), frame, scales
    )
    return effect_of_held(S, estimated, prior_cov)


def effect_of_held(S: FloatArray, estimated: tuple[int, ...], prior_cov: FloatArray) -> HeldEffect:
    """`HeldEffect` from the reduced normal matrix over all seven parameters.

    Parameters
    ----------
    S : ndarray, shape (7, 7)
        Reduced normal matrix over the seven parameters (features eliminated; internal
        units), as `kinsync.calibration.adjustment.reduced_normal_matrix` gives it.
    estimated : tuple of int
        The estimated parameters; the others are held.
    prior_cov : ndarray, shape (7, 7)
        Covariance of the held values (internal units, `covariance_of_uncertainty`);
        NaN on the diagonal where not known.

    Returns
    -------
    HeldEffect
        ``D = -S_ee^-1 S_eh`` and ``D Sigma D'`` over the held values with a sigma.
    """
    held = tuple(i for i in range(7) if i not in estimated)
    k = len(estimated)
    sensitivity = np.zeros((k, 7))
    sigma_h = np.full(7, np.nan)
    cov = np.zeros((k, k))
    prior_known = np.zeros((7, 7))
    if held and k:
        e, h = list(estimated), list(held)
        S_ee, S_eh = S[np.ix_(e, e)], S[np.ix_(e, h)]
        try:
            sensitivity[:, h] = -np.linalg.solve(S_ee, S_eh)
        except np.linalg.LinAlgError:  # the estimates passed the observability analysis
            sensitivity[:, h] = -np.linalg.pinv(S_ee) @ S_eh
    if held:
        prior = np.asarray(prior_cov, dtype=np.float64)
        sigma_h[list(held)] = np.sqrt(np.diag(prior)[list(held)])
        known = [i for i in held if math.isfinite(float(sigma_h[i]))]
        if known:
            prior_known[np.ix_(known, known)] = prior[np.ix_(known, known)]
        if known and k:
            d = sensitivity[:, known]
            cov = d @ prior[np.ix_(known, known)] @ d.T
    return HeldEffect(
        estimated=estimated,
        held=held,
        sensitivity=sensitivity,
        held_std=sigma_h,
        covariance=cov,
        held_covariance=prior_known,
    )


NAMED_SHARE = 1.0 / 3.0
"""A held value is named as limiting an estimate when its own effect on it is at least
this share of the largest held value's."""


def hold_too_uncertain(
    estimated: tuple[int, ...],
    std: FloatArray,
    covariance: FloatArray,
    effect: HeldEffect,
    offsets: FloatArray | None = None,
) -> HeldAfterSolution | None:
    """What to hold after a solution, with the held values' stated sigma counted.

    First `kinsync.calibration.observability.hold_after_solution` on the data's sigma
    alone; when it holds nothing, again on the total sigma (the data's and
    ``effect.covariance`` added), the status of which reads the total: a lever arm known
    to 0.9 m leaves the boresight and the latency no better than a crew knows without
    calibrating, however good the data. Such a parameter is held at its prior too, and
    the result names the held values whose stated sigma did it, with the sigma they
    would need (all scaled alike, their correlations kept) to bring it within its
    threshold. When no held value has a stated sigma this is `hold_after_solution`.

    Parameters
    ----------
    estimated : tuple of int
        The estimated parameters (k), in ``effect.estimated``'s order.
    std : ndarray, shape (k,)
        Their honest standard deviations from the data (internal units: rad, m, s).
    covariance : ndarray, shape (k, k)
        The data's covariance of the estimates (internal units).
    effect : HeldEffect
        What the held values' stated sigma adds (``effect.covariance``).
    offsets : ndarray, shape (k,), optional
        How far the solution moved each estimate from where its solve started (internal
        units): the prior, or the prior with the yaw a search chose
        (`kinsync.calibration.gross.search_yaw`), which is no move by the adjustment. An
        estimate moved beyond 3 sigma is determined, if loosely, and is kept. None in a
        plan (nothing moved).

    Returns
    -------
    HeldAfterSolution or None
    """
    data_std = np.asarray(std, dtype=np.float64)
    moved_by = np.zeros(len(estimated)) if offsets is None else np.abs(offsets)
    held = hold_after_solution(estimated, data_std, list(moved_by > 3.0 * data_std), covariance)
    if held is not None or not np.any(effect.covariance):
        return held
    total_cov = covariance + effect.covariance
    total = np.sqrt(np.maximum(np.diag(total_cov), 0.0))
    held = hold_after_solution(estimated, total, list(moved_by > 3.0 * total), total_cov)
    if held is None:
        return None
    j = estimated.index(held.cause)
    scale = float(REPORT_SCALE[held.cause])
    data, limit = float(data_std[j]) * scale, UNOBSERVABLE_THRESHOLDS[held.cause]
    if not data < limit:  # the data alone leave it beyond: say so, as before
        return replace(held, std_report=data)
    part = float(effect.std[j]) * scale
    factor = math.sqrt(limit**2 - data**2) / part
    stated = effect.held_std * REPORT_SCALE  # report units; NaN where taken as exact
    own = {  # each held value's own effect on the cause (its correlations left out)
        h: abs(float(effect.sensitivity[j, h] * effect.held_std[h]))
        for h in effect.held
        if h not in effect.unknown
    }
    largest = max(own.values())
    named = sorted((h for h in own if own[h] >= NAMED_SHARE * largest), key=lambda h: -own[h])
    limited = tuple((h, float(stated[h]), float(stated[h]) * factor) for h in named)
    return replace(held, std_data=data, limited_by=limited)
