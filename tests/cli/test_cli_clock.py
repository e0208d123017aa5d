"""``kinsync simulate clock``, ``kinsync clock fit`` and ``kinsync clock apply``."""

from __future__ import annotations

import csv
import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from kinsync.io.clock_model import read_clock_model

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from kinsync.cli import main  # noqa: PLC0415

    folder = tmp_path_factory.mktemp("clock") / "logs"
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "clock", "--out", str(folder), "--seed", "1", "--json"])
    assert exc.value.code == 0
    return folder


def fit_args(folder: Path, *extra: str) -> list[str]:
    return [
        "clock",
        "fit",
        "--pps",
        str(folder / "pps.csv"),
        "--nmea",
        str(folder / "nmea.csv"),
        *extra,
    ]


def test_simulate_json_and_files(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "sim"
    code, stdout, _ = run_cli(
        [
            *["simulate", "clock", "--out", str(out), "--duration-s", "60", "--json"],
            *["--convention", "following", "--baud", "38400", "--zda-delay-ms", "20"],
        ]
    )
    assert code == 0
    doc = json.loads(stdout)
    assert doc["files"] == ["pps.csv", "nmea.csv", "truth.json"]
    assert doc["convention"] == "following"
    assert (doc["n_missing"], doc["n_spurious"], doc["n_wrong_zda"]) == (3, 2, 1)
    assert doc["n_pps_lines"] == 61 - 3 + 2
    truth = json.loads((out / "truth.json").read_text())
    assert truth["config"]["baud"] == 38400.0
    assert truth["config"]["zda_delay_ms"] == 20.0


def test_simulate_duration_span_is_the_one_declared(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    # The declared span was 1-86400 s, but under 9 s the simulator refused with another
    # message: the span now starts where the simulator does.
    from kinsync.cli._bounds import bounds_for  # noqa: PLC0415
    from kinsync.sim.clock import MIN_DURATION_S  # noqa: PLC0415

    span = bounds_for("simulate clock", "--duration-s")
    assert span is not None
    assert span.low == MIN_DURATION_S
    code, out, err = run_cli(
        ["simulate", "clock", "--out", str(tmp_path / "short"), "--duration-s", "5"]
    )
    assert_one_line_error(
        code, out, err, "--duration-s 5: outside the span kinsync accepts, 9 to 86400 s"
    )
    code, _, err = run_cli(
        ["simulate", "clock", "--out", str(tmp_path / "ok"), "--duration-s", str(span.low)]
    )
    assert code == 0, err


def test_simulate_table(run_cli: RunCli, tmp_path: Path) -> None:
    code, stdout, _ = run_cli(["simulate", "clock", "--out", str(tmp_path / "t")])
    assert code == 0
    assert "PPS + NMEA clock simulation" in stdout
    assert "truth.json" in stdout


def test_fit_json_matches_truth(run_cli: RunCli, logs: Path, tmp_path: Path) -> None:
    model_path = tmp_path / "model.json"
    fig = tmp_path / "res.png"
    code, stdout, _ = run_cli(
        fit_args(logs, "--json", "--model-out", str(model_path), "--figure", str(fig))
    )
    assert code == 0
    doc = json.loads(stdout)
    truth = json.loads((logs / "truth.json").read_text())
    for key in (
        "offset_s",
        "drift_ppm",
        "reference_local_s",
        "reference_gps_s",
        "residual_rms_s",
        "n_pulses",
        "n_missing",
        "n_spurious",
        "n_rejected_messages",
    ):
        assert key in doc
    assert abs(doc["drift_ppm"] - 25.0) < 0.01
    assert (doc["n_missing"], doc["n_spurious"], doc["n_wrong_zda"]) == (3, 2, 1)
    assert doc["n_rejected_messages"] == truth["n_rejected_messages"]
    assert len(doc["rejected_lines"]) == 2
    assert doc["offset_s"] == doc["reference_gps_s"] - doc["reference_local_s"]
    model = read_clock_model(model_path)
    assert model.reference_gps_s == doc["reference_gps_s"]
    assert model.drift_ppm == doc["drift_ppm"]
    err = model.apply(truth["edges_t_local_s"]) - np.asarray(truth["edges_gps_s"])
    assert np.max(np.abs(err)) < 2e-6
    assert fig.read_bytes().startswith(b"\x89PNG")


def test_fit_table(run_cli: RunCli, logs: Path) -> None:
    code, stdout, _ = run_cli(fit_args(logs))
    assert code == 0
    assert "drift (ppm)" in stdout
    assert "reference_gps_s" in stdout
    assert "rejected line" in stdout
    assert "t_gps_s = reference_gps_s" in stdout
    # the reference times to 1 us, what their float64 holds (it printed 1479384018.0000002)
    for name in ("reference_local_s", "reference_gps_s"):
        row = next(line for line in stdout.splitlines() if name in line)
        assert re.search(r"\b\d{10}\.\d{6}\b", row), row


def test_wrong_convention_is_seen_in_the_zda_delay(run_cli: RunCli, logs: Path) -> None:
    code, stdout, _ = run_cli(fit_args(logs, "--json", "--convention", "FOLLOWING"))
    assert code == 0
    doc = json.loads(stdout)
    assert doc["convention"] == "following"
    assert doc["zda_delay_s"] == pytest.approx(0.015 - 1.0, abs=1e-3)


def write_data(path: Path) -> list[list[str]]:
    rows = [
        ["id", "t_local_s", "label", "x_m"],
        ["1", "1479384100.25", "wall, north", "1.5"],
        ["2", "1479384200.5", "", "-2"],
        ["3", "1479384300.75", "ground", "1e-3"],
    ]
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return rows


def test_apply_keeps_every_column_and_row(run_cli: RunCli, logs: Path, tmp_path: Path) -> None:
    model_path = tmp_path / "model.json"
    assert run_cli(fit_args(logs, "--json", "--model-out", str(model_path)))[0] == 0
    data = tmp_path / "data.csv"
    rows = write_data(data)
    out = tmp_path / "data_gps.csv"
    code, stdout, _ = run_cli(
        [
            *["clock", "apply", "--model", str(model_path), "--in", str(data)],
            *["--column", "t_local_s", "--out", str(out), "--json"],
        ]
    )
    assert code == 0
    doc = json.loads(stdout)
    assert (doc["n_rows"], doc["n_outside_span"], doc["outside"]) == (3, 0, "extrapolate")
    with out.open(newline="") as fh:
        back = list(csv.reader(fh))
    assert back[0] == [*rows[0], "t_gps_s"]
    assert [r[:-1] for r in back[1:]] == rows[1:]
    model = read_clock_model(model_path)
    t_gps = np.array([float(r[-1]) for r in back[1:]])
    np.testing.assert_array_equal(t_gps, model.apply([float(r[1]) for r in rows[1:]]))
    assert not list(tmp_path.glob("*.part"))


@pytest.mark.parametrize("piecewise", [False, True], ids=["linear", "piecewise"])
def test_fit_json_table_and_model_file_describe_one_model(
    run_cli: RunCli, logs: Path, tmp_path: Path, piecewise: bool
) -> None:
    """--json, the table and --model-out give the same formula and piecewise knots."""
    model = tmp_path / "model.json"
    extra = ["--piecewise"] if piecewise else []
    code, stdout, err = run_cli(fit_args(logs, "--json", *extra, "--model-out", str(model)))
    assert code == 0, err
    doc = json.loads(stdout)
    written = json.loads(model.read_text())
    assert doc["formula"] == written["formula"] == read_clock_model(model).formula
    assert doc["piecewise"] == written["piecewise"]
    if piecewise:
        assert doc["formula"].startswith("t_gps_s = knots_gps_s[k] + ")
        assert len(doc["piecewise"]["knots_local_s"]) == doc["n_pulses"]
    else:
        assert doc["formula"].startswith("t_gps_s = reference_gps_s + ")
        assert doc["piecewise"] is None
    code, table, err = run_cli(fit_args(logs, *extra))
    assert code == 0, err
    assert doc["formula"] in table


def test_apply_outside_span(
    run_cli: RunCli, logs: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    linear = tmp_path / "linear.json"
    piecewise = tmp_path / "piecewise.json"
    assert run_cli(fit_args(logs, "--json", "--model-out", str(linear)))[0] == 0
    assert run_cli(fit_args(logs, "--json", "--piecewise", "--model-out", str(piecewise)))[0] == 0
    data = tmp_path / "late.csv"
    data.write_text("t_local_s\n1479384100.0\n1479384900.0\n")
    out = tmp_path / "o.csv"
    base = ["clock", "apply", "--in", str(data), "--out", str(out)]
    code, stdout, err = run_cli([*base, "--model", str(linear)])
    assert code == 0
    (note,) = [line for line in err.splitlines() if "outside the fitted span" in line]
    # one line (it was wrapped at 80 columns), marked as kinsync's as warnings are
    one_line = r"kinsync: note: 1 time\(s\) outside the fitted span \[.*\] s were \D+"
    assert re.fullmatch(one_line, note)
    assert "2 rows" in stdout
    code, out_text, err = run_cli([*base, "--model", str(piecewise)])
    # The option that allows it is named (it said "allow extrapolation with the linear model").
    assert_one_line_error(
        code, out_text, err, "late.csv: line 3", "outside", "piecewise", "--outside nan"
    )
    assert "--outside extrapolate" in err
    assert not out.exists() or "nan" not in out.read_text()
    code, stdout, _ = run_cli([*base, "--model", str(piecewise), "--outside", "nan", "--json"])
    assert code == 0
    assert json.loads(stdout)["n_outside_span"] == 1
    assert out.read_text().splitlines()[2].endswith(",nan")


def _boot_logs(logs: Path, boot: Path) -> Path:
    """The simulated logs on a clock started 100 s before them (time since boot)."""
    boot.mkdir()
    shift_s = 1479384017.0 - 100.0
    pps = (logs / "pps.csv").read_text().splitlines()
    (boot / "pps.csv").write_text(
        "\n".join([pps[0], *(repr(float(x) - shift_s) for x in pps[1:])]) + "\n"
    )
    nmea = [x.split(",", 1) for x in (logs / "nmea.csv").read_text().splitlines()]
    (boot / "nmea.csv").write_text(
        "\n".join([",".join(nmea[0]), *(f"{float(t) - shift_s!r},{s}" for t, s in nmea[1:])]) + "\n"
    )
    return boot


def test_fit_table_prints_no_offset_digit_the_model_cannot_hold(
    run_cli: RunCli, logs: Path, tmp_path: Path
) -> None:
    """A boot-time clock's offset (1.48e9 s) was printed to 1 ns ('...499999762'), below
    the 238 ns step of a float64 there."""
    code, stdout, _ = run_cli(fit_args(_boot_logs(logs, tmp_path / "boot")))
    assert code == 0
    row = next(x for x in stdout.splitlines() if "offset at reference" in x)
    offset_text = row.split("│")[2].split("±")[0].strip()
    assert offset_text.startswith("1479383917.3")
    assert len(offset_text.split(".")[1]) == 6
    code, stdout, _ = run_cli(fit_args(logs))
    row = next(x for x in stdout.splitlines() if "offset at reference" in x)
    assert len(row.split("│")[2].split("±")[0].strip().split(".")[1]) == 6


def test_apply_refuses_a_time_on_another_clock(
    run_cli: RunCli, logs: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """A model of a boot-time clock applied to a Unix time wrote a date in 2078 (exit 0)."""
    boot = _boot_logs(logs, tmp_path / "boot")
    model = tmp_path / "boot.json"
    assert run_cli(fit_args(boot, "--json", "--model-out", str(model)))[0] == 0
    lo, hi = read_clock_model(model).span_local_s
    data = tmp_path / "scan.csv"
    data.write_text(f"t_local_s\n{hi + 10.0!r}\n1718000000.5\n{lo - 0.9 * (hi - lo)!r}\n")
    out = tmp_path / "scan_gps.csv"
    base = ["clock", "apply", "--model", str(model), "--in", str(data), "--out", str(out)]
    code, stdout, err = run_cli(base)
    assert_one_line_error(
        code, stdout, err, "scan.csv: line 3", "1718000000.5", "another clock", "--outside"
    )
    assert f"[{lo!r}, {hi!r}]" in err
    assert not out.exists()
    # Within one span length of either end: extrapolated, with the note.
    data.write_text(f"t_local_s\n{hi + 10.0!r}\n{lo - 0.9 * (hi - lo)!r}\n")
    code, stdout, err = run_cli([*base, "--json"])
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["n_outside_span"] == 2
    assert doc["extrapolation_limit_local_s"] == [lo - (hi - lo), hi + (hi - lo)]
    # Asked for: every time is extrapolated.
    data.write_text("t_local_s\n1718000000.5\n")
    code, stdout, err = run_cli([*base, "--outside", "extrapolate"])
    assert code == 0, err
    assert "1 time(s) outside the fitted span" in err
    assert float(out.read_text().splitlines()[1].split(",")[1]) > 3e9


def test_apply_custom_out_column(run_cli: RunCli, logs: Path, tmp_path: Path) -> None:
    model_path = tmp_path / "model.json"
    assert run_cli(fit_args(logs, "--json", "--model-out", str(model_path)))[0] == 0
    data = tmp_path / "d.csv"
    data.write_text("stamp,t_gps_s\n1479384100.0,0\n")
    out = tmp_path / "o.csv"
    code, _, _ = run_cli(
        [
            *["clock", "apply", "--model", str(model_path), "--in", str(data), "--out", str(out)],
            *["--column", "stamp", "--out-column", "t_gps_new_s"],
        ]
    )
    assert code == 0
    assert out.read_text().splitlines()[0] == "stamp,t_gps_s,t_gps_new_s"


def test_fit_bad_input(
    run_cli: RunCli, logs: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    bad = tmp_path / "bad"
    shutil.copytree(logs, bad)
    pps, nmea = bad / "pps.csv", bad / "nmea.csv"

    def fit(*extra: str) -> tuple[int, str, str]:
        return run_cli(fit_args(bad, *extra))

    assert_one_line_error(*fit("--convention", "nearest"), "--convention")
    assert_one_line_error(*fit("--baud", "0"), "baud")
    pps.write_text("time_s\n1.0\n")
    assert_one_line_error(*fit(), "pps.csv", "t_local_s")
    pps.write_text("t_local_s\n")
    assert_one_line_error(*fit(), "pps.csv", "no pulses")
    pps.write_text("t_local_s\n1.0\nabc\n")
    assert_one_line_error(*fit(), "pps.csv", "line 3")
    pps.write_text("t_local_s\n1.0\n3.0\n2.0\n")
    assert_one_line_error(*fit(), "pps.csv", "line 4", "increasing")
    pps.unlink()
    assert_one_line_error(*fit(), "pps.csv", "not found")
    shutil.copy(logs / "pps.csv", pps)
    nmea.write_text("")
    assert_one_line_error(*fit(), "nmea.csv")
    nmea.write_text("t_local_s,sentence\n")
    assert_one_line_error(*fit(), "nmea.csv")
    lines = (logs / "nmea.csv").read_text().splitlines()
    nmea.write_text("\n".join([lines[0], *(x for x in lines[1:] if "ZDA" not in x)]) + "\n")
    assert_one_line_error(*fit(), "nmea.csv", "no valid ZDA")
    nmea.unlink()
    assert_one_line_error(*fit(), "nmea.csv", "not found")


def test_apply_bad_input(
    run_cli: RunCli, logs: Path, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    model_path = tmp_path / "model.json"
    assert run_cli(fit_args(logs, "--json", "--model-out", str(model_path)))[0] == 0
    data = tmp_path / "data.csv"
    write_data(data)
    out = tmp_path / "out.csv"

    def apply(*extra: str, model: Path = model_path, src: Path = data) -> tuple[int, str, str]:
        return run_cli(
            ["clock", "apply", "--model", str(model), "--in", str(src), "--out", str(out), *extra]
        )

    assert_one_line_error(*apply("--column", "time"), "column 'time' is not in the header")
    assert_one_line_error(*apply("--column", "label"), "line 2", "is not a number")
    assert_one_line_error(*apply("--outside", "clip"), "--outside")
    assert_one_line_error(*apply(src=tmp_path / "none.csv"), "none.csv", "not found")
    assert_one_line_error(*apply(model=tmp_path / "none.json"), "none.json", "not found")
    bad_model = tmp_path / "bad.json"
    bad_model.write_text('{"reference_local_s": 1.0}')
    assert_one_line_error(*apply(model=bad_model), "bad.json", "reference_gps_s")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    assert_one_line_error(*apply(src=empty), "empty file")
    header_only = tmp_path / "header.csv"
    header_only.write_text("t_local_s,x\n")
    assert_one_line_error(*apply(src=header_only), "no data rows")
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("t_local_s,x\n1.0,2\n3.0\n")
    assert_one_line_error(*apply(src=ragged), "line 3", "fields")
    nan = tmp_path / "nan.csv"
    nan.write_text("t_local_s\n1.0\nnan\n")
    assert_one_line_error(*apply(src=nan), "line 3", "not a finite number")
    has_col = tmp_path / "has.csv"
    has_col.write_text("t_local_s,t_gps_s\n1.0,2.0\n")
    assert_one_line_error(*apply(src=has_col), "already has a column 't_gps_s'")
    # An empty column name was written into the header; a .parquet got CSV text.
    for name in ("", " ", "a,b", 'say "t"'):
        assert_one_line_error(*apply("--out-column", name), "--out-column", "give a column name")
    parquet = tmp_path / "out.parquet"
    code, o, e = run_cli(
        ["clock", "apply", "--model", str(model_path), "--in", str(data), "--out", str(parquet)]
    )
    assert_one_line_error(code, o, e, "writes CSV; give a .csv file")
    assert not parquet.exists()
    code, o, e = run_cli(
        ["clock", "apply", "--model", str(model_path), "--in", str(data), "--out", str(data)]
    )
    assert_one_line_error(code, o, e, "is the input --in")
    assert not out.exists()


def _stepped_logs(folder: Path, step_s: float, at: int) -> tuple[Path, Path]:
    """The reviewer's logs: 600 pulses of a 25 ppm clock stepped by ``step_s`` at ``at``."""
    import datetime as dt  # noqa: PLC0415

    from kinsync.io.nmea import format_sentence  # noqa: PLC0415

    folder.mkdir()
    t0 = dt.datetime(2024, 6, 1, 12, tzinfo=dt.UTC)
    pps, nmea = [], []
    for k in range(600):
        t_local = 1000.0 + k / (1 + 25e-6) + (step_s if k >= at else 0.0)
        u = t0 + dt.timedelta(seconds=k)
        zda = format_sentence(f"GPZDA,{u:%H%M%S}.00,{u:%d,%m,%Y},00,00")
        pps.append(f"{t_local!r}\n")
        nmea.append(f'{t_local + 0.015 + (len(zda) + 2) * 10 / 115200!r},"{zda}"\n')
    (folder / "pps.csv").write_text("t_local_s\n" + "".join(pps))
    (folder / "nmea.csv").write_text("t_local_s,sentence\n" + "".join(nmea))
    return folder / "pps.csv", folder / "nmea.csv"


@pytest.mark.parametrize(("step_s", "at"), [(1.0, 250), (0.3, 250), (0.5, 400)])
def test_fit_refuses_a_step_of_the_local_clock(
    run_cli: RunCli,
    tmp_path: Path,
    assert_one_line_error: OneLineError,
    step_s: float,
    at: int,
) -> None:
    """Before: +1 s gave a model 1 s off with exit 0, +0.5 s cut the span short with exit
    0, +0.3 s said the pulses share no grid."""
    pps, _ = _stepped_logs(tmp_path / "logs", step_s, at)
    t = pps.read_text().splitlines()[1:]
    assert_one_line_error(
        *run_cli(fit_args(tmp_path / "logs", "--json")),
        f"stepped between pulse {at - 1} (t_local_s={t[at - 1]})",
        f"split the PPS and NMEA logs at t_local_s={t[at]}",
    )


def test_fit_lists_a_zda_without_gps_time_and_goes_on(
    run_cli: RunCli, logs: Path, tmp_path: Path
) -> None:
    """A ZDA at 23:59:60 on a day without a leap second stopped the fit (exit 2)."""
    from kinsync.io.nmea import format_sentence  # noqa: PLC0415

    folder = tmp_path / "leap"
    shutil.copytree(logs, folder)
    lines = (folder / "nmea.csv").read_text().splitlines()
    lines[401] = (
        lines[401].split(",")[0] + ',"' + format_sentence("GPZDA,235960.00,22,11,2026,00,00") + '"'
    )
    (folder / "nmea.csv").write_text("\n".join(lines) + "\n")
    code, out, err = run_cli(fit_args(folder, "--json"))
    assert code == 0, err
    doc = json.loads(out)
    assert {"line": 402, "reason": doc["rejected_lines"][0]["reason"]} in doc["rejected_lines"]
    assert "no leap second" in doc["rejected_lines"][0]["reason"]
    code, out, _ = run_cli(fit_args(folder))
    assert code == 0
    assert "rejected line 402: ZDA time has no GPS time" in out


def test_fit_table_lists_corrupt_lines_first_and_counts_ignored_types(
    run_cli: RunCli, logs: Path, tmp_path: Path
) -> None:
    """With GSV and VTG after every ZDA the table listed five 'unsupported sentence type'
    lines and hid the two corrupt ones behind '... and 1199 more rejected line(s)'."""
    from kinsync.io.nmea import format_sentence  # noqa: PLC0415

    folder = tmp_path / "gsv"
    shutil.copytree(logs, folder)
    gsv = format_sentence("GPGSV,3,1,11,03,03,111,00,04,15,270,00,06,01,010,00,13,06,292,00")
    vtg = format_sentence("GPVTG,054.7,T,034.4,M,005.5,N,010.2,K")
    lines = (folder / "nmea.csv").read_text().splitlines()
    out_lines = [lines[0]]
    for line in lines[1:]:
        out_lines.append(line)
        if "GPZDA" in line:
            t = float(line.split(",")[0])
            out_lines += [f'{t + 0.001!r},"{gsv}"', f'{t + 0.002!r},"{vtg}"']
    (folder / "nmea.csv").write_text("\n".join(out_lines) + "\n")
    n_zda = sum("GPZDA" in x for x in lines)
    code, stdout, _ = run_cli(fit_args(folder))
    assert code == 0
    corrupt = [x for x in stdout.splitlines() if x.startswith("rejected line")]
    assert len(corrupt) == 2
    assert not any("unsupported" in x for x in corrupt)
    assert "more rejected line" not in stdout
    assert f"not errors): {n_zda} GSV, {n_zda} VTG" in stdout
    code, stdout, _ = run_cli(fit_args(folder, "--json"))
    assert len(json.loads(stdout)["rejected_lines"]) == 2 + 2 * n_zda  # --json keeps them all
