"""Held parameters: their stated uncertainty reaches the sigma of the estimates.

The simulated vehicle patch test with thinned beams (8 lines) and the default
``--estimate boresight,latency``: the nominal lever arm is 3/-2/4 cm off the truth, and
the jackknife over lines cannot see an error every line shares. Without a stated
uncertainty the latency comes out several sigma off; with the lever arm's stated
(2 cm) the sigma holds the error (`kinsync.calibration.held`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from kinsync.calibration.adjustment import Adjustment, adjust
from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount, find_features
from kinsync.calibration.held import (
    REFERENCE_ERRORS,
    HeldEffect,
    covariance_of_uncertainty,
    effect_of_held,
    held_covariance,
    held_effect,
    hold_too_uncertain,
    uncertainty_from_covariance,
    uncertainty_from_std,
    uncertainty_notes,
)
from kinsync.calibration.model import LineModel, local_frame_for
from kinsync.calibration.observability import (
    UNOBSERVABLE_THRESHOLDS,
    Observability,
    hold_after_solution,
)
from kinsync.calibration.parameters import (
    PARAMETER_NAMES,
    REPORT_SCALE,
    estimated_indices,
    mount_from_values,
    mount_values,
)
from kinsync.calibration.result import CalibrationResult
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.mount import (
    MountUncertainty,
    StdCorrelation,
    mount_from_toml_text,
    mount_to_toml_text,
)
from kinsync.sim.patch_config import PatchTestConfig
from kinsync.sim.patch_test import PatchTestSimulation, simulate_patch_test

LEVER_STD_M = 0.02
ESTIMATED = ("boresight_roll_deg", "boresight_pitch_deg", "boresight_yaw_deg", "latency_ms")


@pytest.fixture(scope="module")
def thin() -> PatchTestSimulation:
    return simulate_patch_test(PatchTestConfig(scenario="vehicle", density=0.05, seed=3))


@pytest.fixture(scope="module")
def exact(thin: PatchTestSimulation) -> CalibrationResult:
    """The nominal mount as given by the simulator: no [uncertainty]."""
    return calibrate_mount(thin.lines, thin.mount_nominal)


@pytest.fixture(scope="module")
def stated(thin: PatchTestSimulation) -> CalibrationResult:
    unc = MountUncertainty(lever_arm_body_m=(LEVER_STD_M,) * 3)
    return calibrate_mount(thin.lines, replace(thin.mount_nominal, uncertainty=unc))


def _error(result: CalibrationResult, sim: PatchTestSimulation, name: str) -> float:
    truth = mount_values(sim.mount_true) * REPORT_SCALE
    return result.parameter(name).value - float(truth[PARAMETER_NAMES.index(name)])


def test_stated_lever_uncertainty_makes_the_sigma_hold_the_error(
    stated: CalibrationResult, thin: PatchTestSimulation
) -> None:
    assert [p.name for p in stated.parameters if p.status in ("estimated", "weak")] == list(
        ESTIMATED
    )
    for name in ESTIMATED:
        p = stated.parameter(name)
        assert p.std == pytest.approx(math.hypot(p.data_std, p.held_std), rel=1e-12)
        assert p.held_std > 0.0
        assert abs(_error(stated, thin, name)) <= 3.0 * p.std, name
    # The held part is the sensitivity times the stated sigma, axis by axis.
    assert stated.held is not None
    shifts = stated.held.per_reference()  # per 1 cm of each lever component
    j = stated.held.estimated.index(6)
    expected = math.sqrt(sum((shifts[j, i] * LEVER_STD_M / 0.01) ** 2 for i in (3, 4, 5)))
    assert stated.parameter("latency_ms").held_std == pytest.approx(expected, rel=1e-9)
    assert "plus the stated uncertainty of the held lever_x_m" in stated.sigma_method
    # Nothing is taken as exact; the stated lever arm limits the boresight and latency.
    assert not any("held as exact" in a for a in stated.held_advice)
    assert any(
        a.startswith("lever_y_m's stated sigma moves boresight_") and "more than the data" in a
        for a in stated.held_advice
    )


def test_a_held_value_stated_too_loosely_leaves_an_estimate_unobservable(
    thin: PatchTestSimulation,
) -> None:
    # The lever arm stated to 3 cm: the data leave the yaw +-0.23 deg, the lever y's
    # sigma adds +-1.2: more than the 1 deg a crew knows anyway. The status reads the
    # total, so the yaw is held at its prior, not printed as a weak +-1.2 (as it was).
    unc = MountUncertainty(lever_arm_body_m=(0.03,) * 3)
    result = calibrate_mount(thin.lines, replace(thin.mount_nominal, uncertainty=unc))
    yaw = result.parameter("boresight_yaw_deg")
    assert yaw.status == "unobservable"
    assert yaw.value == yaw.prior
    assert not math.isfinite(yaw.std)
    reason = next(r for r in result.unobservable_reasons if r.startswith("boresight_yaw_deg"))
    assert "these data give +-0.2" in reason
    assert "the rest is the stated sigma of the held lever_y_m" in reason
    advice = next(a for a in result.advice if a.startswith("boresight_yaw_deg: "))
    assert "lever_y_m known to +-0.02" in advice
    assert advice.endswith("(for a sigma within 1), or estimated")
    for p in result.parameters:
        if p.status in ("estimated", "weak"):
            i = PARAMETER_NAMES.index(p.name)
            assert p.std <= UNOBSERVABLE_THRESHOLDS[i], p.name
            assert abs(_error(result, thin, p.name)) <= 3.0 * p.std, p.name


def test_without_stated_uncertainty_the_advice_names_the_lever(
    exact: CalibrationResult, thin: PatchTestSimulation
) -> None:
    # The premise: the data's sigma alone misses the shared lever error by far.
    latency = exact.parameter("latency_ms")
    assert abs(_error(exact, thin, "latency_ms")) > 3.0 * latency.std
    assert latency.held_std == 0.0
    assert latency.std == latency.data_std
    assert exact.held is not None
    assert exact.held.unknown == (3, 4, 5)
    assert "taken as exact" in exact.sigma_method
    named = " ".join(exact.held_advice)
    assert "lever_y_m is held as exact" in named
    assert "[uncertainty]" in named
    assert all(" sigma)" in a for a in exact.held_advice)
    assert all(a.endswith("or estimate it") for a in exact.held_advice)  # not asked for


def test_calibrated_mount_carries_its_sigma(stated: CalibrationResult) -> None:
    unc = stated.mount.uncertainty
    assert unc is not None
    assert unc.lever_arm_body_m == (LEVER_STD_M,) * 3  # held: the prior's
    assert unc.latency_s == pytest.approx(stated.parameter("latency_ms").std / 1e3)
    assert unc.boresight_rpy_deg == pytest.approx([stated.parameter(n).std for n in ESTIMATED[:3]])


def test_json_names_each_held_value_and_its_effect(stated: CalibrationResult) -> None:
    doc = stated.as_document()
    assert set(doc["held"]) == {"lever_x_m", "lever_y_m", "lever_z_m"}
    entry = doc["held"]["lever_y_m"]
    assert entry["std"] == LEVER_STD_M
    assert entry["reference_error"] == REFERENCE_ERRORS[4]
    assert set(entry["per_reference_error"]) == set(ESTIMATED)
    lat = doc["parameters"]["latency_ms"]
    assert lat["std"] == pytest.approx(math.hypot(lat["std_data"], lat["std_held"]))
    assert doc["mount"]["uncertainty"]["lever_arm_body_m"] == [LEVER_STD_M] * 3


def test_sensitivity_is_what_a_new_solution_does(thin: PatchTestSimulation) -> None:
    """The linearised shift against solving again with the held value changed.

    Central differences of +-1 cm, the features' noise scales held (as the jackknife
    holds them): the shift is then the model's, not a new weighting's.
    """
    cache: dict[int, GeorefTrajectory] = {}
    models = [LineModel.prepare(line, cache) for line in thin.lines]
    frame = local_frame_for(thin.lines)
    prior = mount_values(thin.mount_nominal)
    features, obs = find_features(models, prior, frame, CalibrationOptions())
    est = estimated_indices("boresight,latency")
    sol = adjust(models, obs, features, prior, est, frame)
    effect = held_effect(models, obs, sol, frame, held_covariance(thin.mount_nominal))
    assert np.all(np.isnan(effect.held_std[[3, 4, 5]]))  # nothing stated
    assert np.all(effect.covariance == 0.0)
    fitted = [f.feature for f in sol.features]
    scales = [f.sigma_m for f in sol.features]

    def solve_with(h: int, dv: float) -> Adjustment:
        start = sol.values.copy()
        start[h] += dv
        return adjust(models, obs, fitted, start, est, frame, None, scales)

    rows = REPORT_SCALE[list(est)]
    for h in (3, 4):
        up, down = solve_with(h, 0.01), solve_with(h, -0.01)
        resolved = (up.values - down.values)[list(est)] / 2.0 * rows  # per cm
        linear = effect.per_reference()[:, h]
        assert np.all(np.abs(resolved - linear) <= 0.2 * np.abs(linear) + 0.02), (
            PARAMETER_NAMES[h],
            resolved,
            linear,
        )
    # A lever x error moves the latency by about 1 ms per cm at these speeds.
    assert abs(effect.per_reference()[est.index(6), 3]) > 0.5


def test_certificate_shows_what_each_held_value_does(
    stated: CalibrationResult, exact: CalibrationResult
) -> None:
    from kinsync.report.calibration import calibration_certificate  # noqa: PLC0415

    html = calibration_certificate(stated)
    assert html.index("Held parameters") < html.index("Features")
    assert "of which held" in html
    assert "lever_y_m (sigma 0.02 m): 1 cm moves" in html
    assert "stated sigma moves boresight_" in html
    assert "taken as exact" not in html
    html = calibration_certificate(exact)
    assert "lever_y_m (taken as exact)" in html
    assert "the sigma holds the stated uncertainty" not in html
    assert "Warning: lever_y_m is held as exact" in html


def test_a_sigma_beyond_what_a_mount_may_state_is_left_out() -> None:
    std = np.array([np.radians(0.01)] * 3 + [0.01] * 3 + [15.0])  # latency sigma 15 s
    unc = uncertainty_from_std(std)
    assert unc is not None
    assert unc.latency_s is None
    assert unc.lever_arm_body_m == (0.01, 0.01, 0.01)
    assert uncertainty_from_std(np.full(7, np.nan)) is None


def test_notes_say_what_the_written_uncertainty_leaves_out() -> None:
    nan = np.nan
    deg = np.radians(1.0)
    prior = np.array([0.2 * deg] * 3 + [nan, nan, nan] + [nan])
    new = np.array([0.01 * deg, 2.17 * deg, 0.1 * deg, 0.02, 0.006, nan, 0.001])
    notes = uncertainty_notes(prior, new, (0, 1, 2, 3, 4, 6), honest=True)
    assert len(notes) == 2
    assert notes[0].startswith("lever_arm_body_m is left out of the written [uncertainty]")
    assert "the sigma of lever_z_m is not known" in notes[0]
    assert notes[1].startswith("boresight_pitch_deg: these data give +-2.17, less well than")
    assert "+-0.2;" in notes[1]
    # Each says what to do.
    assert "give lever_arm_body_m's in the input mount's [uncertainty]" in notes[0]
    assert "leave its group out of --estimate" in notes[1]
    expected = (
        "boresight_rpy_deg is left out of the written [uncertainty]: the calibration's "
        "sigma is not honest (fewer than 5 lines)"
    )
    unknown = new.copy()
    unknown[[0, 1, 2]] = nan  # as the estimator leaves a sigma that is not honest
    assert uncertainty_notes(prior, unknown, (0, 1, 2), honest=False) == (expected,)
    beyond = new.copy()
    beyond[6] = 15.0
    assert any("latency_s is left out" in n and "beyond" in n
               for n in uncertainty_notes(prior, beyond, (6,), honest=True))  # fmt: skip


def test_no_notes_when_everything_is_written(stated: CalibrationResult) -> None:
    assert stated.uncertainty_notes == ()
    assert stated.as_document()["uncertainty_notes"] == []


def test_held_values_are_reported_and_written_exactly_as_given(
    exact: CalibrationResult, thin: PatchTestSimulation
) -> None:
    # The nominal boresight (0, -30, 30) deg went through radians: -29.999999999999996
    # was reported as the prior and written for a held angle.
    assert exact.parameter("boresight_pitch_deg").prior == -30.0
    assert exact.parameter("lever_z_m").value == thin.mount_nominal.lever_arm_body_m[2]
    held = mount_from_values(thin.mount_nominal, mount_values(thin.mount_nominal))
    assert held.boresight_rpy_deg == thin.mount_nominal.boresight_rpy_deg == (0.0, -30.0, 30.0)
    assert exact.mount.lever_arm_body_m == thin.mount_nominal.lever_arm_body_m


# ---- correlations: read, used, written ---------------------------------------------


def test_covariance_of_uncertainty_puts_the_correlations_off_the_diagonal() -> None:
    corr = StdCorrelation(("lever_x_m", "latency_ms"), ((1.0, -0.8), (-0.8, 1.0)))
    unc = MountUncertainty(lever_arm_body_m=(0.02, 0.02, 0.03), latency_s=0.002, correlation=corr)
    cov = covariance_of_uncertainty(unc)
    assert np.all(np.isnan(np.diag(cov)[:3]))  # the boresight: not known
    assert np.all(cov[:3, 3:] == 0.0)
    assert cov[3, 3] == pytest.approx(0.02**2)
    assert cov[3, 6] == cov[6, 3] == pytest.approx(-0.8 * 0.02 * 0.002)
    assert cov[4, 6] == 0.0  # not named: independent


def test_correlated_held_values_add_the_full_consider_covariance() -> None:
    # Two held values whose errors cancel in the estimate (perfectly correlated, equal
    # and opposite effects) add nothing; taken as independent they would add 2 d^2 s^2.
    S = np.eye(7)
    S[0, 3] = S[3, 0] = 0.5
    S[0, 6] = S[6, 0] = 0.5 * 0.01 / 0.001  # latency's unit: its effect equals lever x's
    S += np.diag([0, 0, 0, 0, 0, 0, 10.0])
    est = (0, 1, 2, 4, 5)
    std = np.full(7, np.nan)
    std[3], std[6] = 0.01, 0.001
    independent = effect_of_held(S, est, np.diag(std**2))
    cov = np.diag(std**2)
    d = -np.linalg.solve(S[np.ix_(est, est)], S[np.ix_(est, [3, 6])])
    rho = -float(np.sign(d[0, 0] * d[0, 1]))  # the correlation that cancels the two
    cov[3, 6] = cov[6, 3] = rho * 0.01 * 0.001
    correlated = effect_of_held(S, est, cov)
    expected = d @ cov[np.ix_([3, 6], [3, 6])] @ d.T
    assert correlated.covariance == pytest.approx(expected, abs=1e-15)
    assert independent.std[0] > 10.0 * correlated.std[0]
    assert correlated.held_std[3] == pytest.approx(0.01)


def test_uncertainty_from_covariance_round_trips_with_its_correlations() -> None:
    rng = np.random.default_rng(2)
    a = rng.normal(size=(7, 7)) * np.array([1e-4, 1e-4, 2e-4, 0.01, 0.01, 0.02, 0.001])
    cov = a.T @ a
    unc = uncertainty_from_covariance(cov)
    assert unc is not None
    assert unc.correlation is not None
    assert unc.correlation.names == PARAMETER_NAMES
    assert covariance_of_uncertainty(unc) == pytest.approx(cov, rel=1e-9, abs=1e-20)
    # A vector with an unknown component is left out, and so are its correlations.
    cov[5, 5] = np.nan
    part = uncertainty_from_covariance(cov)
    assert part is not None
    assert part.lever_arm_body_m is None
    assert part.correlation is not None
    assert "lever_x_m" not in part.correlation.names
    # Independent errors write no correlation table.
    plain = uncertainty_from_covariance(np.diag(np.diag(a.T @ a)))
    assert plain is not None
    assert plain.correlation is None


def test_the_calibrated_mount_carries_the_joint_covariance(stated: CalibrationResult) -> None:
    unc = stated.mount.uncertainty
    assert unc is not None
    assert unc.correlation is not None
    cov = covariance_of_uncertainty(unc)
    est = [PARAMETER_NAMES.index(n) for n in stated.correlation_names]
    std = np.sqrt(np.diag(cov))
    # Among the estimates: the correlations the result reports.
    written = cov[np.ix_(est, est)] / np.outer(std[est], std[est])
    assert written == pytest.approx(np.asarray(stated.correlation), abs=1e-9)
    # Between an estimate and a held lever component: D Sigma_h.
    assert stated.held is not None
    d = stated.held.sensitivity
    j = stated.held.estimated.index(6)
    assert cov[6, 3] == pytest.approx(d[j, 3] * LEVER_STD_M**2, rel=1e-9)
    # The lever components' own errors stay independent, as the prior stated them.
    assert cov[3, 4] == 0.0
    # Read back from the file it is the same.
    back = mount_from_toml_text(mount_to_toml_text(stated.mount))
    assert back.uncertainty == unc


def test_a_later_calibration_holds_the_correlated_values(
    stated: CalibrationResult, thin: PatchTestSimulation
) -> None:
    # The calibrated mount held again with only the latency estimated: its held part is
    # D Sigma D' with the written correlations, not with independent errors.
    again = calibrate_mount(
        thin.lines, stated.mount, CalibrationOptions(estimate=("latency",), jackknife=False)
    )
    assert again.held is not None
    prior = covariance_of_uncertainty(stated.mount.uncertainty)
    d = again.held.sensitivity[0]
    known = [i for i in range(7) if i != 6 and np.isfinite(prior[i, i])]
    full = float(d[known] @ prior[np.ix_(known, known)] @ d[known])
    diagonal = float(np.sum(d[known] ** 2 * np.diag(prior)[known]))
    got = again.parameter("latency_ms").held_std / 1000.0
    assert got == pytest.approx(math.sqrt(full), rel=1e-9)
    assert abs(math.sqrt(full) - math.sqrt(diagonal)) > 0.05 * math.sqrt(diagonal)
    # The advice weighs each held value with its correlations, and names the partner
    # through which most of its share comes (a surveyor lowered one sigma by hand, as
    # "knowing it better" suggested, and the latency's sigma grew).
    correlated = [a for a in again.held_advice if a.startswith("knowing ")]
    assert correlated, again.held_advice
    assert all("through its stated correlation" in a for a in correlated)
    assert all("measuring it anew" in a for a in correlated)


def test_the_advice_weighs_a_held_value_with_its_correlations() -> None:
    # Lever x and latency held, their errors correlated so that their effects on the
    # roll cancel: knowing either exactly takes nothing out of the roll's sigma, so the
    # advice names neither; taken as independent each would be named.
    S = np.eye(7)
    S[0, 3] = S[3, 0] = 0.5
    S[0, 6] = S[6, 0] = 5.0
    S[6, 6] = 11.0
    est = (0, 1, 2, 4, 5)
    unknown = np.nan
    independent_cov = np.diag([unknown] * 3 + [1e-4] + [unknown] * 2 + [1e-6])
    independent_cov[np.isnan(independent_cov) & ~np.eye(7, dtype=bool)] = 0.0
    d = -np.linalg.solve(S[np.ix_(est, est)], S[np.ix_(est, [3, 6])])
    rho = -float(np.sign(d[0, 0] * d[0, 1]))  # the correlation whose effects cancel
    correlated_cov = independent_cov.copy()
    correlated_cov[3, 6] = correlated_cov[6, 3] = rho * 0.01 * 0.001
    data_std = np.full(len(est), 1e-6)
    named = " ".join(effect_of_held(S, est, independent_cov).advice(data_std))
    assert "lever_x_m's stated sigma moves boresight_roll_deg" in named
    assert "latency_ms's stated sigma moves boresight_roll_deg" in named
    correlated = effect_of_held(S, est, correlated_cov).advice(data_std)
    assert not any("boresight_roll_deg" in a for a in correlated)


def test_a_sigma_that_takes_a_relevant_held_value_as_exact_is_not_written(
    exact: CalibrationResult,
) -> None:
    # The lever arm is taken as exact and 1 cm of it moves the yaw by 1.8 sigma and the
    # latency by 0.7: those sigmas hold none of it, and a later calibration that held
    # the written values would trust them (a surveyor's two-stage run came out 3.8
    # sigma off). They are left out, saying why and what to give.
    unc = exact.mount.uncertainty
    assert unc is None or (unc.boresight_rpy_deg is None and unc.latency_s is None)
    notes = " ".join(exact.uncertainty_notes)
    assert "boresight_rpy_deg is left out" in notes
    assert "takes the held lever_y_m as exact" in notes
    assert "latency_s is left out" in notes
    assert "give lever_arm_body_m's standard deviation in the input mount's" in notes


def _effect(sensitivity: np.ndarray, held_cov: np.ndarray) -> HeldEffect:
    """Estimates yaw and latency (2, 6); everything else held with ``held_cov``."""
    held = (0, 1, 3, 4, 5)
    std = np.full(7, np.nan)
    std[list(held)] = np.sqrt(np.diag(held_cov)[list(held)])
    cov = np.nan_to_num(held_cov, nan=0.0)
    return HeldEffect((2, 6), held, sensitivity, std, np.zeros((2, 2)), cov)


def test_every_estimate_a_held_exact_value_moves_too_far_is_named() -> None:
    # 1 cm of the lever x (no sigma stated) moves the yaw by 3 sigma and the latency by
    # 1.5: both are returned (only the largest was, so the latency's sigma was written).
    d = np.zeros((2, 7))
    d[0, 3] = np.radians(0.03) / 0.01  # 0.03 deg per cm
    d[1, 3] = 0.0015 / 0.01  # 1.5 ms per cm
    cov = np.diag([1e-8, 1e-8, np.nan, np.nan, 1e-4, 1e-4, np.nan])
    effect = _effect(d, cov)
    found = effect.exact_that_matter(np.array([np.radians(0.01), 0.001]))
    assert [(h, j) for h, j, _ in found] == [(3, 0), (3, 1)]
    assert [round(share, 6) for *_, share in found] == [3.0, 1.5]
    # A sigma that is NaN or zero is passed over, not a NaN that hides the others.
    assert [j for _, j, _ in effect.exact_that_matter(np.array([np.nan, 0.001]))] == [1]
    assert effect.exact_that_matter(np.array([0.0, 0.0])) == ()


def test_the_partner_is_named_when_a_correlation_reverses_the_sign() -> None:
    # Lever x's own effect on the yaw is +0.03 deg; through its -0.9 correlation with
    # lever y the effect is -0.06: the net -0.03 has the own effect's size, not its sign.
    d = np.zeros((2, 7))
    d[0, 3] = np.radians(0.03) / 0.01
    d[0, 4] = np.radians(0.0667) / 0.01
    cov = np.diag([np.nan, np.nan, np.nan, 1e-4, 1e-4, np.nan, np.nan])
    cov[3, 4] = cov[4, 3] = -0.9e-4
    effect = _effect(d, cov)
    partner = effect._partner(0, 3)
    assert partner is not None
    assert partner[0] == 4
    assert partner[1] == pytest.approx(-0.9)
    text = " ".join(effect.advice(np.array([np.radians(0.01), 0.001])))
    assert "knowing lever_x_m exactly" in text
    assert "correlation -0.90 with lever_y_m" in text


def test_the_unobservable_rule_reads_the_total_sigma() -> None:
    # Yaw and latency estimated. The data leave the yaw +-0.1 deg and the latency
    # +-0.5 ms; 1 cm of lever y moves the yaw 0.25 deg, 1 cm of lever x the latency
    # 1 ms. With the lever y stated to 0.9 m the yaw is +-22.5 deg in all: held, naming
    # lever y and the sigma that would bring it within 1 deg.
    d = np.zeros((2, 7))
    d[0, 4] = np.radians(0.25) / 0.01
    d[1, 3] = 0.001 / 0.01
    held_cov = np.diag([np.nan, np.nan, np.nan, 0.02**2, 0.9**2, 0.02**2, np.nan])
    known = [3, 4, 5]
    sigma = held_cov[np.ix_(known, known)]
    std = np.full(7, np.nan)
    std[known] = np.sqrt(np.diag(sigma))
    cov_held = d[:, known] @ sigma @ d[:, known].T
    full = np.zeros((7, 7))
    full[np.ix_(known, known)] = sigma
    effect = HeldEffect((2, 6), (0, 1, 3, 4, 5), d, std, cov_held, full)
    data = np.array([np.radians(0.1), 0.0005])
    cov = np.diag(data**2)
    assert hold_after_solution((2, 6), data, [False, False], cov) is None  # the data alone
    held = hold_too_uncertain((2, 6), data, cov, effect)
    assert held is not None
    assert (held.index, held.cause) == (2, 2)
    assert held.std_report == pytest.approx(math.hypot(0.1, 22.5))
    assert held.std_data == pytest.approx(0.1)
    ((h, stated, need),) = held.limited_by  # lever x does nothing to the yaw: not named
    assert h == 4
    assert stated == pytest.approx(0.9)
    assert math.hypot(0.1, 22.5 * need / stated) == pytest.approx(1.0)
    obs = Observability(estimated=(6,), unobservable=(), null_directions=(), held_after=(held,))
    assert (
        "these data give +-0.1, the rest is the stated sigma of the held lever_y_m"
        in (obs.explanation()[0])
    )
    expect = f"boresight_yaw_deg: lever_y_m known to +-{need:.2g} instead of +-0.9"
    assert obs.advice() == (f"{expect} (for a sigma within 1), or estimated",)
    # An estimate the data moved beyond 3 of its total sigma is determined: kept.
    assert hold_too_uncertain((2, 6), data, cov, effect, np.array([np.radians(70.0), 0.0])) is None
    # No held value with a stated sigma: the data's rule alone, as before.
    none = replace(effect, covariance=np.zeros((2, 2)))
    assert hold_too_uncertain((2, 6), data, cov, none) is None


def test_a_calibration_cannot_be_changed_in_place(stated: CalibrationResult) -> None:
    # correlation and the held effect's arrays were writeable: a result could be edited.
    assert stated.held is not None
    arrays = {"correlation": stated.correlation} | {
        name: getattr(stated.held, name)
        for name in ("sensitivity", "held_std", "covariance", "held_covariance")
    }
    for name, array in arrays.items():
        assert not array.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            array[...] = 0.0
