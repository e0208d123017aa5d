"""The demo's words follow from its numbers: what a check does not cover is said.

A reviewer found a PASS whose conclusion claimed more than its checks tested (the
self-calibrated latency "within its share" at 4.47 ± 3.46 ms against a 1 ms share), a
gyro Z bias 3.12σ off and a NaveGo pitch inside 3σ on 43 % of the epochs shown without
a word, undetermined parameters printed as "calibrated" values, and the CIDCO sphere-fit
numbers and residual figure in no file beside the report.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from kinsync.demo.calibration import calibrated_cell, latency_caveat
from kinsync.demo.ins import gyro_bias_sentence
from kinsync.demo.method_a import cidco_section, find_cidco_folder
from kinsync.demo.navego import pitch_coverage_sentence


def test_a_self_calibrated_latency_beyond_its_share_is_said_with_its_numbers() -> None:
    text = latency_caveat([("vehicle", 4.47, 3.46, 5.0), ("vessel", 2.08, 2.19, 5.0)])
    assert text is not None
    assert "vehicle 4.47 ± 3.46 ms for a true 5.00 ms" in text
    assert "vessel 2.08 ± 2.19 ms" in text
    assert "2.2-3.5 ms exceeds the ±1 ms share" in text
    assert "Method A" in text
    assert latency_caveat([("vehicle", 5.1, 0.3, 5.0)]) is None  # 0.1 + 0.6 <= 1 ms


def test_an_undetermined_parameter_is_shown_as_held() -> None:
    assert calibrated_cell(-1.75, "unobservable") == "held at -1.7500"
    assert calibrated_cell(0.0, "fixed") == "held at 0.0000"
    assert calibrated_cell(4.4697, "weak") == "4.4697"


def test_a_gyro_bias_beyond_three_sigma_is_named_with_its_values() -> None:
    d = math.radians(1.0)
    gyro = {
        "smoothed_start": [0.01 * d, 0.02 * d, 0.03514 * d],
        "smoothed_start_std": [0.001 * d, 0.001 * d, 0.00088 * d],
        "injected_start": [0.0111 * d, 0.0181 * d, 0.0379 * d],
    }
    text = gyro_bias_sentence(gyro)
    assert "gyro Z 0.03514 ± 0.00088 deg/s against 0.0379 injected (-3.14 sigma)" in text
    assert "gyro X" not in text
    gyro["injected_start"] = gyro["smoothed_start"]
    assert gyro_bias_sentence(gyro) == "the gyro biases within 0.0 sigma."


def test_the_navego_pitch_coverage_is_stated_with_its_cause() -> None:
    runs = [
        {"condition": c, "smoothed": {"within_3sigma": {"att_n": 0.97, "att_e": e, "att_d": 1.0}}}
        for c, e in (("A", 0.796), ("B", 0.428), ("C", 0.935), ("C+v", 0.449))
    ]
    text = pitch_coverage_sentence(runs)
    assert "79.6 % (A), 42.8 % (B), 93.5 % (C), 44.9 % (C+v)" in text
    assert "roll and yaw on at least 97.0 %" in text
    assert "0.02° about the body Y axis" in text


CIDCO = find_cidco_folder()


@pytest.mark.skipif(CIDCO is None, reason="no CIDCO data in ../shared")
def test_the_cidco_sphere_fits_are_written_as_json_and_png(tmp_path: Path) -> None:
    assert CIDCO is not None
    section = cidco_section(CIDCO, tmp_path, [])
    doc = json.loads((tmp_path / "cidco.json").read_text())
    table = section.tables[0]
    assert [p["pass"] for p in doc["passes"]] == [row[0] for row in table.rows]
    for p, row in zip(doc["passes"], table.rows, strict=True):
        assert f"{p['free_radius']['radius_m']:.4f}" == row[2]
        assert f"{p['fixed_radius']['residual_rms_m'] * 1e3:.1f}" == row[5]
        assert f"{p['fixed_radius']['centre_std_norm_m'] * 1e3:.2f}" == row[6]
    assert (tmp_path / "cidco_1.png").read_bytes() == section.figures[0].png
