"""PPS + NMEA clock simulator: files, truth, faults as configured, bad set-ups."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from kinsync.clock import fit_clock_to_log, utc_fields_to_gps_s, zda_to_gps_s
from kinsync.errors import InputError
from kinsync.io.clock_model import read_pps_csv
from kinsync.io.nmea import read_nmea_log
from kinsync.messages import GgaRecord, HdtRecord, RmcRecord, ZdaRecord
from kinsync.sim.clock import ClockSimConfig, simulate_clock, write_clock_simulation


def test_files_and_truth(tmp_path: Path) -> None:
    sim = simulate_clock(ClockSimConfig(duration_s=60.0, seed=3))
    write_clock_simulation(sim, tmp_path / "out")
    folder = tmp_path / "out"
    pps = read_pps_csv(folder / "pps.csv")
    np.testing.assert_array_equal(pps, sim.pps_t_local_s)
    assert len(pps) == 61 - 3 + 2
    with (folder / "nmea.csv").open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t_local_s", "sentence"]
    assert len(rows) - 1 == len(sim.nmea_sentences) == 4 * 61
    assert '"$GPZDA,' in (folder / "nmea.csv").read_text()
    log = read_nmea_log(folder / "nmea.csv")
    kinds = {type(r) for r in log.records}
    assert kinds == {ZdaRecord, GgaRecord, RmcRecord, HdtRecord}
    reasons = sorted(r.reason for r in log.rejected)
    assert len(reasons) == 2
    assert reasons[0].startswith("bad checksum")
    assert reasons[1].startswith("truncated")
    truth = json.loads((folder / "truth.json").read_text())
    assert truth == json.loads(json.dumps(sim.truth))
    assert [b["line"] for b in truth["bad_lines"]] == sorted(r.line for r in log.rejected)
    # Every arrival time is increasing and the ZDAs read back name the seconds simulated.
    assert np.all(np.diff(log.t_local_s) > 0)
    zda_t, zdas = log.zda()
    np.testing.assert_array_equal(zda_t, sim.zda_t_local_s)
    assert [zda_to_gps_s(z) for z in zdas] == sim.zda_gps_s.tolist()


def test_physics_of_the_truth() -> None:
    cfg = ClockSimConfig(duration_s=30.0, jitter_us=0.0, missing=0, spurious=0, bad_zda=0)
    sim = simulate_clock(cfg)
    truth = sim.truth
    g0 = utc_fields_to_gps_s(2026, 11, 22, 12 * 3600.0)
    assert truth["reference_gps_s"] == g0 == truth["edges_gps_s"][0]
    assert truth["reference_local_s"] == g0 - 0.37
    edges_gps = np.asarray(truth["edges_gps_s"])
    np.testing.assert_allclose(
        sim.true_local_s(edges_gps), truth["edges_t_local_s"], rtol=0, atol=0
    )
    np.testing.assert_allclose(sim.true_gps_s(sim.pps_t_local_s), edges_gps, rtol=0, atol=3e-7)
    # 25 ppm slow: 30 GPS seconds last 30 / (1 + 25e-6) local seconds.
    assert sim.pps_t_local_s[-1] - sim.pps_t_local_s[0] == pytest.approx(30 / (1 + 25e-6), abs=1e-6)
    # The ZDA of edge k starts 15 ms after it and arrives after its transmission.
    first_zda = sim.nmea_sentences[0]
    assert first_zda.startswith("$GPZDA,120000.00,22,11,2026,")
    tx = (len(first_zda) + 2) * 10 / 115200
    assert float(sim.true_gps_s(sim.zda_t_local_s[0])) - g0 == pytest.approx(0.015 + tx, abs=3e-4)


def test_following_convention_names_the_next_edge() -> None:
    sim = simulate_clock(ClockSimConfig(duration_s=20.0, convention="following", bad_zda=0))
    g0 = sim.truth["reference_gps_s"]
    assert len(sim.zda_gps_s) == 21
    np.testing.assert_array_equal(sim.zda_gps_s, g0 + np.arange(21))
    # The first ZDA goes out before the first edge, announcing it.
    assert sim.zda_t_local_s[0] < sim.truth["edges_t_local_s"][0]


def test_same_seed_same_data() -> None:
    a = simulate_clock(ClockSimConfig(duration_s=20.0, seed=7))
    b = simulate_clock(ClockSimConfig(duration_s=20.0, seed=7))
    c = simulate_clock(ClockSimConfig(duration_s=20.0, seed=8))
    np.testing.assert_array_equal(a.pps_t_local_s, b.pps_t_local_s)
    assert a.nmea_sentences == b.nmea_sentences
    assert not np.array_equal(a.pps_t_local_s, c.pps_t_local_s)


def test_wrong_zda_is_off_by_one_second() -> None:
    sim = simulate_clock(ClockSimConfig(duration_s=40.0, bad_zda=2, seed=2))
    wrong = sim.truth["wrong_zda"]
    assert len(wrong) == 2
    for w in wrong:
        assert abs(w["named_gps_s"] - w["true_gps_s"]) == 1.0
        assert w["true_gps_s"] not in sim.truth["missing_gps_s"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"duration_s": 5.0}, "at least 9"),
        ({"duration_s": 20.0, "missing": 15, "bad_zda": 5}, "interior edges"),
        ({"jitter_us": -1.0}, "jitter_us"),
        ({"baud": 1200.0}, "within 0.95 s"),
        ({"zda_delay_ms": 0.0}, "zda_delay_ms"),
        ({"convention": "nearest"}, "preceding or following"),
        ({"start_utc": "yesterday"}, "ISO 8601"),
        ({"start_utc": "2026-11-22T12:00:00.5"}, "whole second"),
        ({"start_utc": "1979-01-01T00:00:00"}, "GPS epoch"),
        ({"missing": -1}, "non-negative"),
        ({"drift_ppm": float("nan")}, "finite"),
    ],
)
def test_bad_setups(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        simulate_clock(ClockSimConfig(**kwargs))  # type: ignore[arg-type]


def test_refuses_a_file_as_folder(tmp_path: Path) -> None:
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        write_clock_simulation(simulate_clock(ClockSimConfig(duration_s=10.0)), target)


def test_many_spurious_pulses_make_a_log_its_reader_accepts(tmp_path: Path) -> None:
    """100000 spurious pulses in 10 s of local time about 1.5e9 s: draws that round to
    one float made a PPS log with a repeated time, which read_pps_csv refuses."""
    config = ClockSimConfig(duration_s=9.0, missing=0, bad_zda=0, spurious=100_000, seed=2)
    sim = simulate_clock(config)
    write_clock_simulation(sim, tmp_path / "out")
    pps = read_pps_csv(tmp_path / "out" / "pps.csv")
    assert len(pps) == config.n_edges + 100_000
    assert np.all(np.diff(pps) > 0.0)
    spurious = np.asarray(sim.truth["spurious_t_local_s"])
    assert len(np.unique(spurious)) == 100_000


def test_a_leap_second_is_written_as_23_59_60(tmp_path: Path) -> None:
    """The edge inside the leap second of 2016-12-31 was written 000000.00 01-01-2017,
    twice, so the fit counted a wrong ZDA the truth did not list."""
    config = ClockSimConfig(
        start_utc="2016-12-31T23:55:00", missing=0, spurious=0, bad_zda=0, bad_lines=0
    )
    sim = simulate_clock(config)
    zdas = [s for s in sim.nmea_sentences if s.startswith("$GPZDA")]
    times = [s.split(",")[1] for s in zdas]
    assert times.count("235960.00") == 1
    assert times.count("000000.00") == 1
    leap = zdas[times.index("235960.00")]
    assert ",31,12,2016," in leap
    gga = [s.split(",")[1] for s in sim.nmea_sentences if s.startswith("$GPGGA")]
    assert gga.count("235960.00") == 1
    write_clock_simulation(sim, tmp_path)
    fit = fit_clock_to_log(read_pps_csv(tmp_path / "pps.csv"), read_nmea_log(tmp_path / "nmea.csv"))
    assert fit.n_wrong_zda == sim.truth["n_wrong_zda"] == 0
    assert fit.model.offset_s == pytest.approx(0.37, abs=1e-5)
