"""The HTML report: verdict first, summary of every check, conclusion, tolerances."""

from __future__ import annotations

from html.parser import HTMLParser

import pytest

from kinsync.report.html import (
    Section,
    Skipped,
    Table,
    internal_references,
    render_report,
    summary_line,
)
from kinsync.report.verdict import JUDGING_RULE, Check, Tolerance

MS = Tolerance("latency budget", 0.1, "ms", "abs_at_most", "0.1 ms is 0.9 mm on the beach")
MM = Tolerance("one error source", 10.0, "mm", "abs_at_most", "a third of 3 cm")
DETECT = Tolerance("detection", 0.01, "", "at_most", "99 % confidence", p_value=True)


class _Text(HTMLParser):
    """The page's visible text, in order, and the class of every verdict block."""

    def __init__(self) -> None:
        super().__init__()
        self.chunks: list[str] = []
        self.verdict_classes: list[str] = []
        self._skip = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        cls = dict(attrs).get("class") or ""
        if tag == "div" and cls.startswith("verdict"):
            self.verdict_classes.append(cls)
        self._skip = tag in ("style", "script")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("style", "script"):
            self._skip = False

    def handle_data(self, data: str) -> None:
        if not self._skip and data.strip():
            self.chunks.append(data.strip())


def _sections() -> list[Section]:
    return [
        Section(
            "Method A",
            paragraphs=("evidence paragraph A",),
            tables=(Table("per rate", ("rate", "latency"), (("2", "4.21"),)),),
            checks=(
                Check("latency error", 0.0017, MS, 0.0162, detail="truth 4.21 ms"),
                Check("detected", 1e-6, DETECT),
            ),
        ),
        Section(
            "Calibration",
            paragraphs=("evidence paragraph B",),
            checks=(Check("lever arm error", 7.1, MM, 4.8),),
        ),
    ]


def _text(page: str) -> tuple[str, _Text]:
    parser = _Text()
    parser.feed(page)
    return " | ".join(parser.chunks), parser


def test_summary_leads_and_covers_every_check() -> None:
    text, parser = _text(render_report("T", "intro", _sections()))
    summary = text.index("Summary: 2 of 3 checks pass")
    assert summary < text.index("evidence paragraph A")
    assert JUDGING_RULE in text
    head = text[summary : text.index("evidence paragraph A")]
    for quantity in ("latency error", "detected", "lever arm error"):
        assert quantity in head
    assert "0.002 ± 0.016 ms" in head
    assert "p < 0.001" in head
    assert "7.1 ± 4.8 mm" in head
    assert "±10 mm" in head
    assert parser.verdict_classes == ["verdict pass", "verdict fail"]


def test_each_topic_opens_with_its_verdict_then_the_evidence() -> None:
    text, _ = _text(render_report("T", "intro", _sections()))
    a = text.index("evidence paragraph A")
    verdict_a = text.rindex("Verdict:", 0, a)
    assert "2 of 2 checks pass" in text[verdict_a:a]
    assert "latency error: 0.002 ± 0.016 ms (truth 4.21 ms); tolerance ±0.1 ms: PASS." in text
    b = text.index("evidence paragraph B")
    assert "0 of 1 checks pass" in text[text.rindex("Verdict:", 0, b) : b]
    assert "lever arm error: 7.1 ± 4.8 mm; tolerance ±10 mm: FAIL." in text


def test_conclusion_names_the_failed_checks_and_lists_the_tolerances() -> None:
    page = render_report("T", "intro", _sections(), conclusion=("Take-away.",))
    text, _ = _text(page)
    end = text[text.index("Conclusion |") :]
    assert "2 of 3 checks pass; 1 of 2 topics pass every check." in end
    assert "Failed checks:" in end
    assert "Calibration: lever arm error" in end
    assert "Take-away." in end
    for tol in (MS, MM, DETECT):
        assert tol.name in end
        assert tol.why in end
    assert end.count("latency budget") == 1  # each tolerance listed once


def test_all_pass_says_so() -> None:
    sections = [Section("A", checks=(Check("e", 0.0, MS, 0.01),))]
    text, parser = _text(render_report("T", "i", sections))
    assert "Summary: 1 of 1 checks pass" in text
    assert "No check failed." in text
    assert parser.verdict_classes == ["verdict pass"]


def test_without_checks_no_summary_or_conclusion() -> None:
    text, parser = _text(render_report("T", "i", [Section("A", paragraphs=("p",))]))
    assert "Summary" not in text
    assert "Conclusion" not in text
    assert parser.verdict_classes == []


@pytest.mark.parametrize(
    ("text", "found"),
    [
        ("the budget of SPEC section 3 says", ["SPEC section 3"]),
        ("(SPEC sections 4-7 in a row)", ["SPEC sections 4-7"]),
        ("validation (SPEC 7)", ["SPEC"]),
        ("measured side by side (kinsync issue 17)", ["kinsync issue 17"]),
        ("see DESIGN.md", ["DESIGN.md"]),
        ("the generator's spec as shipped, a SPECTRUM, tissue 3", []),
    ],
)
def test_internal_references_are_found(text: str, found: list[str]) -> None:
    assert internal_references(text) == found


def test_topics_not_run_are_named_and_the_count_says_it_covers_only_those_run() -> None:
    # Without its reference data a topic vanished without a word, and the report said
    # "33 of 33 checks pass ... No check failed. Every topic meets its tolerance".
    sections = [Section("A", checks=(Check("e", 0.0, MS, 0.01),))]
    skipped = [Skipped("NaveGo", "not run: data not found (searched /x/shared and /y/shared)")]
    text, _ = _text(render_report("T", "i", sections, skipped=skipped))
    assert "Summary: 1 of 1 checks pass in the 1 topics run (1 topic not run: NaveGo)" in text
    assert "No check failed in the topics run." in text
    assert text.count("searched /x/shared and /y/shared") == 2  # under the summary, conclusion
    assert summary_line(sections) == "1 of 1 checks pass"


def test_caveats_stand_in_the_verdict_and_the_conclusion() -> None:
    sections = [Section("A", checks=(Check("e", 0.0, MS, 0.01),), caveats=("σ too small",))]
    page = render_report("T", "i", sections)
    text, _ = _text(page)
    verdict = page[
        page.index('class="verdict') : page.index("</div>", page.index('class="verdict'))
    ]
    assert "Not covered by these checks" in verdict
    assert "σ too small" in verdict
    assert "What the checks do not cover: | A: σ too small" in text


def test_what_produced_the_report_is_shown_under_the_introduction() -> None:
    about = [("kinsync version", "0.1.0"), ("command", "kinsync demo --out d")]
    page = render_report("T", "intro", _sections(), about=about)
    text, _ = _text(page)
    assert "How this report was made | kinsync version | 0.1.0 | command | kinsync demo" in text
    assert page.index("How this report was made") < page.index('class="summary"')
