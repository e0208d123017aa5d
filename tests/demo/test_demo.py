"""``kinsync demo``: the report folder and the summary."""

from __future__ import annotations

import json
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest

import kinsync.demo.run as demo_run
from kinsync.cli import main
from kinsync.demo.manifest import write_manifest
from kinsync.errors import InputError
from kinsync.report.render_check import check_renders, find_chromium
from kinsync.report.structure import report_problems


class _Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.imgs: list[str] = []
        self.tables = 0
        self.headings: list[str] = []
        self._in_h2 = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "img":
            self.imgs.append(dict(attrs).get("src") or "")
        if tag == "table":
            self.tables += 1
        self._in_h2 = tag == "h2"

    def handle_data(self, data: str) -> None:
        if self._in_h2:
            self.headings.append(data)
            self._in_h2 = False


@pytest.mark.slow
def test_demo_writes_a_self_contained_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_dir = tmp_path / "demo"
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", str(out_dir)])
    assert exc.value.code == 0
    captured = capsys.readouterr()
    out = captured.out
    assert "kinsync demo summary" in out
    # stderr is not a terminal here: one line per part of the demo, in order, to the report
    stages = [line.split(": ", 2)[2] for line in captured.err.splitlines()]
    assert stages[0].startswith("error budgets (")
    assert stages[-1].startswith("report (")
    assert any(s.startswith("INS/GNSS") for s in stages)
    assert "kinsync:" not in out
    assert "latency budget" in out
    html_text = (out_dir / "report.html").read_text()
    parser = _Collector()
    parser.feed(html_text)
    assert len(parser.imgs) >= 5
    assert all(src.startswith("data:image/png;base64,") for src in parser.imgs)
    assert parser.tables >= 3
    assert any("Latency error budget" in h for h in parser.headings)
    assert any("Method A" in h for h in parser.headings)
    method_a = json.loads((out_dir / "method_a.json").read_text())
    est = method_a["estimate"]
    truth_ms = method_a["truth"]["latency_s"] * 1e3
    assert abs(est["latency_ms"] - truth_ms) < 3 * est["latency_std_ms"]
    assert est["latency_std_ms"] <= 0.1
    assert (out_dir / "method-a-passes" / "passes.csv").exists()
    assert "Method A latency" in out
    assert any("PPS" in h or "clock" in h.lower() for h in parser.headings)
    assert any("georeferencing" in h.lower() for h in parser.headings)
    assert "georeferencing" in out
    assert "http://" not in html_text
    assert "https://" not in html_text
    doc = json.loads((out_dir / "budget.json").read_text())
    assert doc["beach"]["rows"][0]["latency_ms"] == 0.1
    assert (out_dir / "budget_1.png").read_bytes().startswith(b"\x89PNG")
    assert not list(out_dir.glob("*.part"))
    listed = [
        line.split("  ", 1)[1] for line in (out_dir / demo_run.MANIFEST).read_text().splitlines()
    ]
    assert "report.html" in listed
    assert "patch-test-vehicle/mount_lever_uncertainty.toml" in listed
    assert sorted(p.relative_to(out_dir).as_posix() for p in out_dir.rglob("*")
                  if p.is_file() and p.name != demo_run.MANIFEST) == listed  # fmt: skip
    titles = ("INS/GNSS", "Method B", "Validation", "End to end", "Mount self-calibration")
    for title in (*titles, "Coordinate systems"):
        assert any(h.startswith(title) for h in parser.headings), title
    calibration = json.loads((out_dir / "calibration.json").read_text())
    for scenario in ("vehicle", "vessel"):
        truth = calibration[scenario]["truth"]
        params = calibration[scenario]["result"]["parameters"]
        latency = params["latency_ms"]
        assert abs(latency["value"] - truth[6]) < 4 * latency["std"]
        assert (out_dir / f"patch-test-{scenario}" / "truth.json").exists()
    assert calibration["vehicle"]["result"]["parameters"]["lever_z_m"]["status"] == "unobservable"
    # The vehicle's lines again with the lever arm held and its 3 cm stated: the sigma
    # with the held part holds the error the data's sigma alone misses.
    held = calibration["vehicle_lever_held"]
    latency = held["result"]["parameters"]["latency_ms"]
    assert latency["std_held"] > 0.0
    assert abs(latency["value"] - held["truth"][6]) < 3 * latency["std"]
    assert held["result"]["held"]["lever_y_m"]["std"] == 0.03
    # A later survey holding the vessel's calibrated mount, written with its correlations.
    later = calibration["vessel_later"]
    lat = later["result"]["parameters"]["latency_ms"]
    assert lat["status"] in ("estimated", "weak")
    assert abs(lat["value"] - later["truth_latency_ms"]) < 3 * lat["std"]
    assert later["result"]["mount"]["uncertainty"]["correlation"] is not None
    assert lat["std_held"] > 0.0
    assert abs(later["latency_std_if_independent_ms"] - lat["std"]) > 0.02 * lat["std"]
    written = (out_dir / "patch-test-vessel" / "calibrated.toml").read_text()
    assert "[uncertainty.correlation]" in written
    assert "mount self-calibration" in out
    for key in ("INS/GNSS", "Method B", "end-to-end: validation"):
        assert key in out
    # a judged report: summary of verdicts first, a verdict opening every topic, a
    # conclusion last, no internal citations, p-values written "p < 0.001"
    assert report_problems(html_text) == []
    assert "capability that has landed" not in html_text
    assert html_text.index('class="summary"') < html_text.index('class="topic"')
    assert "Conclusion" in html_text[html_text.index('class="conclusion"') :]
    if find_chromium() is not None:
        check = check_renders(out_dir / "report.html")
        assert check.ok, check
        assert check.every_topic_judged, check
        assert check.n_images == len(parser.imgs)
        assert check.n_sections == len(parser.headings)


def test_demo_refuses_a_file_as_output_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "file.txt"
    target.write_text("x")
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", str(target)])
    assert exc.value.code == 2
    assert "not a folder" in capsys.readouterr().err


def test_demo_refuses_a_folder_with_other_files_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_work(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the demo started working")

    monkeypatch.setattr(demo_run, "budget_section", no_work)
    out = tmp_path / "d"
    (out / "clock").mkdir(parents=True)
    (out / "budget.json").write_text('{"mine": 1}\n')
    (out / "clock" / "pps.csv").write_text("t_local_s\n1.0\n")
    with pytest.raises(InputError, match=r"other files \(budget.json, clock\)"):
        demo_run.run_demo(out)
    assert (out / "budget.json").read_text() == '{"mine": 1}\n'
    assert (out / "clock" / "pps.csv").read_text() == "t_local_s\n1.0\n"


def test_an_interrupted_demo_leaves_the_earlier_report(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def interrupt(*_args: object, **_kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(demo_run, "method_a_section", interrupt)  # after the budgets' files
    out = tmp_path / "d"
    out.mkdir()
    (out / "report.html").write_text("<h1>kinsync demo report</h1>\n")
    (out / "budget.json").write_text("{}\n")
    write_manifest(out)
    with pytest.raises(KeyboardInterrupt):
        demo_run.run_demo(out)
    assert sorted(p.name for p in out.iterdir()) == ["budget.json", "demo-files.txt", "report.html"]
    assert (out / "budget.json").read_text() == "{}\n"
    assert [p.name for p in tmp_path.iterdir()] == ["d"]


def test_an_earlier_demo_folder_with_the_users_files_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "d"
    (out / "patch-test-vehicle").mkdir(parents=True)
    (out / "report.html").write_text("<h1>kinsync demo report</h1>\n")
    (out / "budget.json").write_text("{}\n")
    (out / "patch-test-vehicle" / "line_01.laz").write_bytes(b"x")
    with pytest.raises(InputError, match=r"without demo-files.txt"):  # cannot tell
        demo_run.check_demo_folder(out)
    write_manifest(out)
    demo_run.check_demo_folder(out)  # the demo's own files only: replaced on a re-run
    cases = {
        "patch-test-vehicle/my_figure.png": r"did not write \(patch-test-vehicle/my_figure.png\)",
        "notes.txt": r"did not write \(notes.txt\)",
    }
    for name, pattern in cases.items():
        (out / name).write_text("mine")
        with pytest.raises(InputError, match=pattern):
            demo_run.check_demo_folder(out)
        (out / name).unlink()
    (out / "budget.json").write_text('{"my own": 1}\n')  # saved under a demo file's name
    with pytest.raises(InputError, match=r"changed since the demo wrote them \(budget.json\)"):
        demo_run.check_demo_folder(out)
    (out / "budget.json").write_text("{}\n")
    (out / "results" / "deeper").mkdir(parents=True)  # a user's (empty) folders
    with pytest.raises(InputError, match=r"\(results, results/deeper\)"):
        demo_run.check_demo_folder(out)
    (out / "results" / "deeper").rmdir()
    (out / "results").rmdir()
    (out / "link").symlink_to(tmp_path)
    with pytest.raises(InputError, match=r"\(link\)"):
        demo_run.check_demo_folder(out)
    (out / "link").unlink()
    (out / demo_run.MANIFEST).write_text("budget.json\nreport.html\n")  # the first layout
    with pytest.raises(InputError, match=r"line 1 is not 'SHA256  path'"):
        demo_run.check_demo_folder(out)


@pytest.mark.parametrize("where", ["missing_parent", "current_folder"])
def test_demo_refuses_an_output_it_cannot_publish_before_any_work(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    where: str,
) -> None:
    # `--out /tmp/x/nope/deeper/x` created nope/deeper and started work (left behind when
    # interrupted); `--out .` ran the whole demo, then refused its own temporary folder.
    def no_work(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the demo started working")

    monkeypatch.setattr(demo_run, "budget_section", no_work)
    if where == "current_folder":
        monkeypatch.chdir(tmp_path)
        out, fragment = ".", "--out .: is the current folder"
    else:
        out, fragment = str(tmp_path / "nope" / "deeper" / "x"), "does not exist"
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", out])
    assert exc.value.code == 2
    assert fragment in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def _stub_sections(monkeypatch: pytest.MonkeyPatch, failing: bool) -> None:
    """Every part of the demo replaced by a one-check topic; no reference data found."""
    from kinsync.demo.tolerances import ONE_ERROR_SOURCE  # noqa: PLC0415
    from kinsync.report.html import Section  # noqa: PLC0415
    from kinsync.report.verdict import Check  # noqa: PLC0415

    def topic(title: str, value: float = 1.0) -> Section:
        return Section(title, checks=(Check(f"{title} error", value, ONE_ERROR_SOURCE),))

    monkeypatch.setattr(demo_run, "budget_section", lambda _s: (topic("budgets"), {}))
    for name in ("method_a", "clock", "georef", "crs", "validation"):
        monkeypatch.setattr(demo_run, f"{name}_section", lambda *_a, n=name: topic(n))
    monkeypatch.setattr(
        demo_run, "ins_section", lambda *_a, **_k: (topic("ins", 50.0 if failing else 1.0), {})
    )
    monkeypatch.setattr(demo_run, "method_b_section", lambda *_a: (topic("method b"), {}))
    monkeypatch.setattr(demo_run, "end_to_end_section", lambda *_a: (topic("end to end"), {}))
    monkeypatch.setattr(
        demo_run, "calibration_section", lambda *_a: (topic("self-calibration"), {})
    )
    monkeypatch.setattr(demo_run, "find_navego_folder", lambda: None)
    monkeypatch.setattr(demo_run, "find_cidco_folder", lambda: None)


def test_topics_without_their_data_are_named_in_the_report_and_on_the_terminal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # Without ../shared the NaveGo and CIDCO topics vanished without a word, the report
    # said "33 of 33 checks pass ... Every topic meets its tolerance", and the progress
    # line still said "(simulated patch tests, CIDCO)".
    _stub_sections(monkeypatch, failing=False)
    out = tmp_path / "d"
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", str(out)])
    assert exc.value.code == 0
    captured = capsys.readouterr()
    html_text = (out / "report.html").read_text()
    line = "10 of 10 checks pass in the 10 topics run (2 topics not run: "
    assert f"Summary: {line}" in html_text
    assert f"summary: {line}" in captured.out
    assert "not run: NaveGo" not in captured.out  # said twice: "not run: X: not run: ..."
    assert re.search(r"NaveGo[^\n]*: not run: ", captured.out)
    for where in (html_text, captured.out):
        assert "NaveGo synthetic set" in where
        assert "CIDCO" in where
        assert "searched" in where
        assert "shared/data/navego-synthetic" in where
    assert "Every topic meets its tolerance" not in html_text
    stages: list[str] = []
    demo_run.run_demo(tmp_path / "e", progress=lambda _f, stage: stages.append(stage))
    assert "mount self-calibration from survey lines (simulated patch tests)" in stages
    assert report_problems(html_text) == []


def test_the_terminal_names_the_failed_checks_and_json_gives_the_summary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # With 3 FAILs stdout had no count and no failed check; `demo --json`: "No such option".
    _stub_sections(monkeypatch, failing=True)
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", str(tmp_path / "d")])
    assert exc.value.code == 0  # the report is the verdict; exit 2 is for bad input
    out = capsys.readouterr().out
    assert "summary: 9 of 10 checks pass" in out
    assert "FAIL ins: ins error" in out
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", str(tmp_path / "e"), "--json"])
    assert exc.value.code == 0
    doc = json.loads(capsys.readouterr().out)
    assert (doc["checks_passed"], doc["checks_total"]) == (9, 10)
    assert doc["failed_checks"] == ["ins: ins error"]
    assert len(doc["skipped_topics"]) == 2
    assert doc["rows"] == []


def test_the_report_says_what_produced_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _stub_sections(monkeypatch, failing=False)
    out = tmp_path / "d"
    demo_run.run_demo(out)
    html_text = (out / "report.html").read_text()
    about = html_text[html_text.index("How this report was made") : html_text.index("</table>")]
    import kinsync  # noqa: PLC0415

    for field in ("kinsync version", kinsync.__version__, "date (UTC)", "command",
                  f"kinsync demo --out {out}", "output folder", str(out),
                  "NaveGo synthetic set", "not found; searched", "simulation seeds",
                  "patch tests vehicle 11, vessel 12"):  # fmt: skip
        assert field in about, field
    assert ".part" not in about
