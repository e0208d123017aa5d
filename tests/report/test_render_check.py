"""The report page renders in headless Chromium (skipped where no browser is installed)."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib as mpl
import pytest

mpl.use("Agg")
import matplotlib.pyplot as plt

from kinsync.errors import InputError
from kinsync.report.html import Figure, Section, Table, render_report
from kinsync.report.render_check import check_renders, find_chromium
from kinsync.report.verdict import Check, Tolerance

needs_browser = pytest.mark.skipif(find_chromium() is None, reason="no Chromium on PATH")


def _png() -> bytes:
    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.plot([0, 1], [1, 0])
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


_MM = Tolerance("one error source", 10.0, "mm", "abs_at_most", "a third of 3 cm")


def _page(tmp_path: Path, png: bytes, *, judge_two: bool = True, paragraph: str = "text") -> Path:
    sections = [
        Section(
            "One",
            paragraphs=(paragraph,),
            tables=(Table("t", ("a", "b"), (("1", "2"),)),),
            figures=(Figure("f", png),),
            checks=(Check("error", 1.0, _MM, 0.5),),
        ),
        Section(
            "Two",
            figures=(Figure("g", png),),
            checks=(Check("error", 12.0, _MM),) if judge_two else (),
        ),
    ]
    path = tmp_path / "report.html"
    path.write_text(render_report("Render test", "intro", sections), encoding="utf-8")
    return path


@needs_browser
def test_report_renders_with_every_figure_decoded(tmp_path: Path) -> None:
    shot = tmp_path / "shot.png"
    check = check_renders(_page(tmp_path, _png()), screenshot=shot)
    assert check.ok
    assert (check.n_images, check.n_images_decoded) == (2, 2)
    assert check.n_sections == 4  # summary, two topics, conclusion
    assert check.n_tables == 3  # summary, the topic's, tolerances
    assert (check.n_topics, check.n_topics_judged) == (2, 2)
    assert check.every_topic_judged
    assert check.n_failed_checks == 1
    assert check.internal_references == ()
    assert "Render test" in check.title
    assert check.screenshot == shot
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@needs_browser
def test_broken_figure_is_detected(tmp_path: Path) -> None:
    check = check_renders(_page(tmp_path, b"\x89PNG\r\n\x1a\nnot really a png"))
    assert check.n_images == 2
    assert check.n_images_decoded == 0
    assert not check.ok


@needs_browser
def test_topic_without_verdict_and_internal_reference_are_detected(tmp_path: Path) -> None:
    page = _page(tmp_path, _png(), judge_two=False, paragraph="the budget of SPEC section 3")
    check = check_renders(page)
    assert (check.n_topics, check.n_topics_judged) == (2, 1)
    assert not check.every_topic_judged
    assert check.internal_references == ("SPEC section 3",)
    assert not check.ok


def test_missing_page_is_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such report page"):
        check_renders(tmp_path / "nope.html")


def test_missing_browser_is_input_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("kinsync.report.render_check.find_chromium", lambda: None)
    page = tmp_path / "p.html"
    page.write_text("<html><body></body></html>", encoding="utf-8")
    with pytest.raises(InputError, match="no Chromium"):
        check_renders(page)
