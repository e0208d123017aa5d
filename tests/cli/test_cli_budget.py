"""``kinsync budget ...``: JSON documents, tables and bad input."""

from __future__ import annotations

import json
import math
from collections.abc import Callable

import pytest

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py


def test_latency_json(run_cli: RunCli) -> None:
    argv = ["budget", "latency", "--range-m", "50", "--slope-deg", "10", "--rate-deg-s", "10"]
    code, out, err = run_cli([*argv, "--latency-ms", "0.1", "--latency-ms", "1", "--json"])
    assert code == 0
    assert err == ""
    doc = json.loads(out)
    assert doc["scenario"]["range_m"] == 50.0
    assert doc["scenario"]["slope_deg"] == 10.0
    assert [r["latency_ms"] for r in doc["rows"]] == [0.1, 1.0]
    a = math.radians(10.0)
    eps = math.radians(10.0) * 1e-3
    r_true = 50 * math.sin(a) / math.sin(a - eps)
    row = doc["rows"][1]
    assert row["vertical_error_m"] == pytest.approx(-(r_true - 50) * math.tan(a), rel=1e-9)
    assert row["horizontal_error_m"] == pytest.approx(r_true * math.cos(eps) - 50, rel=1e-9)


def test_latency_at_nadir_from_an_aircraft(run_cli: RunCli) -> None:
    """An airborne scanner at nadir, 1000 m over flat ground, rolling 10 deg/s at 60 m/s:
    the horizontal beam's beach was the only scenario (slope 0 refused), and the record
    of the wrong instant's position was left out."""
    argv = ["budget", "latency", "--beam-deg", "90", "--slope-deg", "0", "--range-m", "1000"]
    code, out, err = run_cli([*argv, "--speed-m-s", "60", "--latency-ms", "1", "--json"])
    assert code == 0, err
    (row,) = json.loads(out)["rows"]
    eps = math.radians(10.0) * 1e-3
    across, along = 1000.0 * math.tan(eps), 60.0 * 1e-3
    assert row["position_error_m"] == pytest.approx(along, rel=1e-12)
    assert row["horizontal_error_m"] == pytest.approx(math.hypot(across, along), rel=1e-9)
    assert row["point_horizontal_error_m"] == pytest.approx(math.hypot(across, along), rel=1e-9)
    sag = 1000.0 / math.cos(eps) - 1000.0  # the true range is longer: placed below
    assert row["vertical_error_m"] == pytest.approx(-sag, rel=1e-6)
    assert row["point_vertical_error_m"] == pytest.approx(-sag, rel=1e-6)
    assert row["point_error_m"] == pytest.approx(math.hypot(across, along, sag), rel=1e-9)
    assert row["horizontal_error_linear_m"] == pytest.approx(math.hypot(1000 * eps, along))
    code, out, err = run_cli([*argv, "--speed-m-s", "60", "--latency-ms", "1"])
    assert code == 0, err
    assert "beam at nadir, 1000 m slant range, 0 deg slope, 10 deg/s roll, 60 m/s" in out
    assert "scanner" in out
    assert "184.6" in out


def test_the_point_error_is_shown_beside_the_surface_figures(run_cli: RunCli) -> None:
    """SPEC's horizontal figure is where the two beams meet the surface, not the placed
    point's horizontal error: a beam 30 deg off nadir gave 'horizontal 0.20 m' for a
    point 0.15 m off horizontally."""
    argv = ["budget", "latency", "--beam-deg", "60", "--slope-deg", "0", "--range-m", "1000"]
    code, out, err = run_cli([*argv, "--latency-ms", "1", "--json"])
    assert code == 0, err
    (row,) = json.loads(out)["rows"]
    assert row["horizontal_error_m"] == pytest.approx(0.2016, abs=1e-4)
    assert row["point_horizontal_error_m"] == pytest.approx(0.1512, abs=1e-4)
    assert row["point_vertical_error_m"] == pytest.approx(-0.0873, abs=1e-4)
    assert math.hypot(row["point_horizontal_error_m"], row["point_vertical_error_m"]) == (
        pytest.approx(row["point_error_m"], rel=1e-9)
    )


def test_latency_table(run_cli: RunCli) -> None:
    code, out, _ = run_cli(["budget", "latency"])
    assert code == 0
    assert "Latency error budget" in out
    assert "0.1" in out


def test_serial_json(run_cli: RunCli) -> None:
    code, out, _ = run_cli(["budget", "serial", "--baud", "115200", "--bytes", "14", "--json"])
    assert code == 0
    doc = json.loads(out)
    assert doc.pop("provenance")["command"] == (
        "kinsync budget serial --baud 115200 --bytes 14 --json"
    )
    assert doc == {"latency_s": pytest.approx(14 * 10 / 115200), "warnings": []}
    argv = ["budget", "serial", "--baud", "9600", "--bytes", "16", "--parity", "even"]
    code, out, _ = run_cli([*argv, "--stop-bits", "2", "--json"])
    assert json.loads(out)["latency_s"] == pytest.approx(16 * 12 / 9600)
    # any case: "EVEN" was refused as "parity must be one of ..."
    code, out, err = run_cli([*argv[:-1], "EVEN", "--stop-bits", "1.5", "--json"])
    assert code == 0, err
    assert json.loads(out)["latency_s"] == pytest.approx(16 * 11.5 / 9600)
    code, out, _ = run_cli(["budget", "serial", "--baud", "115200", "--bytes", "14"])
    assert "1.215" in out


def test_period_json(run_cli: RunCli) -> None:
    argv = ["budget", "period", "--profiles", "10000", "--period-error-s", "1e-6"]
    code, out, _ = run_cli([*argv, "--speed-m-s", "2", "--json"])
    assert code == 0
    doc = json.loads(out)
    assert doc["time_error_s"] == pytest.approx(0.01)
    assert doc["position_error_m"] == pytest.approx(0.02)


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (
            ["budget", "serial", "--baud", "-115200", "--bytes", "14"],
            "--baud -115200: outside the span",
        ),
        (["budget", "serial", "--baud", "115200", "--bytes", "-1"], "bytes"),
        # kbit/s for bit/s: a 115 bit/s line was taken (1.2 s for 14 bytes)
        (
            ["budget", "serial", "--baud", "115.2", "--bytes", "14"],
            "--baud 115.2: a line rate in kbit/s? give bit/s (115200 for 115.2 kbit/s)",
        ),
        (
            ["simulate", "clock", "--out", "x", "--baud", "9.6e0"],
            "outside the span",
        ),
        (
            ["budget", "serial", "--baud", "115200", "--bytes", "4", "--parity", "x"],
            "--parity 'x': give one of none, even, odd, mark, space",
        ),
        # was "stop bits must be 1, 1.5 or 2", not naming the option
        (
            ["budget", "serial", "--baud", "115200", "--bytes", "4", "--stop-bits", "1.7"],
            "--stop-bits 1.7: give 1, 1.5 or 2",
        ),
        (["budget", "latency", "--range-m", "-50"], "--range-m -50: outside the span"),
        # a horizontal beam (the default) onto a flat surface: both options named
        (["budget", "latency", "--slope-deg", "0"], "give a slope (--slope-deg, a beach)"),
        (["budget", "latency", "--slope-deg", "0"], "or a beam below horizontal (--beam-deg"),
        (["budget", "latency", "--slope-deg", "-1"], "--slope-deg -1: outside the span"),
        (["budget", "latency", "--beam-deg", "91"], "--beam-deg 91: outside the span"),
        (["budget", "latency", "--speed-m-s", "-60"], "--speed-m-s -60: outside the span"),
        (["budget", "latency", "--slope-deg", "1", "--latency-ms", "500"], "grazing"),
        # Exactly at grazing (10 deg/s x 1 s = the 10 deg slope): was exit 0 with 1e17 m.
        (["budget", "latency", "--latency-ms", "1000", "--json"], "reaches or exceeds the grazing"),
        # A repeatable option's values were not held to the option's span, nor to be finite.
        (["budget", "latency", "--latency-ms", "36000"], "--latency-ms 36000: outside the span"),
        (
            ["budget", "latency", "--latency-ms", "1", "--latency-ms", "-20000"],
            "--latency-ms -20000: outside the span",
        ),
        (["budget", "latency", "--latency-ms", "nan"], "--latency-ms nan: not a finite number"),
        # 100 deg/s x 3.6 s is a full turn: it wrapped to a vertical error of 1e-11 mm.
        (["budget", "latency", "--rate-deg-s", "100", "--latency-ms", "3600"], "half a turn"),
        # The reason given for the low end ("a horizontal beam meets no horizontal surface")
        # was given for the high end too.
        (["budget", "latency", "--slope-deg", "90"], "not a vertical wall"),
        (
            [
                "budget",
                "period",
                "--profiles",
                "10",
                "--period-error-s",
                "1e-6",
                "--speed-m-s",
                "-2",
            ],
            "speed",
        ),
    ],
)
def test_bad_input_exits_2_with_one_line(argv: list[str], fragment: str, run_cli: RunCli) -> None:
    code, out, err = run_cli(argv)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith("kinsync: error: ")
    assert fragment in err
