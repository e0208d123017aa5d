"""The mount file's optional ``[uncertainty]`` table: read, checked, written exactly."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.mount_file import read_mount, write_mount
from kinsync.mount import (
    MAX_ANGLE_DEG,
    MAX_LATENCY_S,
    MAX_LEVER_ARM_M,
    MOUNT_PARAMETER_NAMES,
    Mount,
    MountUncertainty,
    StdCorrelation,
    mount_from_toml_text,
    mount_to_toml_text,
)

BASE = "[mount]\nlever_arm_body_m = [0.1, 0.2, 0.3]\nlatency_s = 0.0\n"

# The round trips draw sigmas up to the refusal bounds; the warnings beyond WARN_STD are
# tested below.
pytestmark = pytest.mark.filterwarnings(
    "ignore:.*standard deviation beyond:kinsync.errors.KinsyncWarning"
)


def _std(limit: float) -> st.SearchStrategy[float]:
    return st.floats(min_value=0.0, max_value=limit, allow_nan=False)


def _maybe(s: st.SearchStrategy[object]) -> st.SearchStrategy[object]:
    return st.one_of(st.none(), s)


uncertainties = st.builds(
    MountUncertainty,
    lever_arm_body_m=_maybe(st.tuples(*[_std(MAX_LEVER_ARM_M)] * 3)),
    boresight_rpy_deg=_maybe(st.tuples(*[_std(MAX_ANGLE_DEG)] * 3)),
    latency_s=_maybe(_std(MAX_LATENCY_S)),
)


@settings(max_examples=150, deadline=None)
@given(unc=uncertainties)
def test_uncertainty_round_trips_exactly(unc: MountUncertainty) -> None:
    mount = Mount(lever_arm_body_m=(0.1, 0.2, 0.3), uncertainty=unc)
    back = mount_from_toml_text(mount_to_toml_text(mount))
    if unc.known:
        assert back == mount
    else:  # nothing known writes no table, and reads back as none
        assert back.uncertainty is None
        assert "[uncertainty]" not in mount_to_toml_text(mount)


def test_file_round_trip_and_partial_table(tmp_path: Path) -> None:
    text = BASE + "\n[uncertainty]\nlever_arm_body_m = [0.01, 0.01, 0.02]\n"
    mount = mount_from_toml_text(text)
    assert mount.uncertainty == MountUncertainty(lever_arm_body_m=(0.01, 0.01, 0.02))
    assert mount.uncertainty.boresight_rpy_deg is None
    assert mount.uncertainty.latency_s is None
    path = tmp_path / "m.toml"
    write_mount(mount, path)
    assert read_mount(path) == mount
    written = path.read_text()
    assert "[uncertainty]" in written
    assert "boresight_rpy_deg" not in written.split("[uncertainty]")[1]


def test_no_table_means_none_and_integers_read() -> None:
    assert mount_from_toml_text(BASE).uncertainty is None
    mount = mount_from_toml_text(BASE + "[uncertainty]\nboresight_rpy_deg = [0, 0, 1]\n")
    assert mount.uncertainty is not None
    assert mount.uncertainty.boresight_rpy_deg == (0.0, 0.0, 1.0)


@pytest.mark.parametrize(
    ("table", "pattern"),
    [
        ("[uncertainty]\nlever_arm_m = [0.1, 0.1, 0.1]\n", r"unknown key.*lever_arm_m"),
        ("[uncertainty]\nantenna_lever_arm_body_m = [0.1, 0.1, 0.1]\n", "antenna"),
        ("[uncertainty]\nlatency_s = -0.001\n", r"latency_s = -0.001.*not negative"),
        ("[uncertainty]\nlatency_s = nan\n", r"latency_s = nan.*finite"),
        ('[uncertainty]\nlatency_s = "1 ms"\n', r"latency_s.*a number"),
        ("[uncertainty]\nlatency_s = true\n", r"latency_s.*a number"),
        ("[uncertainty]\nlever_arm_body_m = [0.1, -0.1, 0.1]\n", r"lever_arm_body_m\[1\]"),
        ("[uncertainty]\nlever_arm_body_m = [0.1, 0.1]\n", "list of 3 numbers"),
        ("[uncertainty]\nboresight_rpy_deg = [0.1, inf, 0.1]\n", "boresight_rpy_deg"),
        ("[uncertainty]\nboresight_rpy_deg = [0.1, 0.1, 400.0]\n", r"at most 360"),
        ("[uncertainty]\nlatency_s = 11.0\n", r"at most 10"),
    ],
    ids=[
        "unknown-key",
        "antenna-not-calibrated",
        "negative",
        "nan",
        "string",
        "bool",
        "negative-in-vector",
        "two-numbers",
        "inf-in-vector",
        "beyond-one-turn",
        "beyond-latency-bound",
    ],
)
def test_bad_uncertainty_is_refused_naming_file_and_key(table: str, pattern: str) -> None:
    with pytest.raises(InputError, match=pattern) as info:
        mount_from_toml_text(BASE + table, source="cfg/mount.toml")
    assert str(info.value).startswith("cfg/mount.toml: ")


def test_uncertainty_that_is_not_a_table_is_refused() -> None:
    with pytest.raises(InputError, match=r"\[uncertainty\] must be a table"):
        mount_from_toml_text("uncertainty = 3\n" + BASE, source="cfg/mount.toml")


def test_unknown_table_message_lists_uncertainty() -> None:
    with pytest.raises(
        InputError, match=r"\[uncertainty\] \(with \[uncertainty.correlation\]\) are read"
    ):
        mount_from_toml_text(BASE + "[sigma]\nlatency_s = 0.001\n")


def test_container_refuses_what_is_not_an_uncertainty() -> None:
    with pytest.raises(InputError, match="MountUncertainty"):
        Mount(uncertainty={"latency_s": 0.001})  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("table", "fragment"),
    [
        ("latency_s = 0.5\n", "latency_s = 0.5 s: a standard deviation beyond 0.1 s"),
        ("lever_arm_body_m = [1, 2, 3]\n", "beyond 1 m is a unit mistake"),
        ("boresight_rpy_deg = [0.1, 0.1, 10.0]\n", "beyond 5 deg"),
    ],
)
def test_implausible_uncertainty_is_read_with_a_warning(table: str, fragment: str) -> None:
    with pytest.warns(KinsyncWarning, match=fragment):
        mount = mount_from_toml_text(BASE + "[uncertainty]\n" + table, source="m.toml")
    assert mount.uncertainty is not None


def test_plausible_uncertainty_reads_without_a_warning() -> None:
    text = BASE + "[uncertainty]\nlatency_s = 0.001\nlever_arm_body_m = [0.02, 0.02, 0.5]\n"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mount_from_toml_text(text)


# ---- [uncertainty.correlation] -------------------------------------------------------

NOT_PSD = (
    'names = ["lever_x_m", "lever_y_m", "latency_ms"]\n'
    "matrix = [[1, 0.9, 0.9], [0.9, 1, -0.9], [0.9, -0.9, 1]]\n"
)
CORR = (
    "[uncertainty]\nlever_arm_body_m = [0.02, 0.02, 0.03]\nlatency_s = 0.002\n"
    "[uncertainty.correlation]\n"
)


@st.composite
def correlated(draw: st.DrawFn) -> MountUncertainty:
    """An uncertainty whose values' errors are correlated: a random correlation matrix
    (a Gram matrix of unit vectors) over a random subset of the known values."""
    names = draw(
        st.lists(st.sampled_from(MOUNT_PARAMETER_NAMES), min_size=2, max_size=7, unique=True)
    )
    unit = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: sum(x * x for x in v) > 0.01)
    vectors = np.array(draw(st.lists(unit, min_size=len(names), max_size=len(names))))
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    matrix = vectors @ vectors.T
    np.fill_diagonal(matrix, 1.0)
    rows = tuple(tuple(float(v) for v in row) for row in matrix)
    return MountUncertainty(
        lever_arm_body_m=(0.01, 0.02, 0.03),
        boresight_rpy_deg=(0.05, 0.05, 0.1),
        latency_s=0.0005,
        correlation=StdCorrelation(tuple(names), rows),
    )


@settings(max_examples=100, deadline=None)
@given(unc=correlated())
def test_correlation_round_trips_exactly(unc: MountUncertainty) -> None:
    mount = Mount(uncertainty=unc)
    assert mount_from_toml_text(mount_to_toml_text(mount)) == mount


def test_correlation_reads_and_documents() -> None:
    text = BASE + CORR + 'names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, -0.8], [-0.8, 1]]\n'
    unc = mount_from_toml_text(text).uncertainty
    assert unc is not None
    assert unc.correlation is not None
    assert unc.correlation.names == ("lever_x_m", "latency_ms")
    assert unc.correlation.matrix == ((1.0, -0.8), (-0.8, 1.0))
    assert unc.as_document()["correlation"] == {
        "names": ["lever_x_m", "latency_ms"],
        "matrix": [[1.0, -0.8], [-0.8, 1.0]],
    }
    assert MountUncertainty(latency_s=0.001).as_document()["correlation"] is None


@pytest.mark.parametrize(
    ("table", "pattern"),
    [
        ('names = ["lever_x_m", "lever_q_m"]\nmatrix = [[1, 0], [0, 1]]\n',
         r"unknown name\(s\) \['lever_q_m'\]"),
        ('names = ["lever_x_m", "lever_x_m"]\nmatrix = [[1, 0], [0, 1]]\n',
         "lever_x_m named twice"),
        ('names = ["lever_x_m"]\nmatrix = [[1]]\n', "at least two"),
        ('names = "lever_x_m"\nmatrix = [[1]]\n', "a list of names"),
        ("names = [1, 2]\nmatrix = [[1, 0], [0, 1]]\n", r"names \(text\)"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, 0]]\n', "2 rows of 2"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, 0], [0.5, 1]]\n',
         r"matrix\[0\]\[1\] \(lever_x_m/latency_ms\) = 0.0 but matrix\[1\]\[0\] = 0.5"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[2, 0], [0, 1]]\n', "diagonal"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, 1.5], [1.5, 1]]\n',
         r"matrix\[0\]\[1\] \(lever_x_m/latency_ms\) = 1.5: a coefficient is within"),
        (NOT_PSD, "positive semidefinite"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, nan], [nan, 1]]\n',
         r"matrix\[0\]\[1\].*not a finite"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, "0"], ["0", 1]]\n', "a number"),
        ('names = ["lever_x_m", "latency_s"]\nmatrix = [[1, 0], [0, 1]]\n',
         "the latency is latency_ms here"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, 0], [0, 0.99]]\n',
         r"matrix\[1\]\[1\] \(latency_ms/latency_ms\) = 0.99: the diagonal is 1"),
        ('names = ["lever_x_m", "boresight_roll_deg"]\nmatrix = [[1, 0], [0, 1]]\n',
         r"does not give \(boresight_rpy_deg\)"),
        ('names = ["lever_x_m", "latency_ms"]\n', "exactly names"),
        ('parameters = ["lever_x_m", "latency_ms"]\nmatrix = [[1, 0], [0, 1]]\n',
         "parameters is now names"),
        ('names = ["lever_x_m", "latency_ms"]\nmatrix = [[1, 0], [0, 1]]\nnote = 1\n',
         "exactly names"),
    ],
    ids=["unknown-name", "duplicate", "one-name", "names-not-list", "names-not-text",
         "not-square", "asymmetric", "diagonal", "beyond-one", "not-psd", "nan", "text",
         "table-key-as-name", "diagonal-entry", "no-sigma", "no-matrix", "old-key", "extra-key"],
)  # fmt: skip
def test_bad_correlation_is_refused_naming_file_and_table(table: str, pattern: str) -> None:
    with pytest.raises(InputError, match=pattern) as info:
        mount_from_toml_text(BASE + CORR + table, source="cfg/mount.toml")
    assert str(info.value).startswith("cfg/mount.toml: ")
    assert "correlation" in str(info.value)


def test_a_value_measured_again_drops_its_correlations() -> None:
    # `latency sphere --mount-out` measures the latency on its own: the calibration's
    # latency correlations no longer hold; the lever arm's own ones do.
    names = ("lever_x_m", "lever_y_m", "latency_ms")
    rows = ((1.0, 0.3, -0.8), (0.3, 1.0, 0.1), (-0.8, 0.1, 1.0))
    unc = MountUncertainty(
        lever_arm_body_m=(0.02, 0.02, 0.03),
        latency_s=0.002,
        correlation=StdCorrelation(names, rows),
    )
    new = unc.with_independent(latency_s=0.0001)
    assert new.latency_s == 0.0001
    assert new.lever_arm_body_m == unc.lever_arm_body_m
    assert new.correlation == StdCorrelation(("lever_x_m", "lever_y_m"), ((1.0, 0.3), (0.3, 1.0)))
    lever = unc.with_independent(lever_arm_body_m=(0.01, 0.01, 0.01))
    assert lever.correlation is None  # only the latency is left: nothing to correlate
    assert MountUncertainty(latency_s=0.001).with_independent(latency_s=0.002).latency_s == 0.002


def test_with_independent_takes_an_array_and_refuses_an_empty_vector() -> None:
    unc = MountUncertainty(lever_arm_body_m=(0.02, 0.02, 0.03), latency_s=1e-3)
    new = unc.with_independent(lever_arm_body_m=np.array([0.01, 0.01, 0.02]))  # type: ignore[arg-type]
    assert new.lever_arm_body_m == (0.01, 0.01, 0.02)
    assert new.latency_s == 1e-3
    with pytest.raises(InputError, match=r"lever_arm_body_m: expected a list of 3 numbers, got 0"):
        unc.with_independent(lever_arm_body_m=[])  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"boresight_rpy_deg: expected a list of 3 numbers"):
        unc.with_independent(boresight_rpy_deg=())  # type: ignore[arg-type]


def test_a_matrix_read_within_the_tolerance_is_stored_positive_semidefinite() -> None:
    # An eigenvalue of -1e-7 is rounding, read; stored as it is it grows through a
    # calibration's [D; I] Sigma [D; I]' and the written table would then be refused.
    v = np.linalg.qr(np.random.default_rng(4).normal(size=(4, 4)))[0]
    r = (v * np.array([-1e-7, 0.5, 1.5, 2.0])) @ v.T
    d = np.sqrt(np.diag(r))
    r = r / np.outer(d, d)
    rows = tuple(tuple(float(x) for x in row) for row in r)
    corr = StdCorrelation(("lever_x_m", "lever_y_m", "lever_z_m", "latency_ms"), rows)
    stored = np.array(corr.matrix)
    assert np.min(np.linalg.eigvalsh(stored)) > -1e-12
    assert np.allclose(np.diag(stored), 1.0)
    assert np.max(np.abs(stored - r)) < 1e-6
    # A valid matrix is kept exactly (a written table reads back the same).
    exact = ((1.0, -0.8), (-0.8, 1.0))
    assert StdCorrelation(("lever_x_m", "latency_ms"), exact).matrix == exact


def test_a_matrix_rounded_by_hand_is_read_with_a_warning() -> None:
    # A calibration's strong correlations rounded to one decimal: the smallest
    # eigenvalue goes a little negative; the nearest positive semidefinite matrix is used.
    rounded = (
        'names = ["boresight_pitch_deg", "boresight_yaw_deg", "lever_y_m"]\n'
        "matrix = [[1, 0.99, -0.97], [0.99, 1, -0.9], [-0.97, -0.9, 1]]\n"
    )
    text = (
        BASE
        + "[uncertainty]\nlever_arm_body_m = [0.02, 0.02, 0.03]\n"
        + "boresight_rpy_deg = [0.1, 0.1, 0.1]\n[uncertainty.correlation]\n"
        + rounded
    )
    with pytest.warns(KinsyncWarning, match=r"m.toml: .*smallest eigenvalue -0\.0"):
        unc = mount_from_toml_text(text, source="m.toml").uncertainty
    assert unc is not None
    assert unc.correlation is not None
    assert np.min(np.linalg.eigvalsh(np.array(unc.correlation.matrix))) > -1e-12


def test_messages_name_the_unit_and_the_right_table() -> None:
    with pytest.raises(InputError, match=r"at most 360 deg"):
        mount_from_toml_text(BASE + "[uncertainty]\nboresight_rpy_deg = [0.1, 0.1, 400.0]\n")
    with pytest.raises(InputError, match=r"go in \[uncertainty.correlation\]"):
        mount_from_toml_text(BASE + '[correlation]\nnames = ["lever_x_m", "latency_ms"]\n')
    with pytest.warns(KinsyncWarning, match="arc-minutes or milliradians written as degrees"):
        mount_from_toml_text(BASE + "[uncertainty]\nboresight_rpy_deg = [0.1, 0.1, 10.0]\n")
