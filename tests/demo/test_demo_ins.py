"""Demo sections for the INS/GNSS filter: the MEMS drive and the NaveGo external check.

The MEMS section runs on a shorter drive than the report's (100 s instead of 240 s);
its tables are checked against a direct run of the same workflow.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path
from typing import Any

import matplotlib.image as mpimg
import numpy as np
import pytest

from kinsync.demo.ins import ERROR_HEADERS, InsDemoSetup, ins_section
from kinsync.demo.navego import NAVEGO_PEERS, find_navego_folder, navego_section
from kinsync.errors import InputError
from kinsync.ins.alignment import align_static_gnss_heading
from kinsync.ins.compare import Comparison, compare_to_truth
from kinsync.ins.filter import run_ins
from kinsync.report.html import Section, render_report
from kinsync.report.ins_figures import ErrorSeries, error_envelope_figure, route_map_figure
from kinsync.sim.drive import simulate_drive

SHORT = InsDemoSetup(duration_s=100.0, static_s=20.0, align_s=15.0, outage_s=(60.0, 75.0), seed=3)
MG = 9.80665e-3


def _image(png: bytes) -> np.ndarray:
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    img = np.asarray(mpimg.imread(io.BytesIO(png), format="png"))
    assert img.ndim == 3
    assert img.shape[0] > 200
    assert img.shape[1] > 200
    return img


def _cells(cell: str) -> np.ndarray:
    return np.array([float(v) for v in cell.split(" / ")])


def _close3(cell: str, values: Any) -> None:
    """A cell of three values printed to 3 significant digits equals ``values``."""
    got = _cells(cell)
    want = np.asarray(values, dtype=np.float64)
    assert got.shape == want.shape == (3,)
    assert np.all(np.abs(got - want) <= 5e-3 * np.abs(want) + 1e-12), (cell, want)


@pytest.fixture(scope="module")
def built(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Path, Section, dict[str, Any], list[tuple[str, str, str]]]:
    out = tmp_path_factory.mktemp("ins-demo")
    summary: list[tuple[str, str, str]] = []
    labels: list[str] = []
    section, doc = ins_section(out, summary, setup=SHORT, progress=labels.append)
    assert labels  # progress reported
    return out, section, doc, summary


@pytest.fixture(scope="module")
def direct() -> dict[str, Any]:
    """The same workflow run directly: simulate, align, filter, smooth, compare."""
    sim = simulate_drive(SHORT.drive_config())
    init = align_static_gnss_heading(
        sim.imu,
        sim.gnss,
        static_s=SHORT.align_s,
        antenna_lever_arm_body_m=sim.config.antenna_lever_arm_body_m,
    )
    res = run_ins(sim.imu, sim.gnss, sim.ins_config, init, smooth=True)
    assert res.smoothed is not None
    return {
        "sim": sim,
        "init": init,
        "result": res,
        "forward": compare_to_truth(res.forward, sim.truth),
        "smoothed": compare_to_truth(res.smoothed, sim.truth),
    }


def test_section_builds_with_tables_figures_and_files(built: Any) -> None:
    out, section, doc, summary = built
    assert "INS/GNSS" in section.title
    assert len(section.tables) == 3
    assert len(section.figures) == 3
    for i, fig in enumerate(section.figures):
        _image(fig.png)
        assert (out / f"ins_{i + 1}.png").read_bytes() == fig.png
    assert json.loads((out / "ins.json").read_text()) == json.loads(json.dumps(doc))
    assert not list(out.glob("*.part"))
    html_text = render_report("t", "i", [section])
    assert html_text.count("data:image/png;base64,") == 3
    assert [row[0] for row in summary] == ["INS/GNSS (MEMS)"]
    _capability, scenario, result = summary[0]
    assert "15 s GNSS outage" in scenario
    assert "outage drift forward" in result


def test_error_table_equals_a_direct_computation(built: Any, direct: dict[str, Any]) -> None:
    _out, section, doc, summary = built
    table = section.tables[0]
    assert tuple(table.headers) == ERROR_HEADERS
    rows = {row[0]: row for row in table.rows}
    fwd: Comparison = direct["forward"]
    smo: Comparison = direct["smoothed"]
    for label, cmp in (("forward filter", fwd), ("smoothed", smo)):
        row = rows[label]
        _close3(row[1], cmp.rms_pos_ned_m)
        _close3(row[2], cmp.max_pos_ned_m)
        _close3(row[3], cmp.rms_vel_ned_m_s)
        _close3(row[4], cmp.max_vel_ned_m_s)
        _close3(row[5], cmp.rms_att_deg)
        _close3(row[6], cmp.max_att_deg)
    a, b = SHORT.outage_s
    for label, cmp in (("forward filter", fwd), ("smoothed", smo)):
        row = rows[f"{label}, outage {a:g}-{b:g} s"]
        inside = (cmp.t_s >= a) & (cmp.t_s <= b)
        assert inside.sum() == round((b - a) * 200) + 1
        e = cmp.err_pos_ned_m[inside]
        _close3(row[1], np.sqrt(np.mean(e**2, axis=0)))
        _close3(row[2], np.abs(e).max(axis=0))
        assert cmp.err_vel_ned_m_s is not None
        _close3(row[4], np.abs(cmp.err_vel_ned_m_s[inside]).max(axis=0))
        _close3(row[6], np.abs(cmp.err_att_deg[inside]).max(axis=0))
    # the outage is what the smoother bridges: the forward drift is far larger
    last = np.flatnonzero((fwd.t_s >= a) & (fwd.t_s <= b))[-1]
    drift = {n: float(np.hypot(*c.err_pos_ned_m[last, :2])) for n, c in (("f", fwd), ("s", smo))}
    assert doc["horizontal_error_at_outage_end_m"]["forward"] == pytest.approx(drift["f"])
    assert doc["horizontal_error_at_outage_end_m"]["smoothed"] == pytest.approx(drift["s"])
    assert drift["f"] > 10 * drift["s"]
    assert f"{drift['f']:.2f} m" in summary[0][2]


def test_three_sigma_table_equals_a_direct_computation(built: Any, direct: dict[str, Any]) -> None:
    _out, section, _doc, _summary = built
    table = section.tables[1]
    assert tuple(table.headers) == ("solution", "position", "velocity", "attitude")
    assert [r[0] for r in table.rows] == ["forward filter", "smoothed"]
    for row, cmp in zip(table.rows, (direct["forward"], direct["smoothed"]), strict=True):
        w = cmp.within_3sigma
        for cell, block in zip(row[1:], ("pos", "vel", "att"), strict=True):
            want = [100.0 * w[f"{block}_{a}"] for a in "ned"]
            assert np.allclose(_cells(cell), want, atol=0.05 + 1e-9), (row[0], block)


def test_bias_table_against_the_injected_errors(built: Any, direct: dict[str, Any]) -> None:
    _out, section, doc, _summary = built
    table = section.tables[2]
    sim, res, init = direct["sim"], direct["result"], direct["init"]
    errors = sim.imu_errors
    k0 = int(np.searchsorted(errors.t_s, res.forward.t_s[0]))
    blocks = (
        ("gyro", math.degrees(1.0), errors.gyro_bias_total_rad_s(), "gyro_bias_rad_s"),
        ("accelerometer", 1.0 / MG, errors.acc_bias_total_m_s2(), "acc_bias_m_s2"),
    )
    rows = iter(table.rows)
    for name, scale, injected, attr in blocks:
        for i, axis in enumerate("XYZ"):
            row = next(rows)
            assert row[0].startswith(f"{name} {axis}")
            assert float(row[1]) == pytest.approx(injected[k0, i] * scale, abs=5e-5)
            assert float(row[3]) == pytest.approx(injected[-1, i] * scale, abs=5e-5)
            est_text, std_text = row[4].split(" ± ")
            half_unit = 0.5 * 10.0 ** -len(est_text.partition(".")[2]) + 1e-12
            sol_est = getattr(res.forward, attr)[-1, i] * scale
            sol_std = getattr(res.forward, "std_" + attr)[-1, i] * scale
            assert float(est_text) == pytest.approx(sol_est, abs=half_unit)
            assert float(std_text) == pytest.approx(sol_std, abs=half_unit)
            # what the table shows is a recovery: within 3σ of the injected bias
            assert abs(sol_est - injected[-1, i] * scale) <= 3.0 * sol_std
        assert doc["biases"][attr]["alignment"] == list(getattr(init, attr))
    assert next(rows, None) is None


def test_document_and_text_carry_the_run(built: Any, direct: dict[str, Any]) -> None:
    _out, section, doc, _summary = built
    assert doc["errors"]["forward"] == direct["forward"].as_document()
    assert doc["errors"]["smoothed"] == direct["smoothed"].as_document()
    # the filter starts at the first IMU epoch: the standstill holds the aligned state
    assert doc["initial_state"]["t_s"] == direct["sim"].imu.t_s[0]
    # the datasheet's figures as they are: turn-on bias and a 100 s instability
    assert doc["filter_config"]["acc_bias_corr_time_s"] == 100.0
    assert max(doc["smoothed_acc_bias_start_error_sigma"]) < 4.0
    assert doc["gnss_used"] == direct["result"].forward.n_gnss_used
    text = " ".join(section.paragraphs)
    assert f"{doc['gnss_used']} GNSS epochs used" in text
    assert "Gauss-Markov" in text


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"align_s": 30.0, "static_s": 30.0}, "shorter than static_s"),
        ({"outage_s": (10.0, 40.0)}, "after the static start"),
        ({"outage_s": (200.0, 250.0)}, "before the end"),
        ({"outage_s": (150.0, 140.0)}, "outage_s"),
        ({"duration_s": -5.0}, "duration_s"),
        ({"speed_m_s": float("nan")}, "speed_m_s"),
    ],
)
def test_bad_setups_are_rejected(kwargs: dict[str, Any], words: str) -> None:
    with pytest.raises(InputError, match=words):
        InsDemoSetup(**kwargs)


def test_figure_inputs_are_checked() -> None:
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(InputError, match="ErrorSeries"):
        ErrorSeries("x", t, np.zeros((4, 3)), np.ones((5, 3)))
    with pytest.raises(InputError, match="at least one"):
        error_envelope_figure([], ("N", "E", "D"), "m", "t")
    ne = np.zeros((5, 2))
    with pytest.raises(InputError, match="window"):
        route_map_figure(ne, ne, [("s", ne)], (3, 3), "t")
    with pytest.raises(InputError, match="shape"):
        route_map_figure(ne, ne, [("s", np.zeros((4, 2)))], (0, 3), "t")
    with pytest.raises(InputError, match=r"\(n, 2\)"):
        route_map_figure(np.zeros((5, 3)), ne, [], (0, 3), "t")


def test_error_figure_draws_envelopes() -> None:
    t = np.linspace(0.0, 10.0, 200)
    err = np.column_stack([np.sin(t), np.cos(t), 0.1 * t])
    png = error_envelope_figure(
        [
            ErrorSeries("a", t, err, np.ones((200, 3))),
            ErrorSeries("b", t, err, 2 * np.ones((200, 3))),
        ],
        ("N", "E", "D"),
        "m",
        "title",
        [(2.0, 4.0)],
    )
    img = _image(png)
    assert img.shape[1] > img.shape[0]  # two columns side by side


NAVEGO = find_navego_folder()


@pytest.mark.skipif(NAVEGO is None, reason="NaveGo data set not found in ../shared/data")
def test_navego_section_against_the_peer_figures(tmp_path: Path) -> None:
    assert NAVEGO is not None
    summary: list[tuple[str, str, str]] = []
    section, doc = navego_section(NAVEGO, tmp_path, summary)
    assert "NaveGo" in section.title
    _image(section.figures[0].png)
    assert (tmp_path / "navego_1.png").read_bytes() == section.figures[0].png
    assert json.loads((tmp_path / "navego.json").read_text()) == json.loads(json.dumps(doc))
    rows = section.tables[0].rows
    assert len(rows) == 8
    for run, (fwd_row, smo_row) in zip(
        doc["runs"], zip(rows[::2], rows[1::2], strict=True), strict=True
    ):
        assert fwd_row[0] == smo_row[0] == run["condition"]
        assert fwd_row[3] == "forward"
        assert smo_row[3] == "smoothed"
        _close3(fwd_row[4], run["forward"]["rms_pos_ned_m"])
        _close3(fwd_row[5], run["forward"]["rms_att_deg"])
        _close3(smo_row[4], run["smoothed"]["rms_pos_ned_m"])
        name, pos, att = NAVEGO_PEERS[run["condition"]]
        assert fwd_row[6] == name
        ours = np.round([*run["forward"]["rms_pos_ned_m"], *run["forward"]["rms_att_deg"]], 3)
        worse = [
            ax
            for ax, v, p in zip(
                ("N", "E", "D", "roll", "pitch", "yaw"), ours, (*pos, *att), strict=True
            )
            if v > p
        ]
        assert run["meets_peer"] == (not worse)
        assert fwd_row[9] == ("yes" if not worse else "no: " + ", ".join(worse))
        # the smoother uses all the data: better than the forward filter on every axis
        assert np.all(np.less(run["smoothed"]["rms_pos_ned_m"], run["forward"]["rms_pos_ned_m"]))
        assert np.all(np.less(run["smoothed"]["rms_att_deg"], run["forward"]["rms_att_deg"]))
    by = {run["condition"]: run for run in doc["runs"]}
    # issue 17's conditions, one shipped configuration: B and C meet the best peer
    assert by["B"]["meets_peer"]
    assert by["C"]["meets_peer"]
    assert by["A"]["turn_on_biases"] == "estimated from zero"
    assert [r[0] for r in summary] == ["INS/GNSS, external data"]
    assert "pyins 0.333/0.407/0.527 m" in summary[0][2]


def test_navego_section_names_a_broken_spec(tmp_path: Path) -> None:
    folder = tmp_path / "navego"
    folder.mkdir()
    (folder / "imu_gnss_spec.json").write_text("{not json")
    with pytest.raises(InputError, match=r"imu_gnss_spec\.json"):
        navego_section(folder, tmp_path, [])
