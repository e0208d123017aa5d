"""Method B: the mount's stated errors in the clock's sigma (`kinsync.sync.mount_effect`).

The clock was fitted with the mount taken as exact and its sigma held the sightings'
and the trajectory's errors only: a lever arm 1 cm off along the track moved t0 by
1 cm / speed, a boresight yaw 0.5 deg off by about 19 ms where the sigma said 9 ms.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import pickle
import warnings

import numpy as np
import pytest

from kinsync.calibration.held import REFERENCE_ERRORS
from kinsync.calibration.parameters import (
    PARAMETER_NAMES,
    REPORT_SCALE,
    mount_from_values,
    mount_values,
)
from kinsync.errors import KinsyncWarning
from kinsync.mount import Mount, MountUncertainty, StdCorrelation
from kinsync.sim.profiler import (
    DriveScanSimulation,
)
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.mount_effect import MountEffect, exact_text
from kinsync.sync.object_space import ObjectSpaceResult, synchronise_object_space

CFG = ObjectSpaceConfig(position_std_m=0.02)
STATED = MountUncertainty(
    lever_arm_body_m=(0.02, 0.02, 0.02), boresight_rpy_deg=(0.5, 0.5, 0.5), latency_s=0.001
)


@pytest.fixture(scope="module")
def sim(cheap: DriveScanSimulation) -> DriveScanSimulation:
    """The oval at 25 Hz, no control targets, scanned over 50-100 deg (conftest): fast."""
    return cheap


def _sync(sim: DriveScanSimulation, mount: Mount) -> ObjectSpaceResult:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", KinsyncWarning)
        return synchronise_object_space(
            sim.scanner.scan, sim.trajectory, mount, sim.sync_points, CFG
        )


@pytest.fixture(scope="module")
def exact(sim: DriveScanSimulation) -> ObjectSpaceResult:
    return _sync(sim, sim.config.mount)


def test_the_sensitivities_are_what_moving_the_mount_does(
    sim: DriveScanSimulation, exact: ObjectSpaceResult
) -> None:
    """Each value moved by its reference error and the whole synchronisation run again
    moves t0 and T as the linearised sensitivity says (within 3 % or 0.05 ms)."""
    effect = exact.mount_effect
    assert effect is not None
    values = mount_values(sim.config.mount)
    for name in ("boresight_yaw_deg", "lever_x_m", "latency_ms"):
        k = PARAMETER_NAMES.index(name)
        moved = values.copy()
        moved[k] += REFERENCE_ERRORS[k] / REPORT_SCALE[k]
        r = _sync(sim, mount_from_values(sim.config.mount, moved))
        d_t0, d_period = effect.sensitivity_s[:, k]
        assert r.t0_s - exact.t0_s == pytest.approx(d_t0, rel=0.03, abs=5e-5), name
        assert r.period_s - exact.period_s == pytest.approx(d_period, rel=0.03, abs=2e-9), name
    lat = PARAMETER_NAMES.index("latency_ms")
    assert effect.sensitivity_s[:, lat] == pytest.approx([-1e-3, 0.0], abs=1e-6)
    x = PARAMETER_NAMES.index("lever_x_m")  # along the track at 2 m/s: 1 cm / 2 m/s
    assert abs(effect.sensitivity_s[0, x]) == pytest.approx(0.01 / 2.0, rel=0.1)


def test_a_mount_without_uncertainty_leaves_the_sigma_as_it_was(
    exact: ObjectSpaceResult,
) -> None:
    assert exact.mount_effect is not None
    assert exact.mount_effect.exact == PARAMETER_NAMES
    assert np.asarray(exact.covariance) == pytest.approx(np.asarray(exact.data_covariance))
    doc = exact.as_document()
    assert doc["t0_std_data_s"] == pytest.approx(doc["t0_std_s"])
    assert doc["mount_effect"]["exact"] == list(PARAMETER_NAMES)
    assert doc["mount_effect"]["sensitivity"]["lever_x_m"]["per"] == "1 cm"


def test_stated_uncertainty_is_added_with_its_correlations(
    sim: DriveScanSimulation, exact: ObjectSpaceResult
) -> None:
    """The stated sigma add D Sigma D' to the data's covariance; the clock is the same."""
    stated = _sync(sim, dataclasses.replace(sim.config.mount, uncertainty=STATED))
    assert stated.t0_s == exact.t0_s
    assert stated.mount_effect is not None
    assert stated.mount_effect.exact == ()
    d = stated.mount_effect.sensitivity_s / (REFERENCE_ERRORS / REPORT_SCALE)
    std = np.array([*np.radians(STATED.boresight_rpy_deg or ()), *(STATED.lever_arm_body_m or ())])
    sigma_h = np.diag([*std**2, 1e-6])
    want = np.asarray(exact.data_covariance) + d @ sigma_h @ d.T
    assert np.asarray(stated.covariance) == pytest.approx(want, rel=1e-9)
    assert stated.t0_std_s > 2.0 * exact.t0_std_s  # 0.5 deg of yaw: about 19 ms
    assert stated.as_document()["t0_std_data_s"] == pytest.approx(exact.t0_std_s)
    # A lever x and a latency whose errors are correlated: a later run of a calibration
    # that estimated both (-5 ms of t0 per cm and -1 ms per ms, so opposite errors cancel).
    rho = -0.9
    lever_latency = StdCorrelation(("lever_x_m", "latency_ms"), ((1.0, rho), (rho, 1.0)))
    unc = MountUncertainty(lever_arm_body_m=(0.01, 0.0, 0.0), latency_s=0.005)
    apart = _sync(sim, dataclasses.replace(sim.config.mount, uncertainty=unc))
    together = _sync(
        sim,
        dataclasses.replace(
            sim.config.mount, uncertainty=dataclasses.replace(unc, correlation=lever_latency)
        ),
    )
    assert together.mount_effect is not None
    x, lat = PARAMETER_NAMES.index("lever_x_m"), PARAMETER_NAMES.index("latency_ms")
    s_x = together.mount_effect.sensitivity_s[0, x]  # per 1 cm, the stated sigma
    s_lat = together.mount_effect.sensitivity_s[0, lat] * 5.0  # per 1 ms; 5 ms stated
    mount_part = together.t0_std_s**2 - together.data_covariance[0][0]
    assert mount_part == pytest.approx(s_x**2 + s_lat**2 + 2.0 * rho * s_x * s_lat, rel=1e-6)
    assert apart.t0_std_s**2 - apart.data_covariance[0][0] == pytest.approx(
        s_x**2 + s_lat**2, rel=1e-6
    )
    assert together.t0_std_s < apart.t0_std_s


def test_the_warning_names_the_exact_values_that_matter(exact: ObjectSpaceResult) -> None:
    """1 cm of lever x moves t0 by about 5 ms, over half the data's 9 ms: named."""
    effect = exact.mount_effect
    text = exact_text(effect, exact.data_covariance)
    assert text is not None
    assert text.startswith(
        "the clock's sigma takes the mount as exact where it gives no [uncertainty]: "
    )
    assert "1 cm of lever_x_m moves t0 by -" in text
    assert "lever_y_m" not in text
    assert "boresight_roll_deg" not in text
    assert text.endswith("[uncertainty] table so that the sigma holds it")


def test_exact_text_thresholds_and_the_unfollowed() -> None:
    """Named only beyond half a sigma, by the larger share; an unfollowed value is named."""
    sens = np.zeros((2, 7))
    sens[:, 2] = (0.004, 0.0)  # yaw: 4 ms against 10 ms -> 0.4 sigma: not named
    sens[:, 3] = (0.006, 0.0)  # lever x: 0.6 sigma
    sens[:, 6] = (0.0, 2e-6)  # latency moving T by 2 us against 1 us: 2 sigma
    cov = ((1e-4, 0.0), (0.0, 1e-12))
    effect = MountEffect(sens, np.zeros((2, 2)), PARAMETER_NAMES, ())
    text = exact_text(effect, cov)
    assert text is not None
    assert "boresight_yaw_deg" not in text
    assert "1 cm of lever_x_m moves t0 by +6 ms (0.6 sigma)" in text
    assert "1 ms of latency_ms moves the period by +2 us (2 sigma)" in text
    assert "standard deviation of each" in text
    quiet = MountEffect(np.zeros((2, 7)), np.zeros((2, 2)), PARAMETER_NAMES, ())
    assert exact_text(quiet, cov) is None
    assert exact_text(None, cov) is None
    lost = MountEffect(np.full((2, 7), math.nan), np.zeros((2, 2)), (), ("lever_x_m",))
    said = exact_text(lost, cov)
    assert said is not None
    assert "the effect of lever_x_m on the clock could not be computed" in said


def test_a_result_pickles_copies_and_hashes(exact: ObjectSpaceResult) -> None:
    # n_crossings was a MappingProxyType: pickle, deepcopy and hash raised TypeError (a
    # result could not be sent to a worker process or cached); MountEffect, a dataclass
    # with eq=True over arrays, raised numpy's ambiguous truth value on ==.
    back: ObjectSpaceResult = pickle.loads(pickle.dumps(exact))
    assert back.as_document() == exact.as_document()
    assert copy.deepcopy(exact).as_document() == exact.as_document()
    assert hash(exact) == hash(exact)
    assert dict(back.n_crossings) == dict(exact.n_crossings)
    with pytest.raises(TypeError):
        back.n_crossings["S1"] = 0  # type: ignore[index]
    effect = exact.mount_effect
    assert effect is not None
    assert effect == exact.mount_effect
    assert effect != dataclasses.replace(effect)  # compared by identity, never by arrays
    assert not effect.sensitivity_s.flags.writeable
    assert not effect.covariance.flags.writeable
