"""The non-browser checks of a judged report: each rule is shown to fail, then to pass."""

from __future__ import annotations

import pytest

from kinsync.report.html import Figure, Section, Table, render_report
from kinsync.report.structure import p_value_problems, report_problems
from kinsync.report.verdict import Check, Tolerance

MM = Tolerance("one error source", 10.0, "mm", "abs_at_most", "a third of 3 cm")
DETECT = Tolerance("detection", 0.01, "", "at_most", "99 % confidence", p_value=True)
PNG = b"\x89PNG\r\n\x1a\n"


def _good_sections() -> list[Section]:
    return [
        Section(
            "Georeferencing",
            checks=(Check("largest error", 0.02, MM), Check("flagged", 1e-9, DETECT)),
            paragraphs=("A million points (p = 0.004 between runs).",),
            tables=(
                Table("walls", ("case", "p-value"), (("correct", "0.79"), ("late", "< 0.001"))),
            ),
            figures=(Figure("errors", PNG),),
        ),
        Section("Validation", checks=(Check("bow", 3.0, MM, 1.0),), paragraphs=("walls",)),
    ]


def test_a_good_report_has_no_problem() -> None:
    page = render_report("T", "intro", _good_sections(), conclusion=("Take-away.",))
    assert report_problems(page) == []


def test_a_topic_without_a_verdict_is_named() -> None:
    sections = [*_good_sections(), Section("Budget", paragraphs=("numbers only",))]
    problems = report_problems(render_report("T", "intro", sections))
    assert problems == ["topic 'Budget' has no verdict before its evidence (opens with a p)"]


def test_a_page_without_checks_has_no_summary_and_no_conclusion() -> None:
    problems = report_problems(render_report("T", "intro", [Section("A", paragraphs=("p",))]))
    assert "no summary table of verdicts" in problems
    assert "no conclusion" in problems
    assert "topic 'A' has no verdict before its evidence (opens with a p)" in problems


def test_verdict_after_the_evidence_is_a_problem() -> None:
    page = render_report("T", "intro", _good_sections())
    verdict_start = page.index('<div class="verdict')
    verdict_end = page.index("</div>", verdict_start) + len("</div>")
    verdict = page[verdict_start:verdict_end]
    moved = page[:verdict_start] + page[verdict_end:]
    moved = moved.replace("</figure>", "</figure>" + verdict, 1)
    problems = report_problems(moved)
    assert problems == [
        "topic 'Georeferencing' has no verdict before its evidence (opens with a p)"
    ]


def test_summary_after_the_topics_and_missing_conclusion_are_problems() -> None:
    page = render_report("T", "intro", _good_sections())
    start = page.index('<section class="summary">')
    end = page.index("</section>", start) + len("</section>")
    summary = page[start:end]
    page = page[:start] + page[end:]
    page = page.replace("</body>", summary + "</body>")
    page = page.replace('<section class="conclusion">', '<section class="appendix">')
    problems = report_problems(page)
    assert "the summary table of verdicts comes after the first topic" in problems
    assert "no conclusion" in problems


def test_internal_citations_and_bad_p_values_are_found() -> None:
    sections = _good_sections()
    sections[1] = Section(
        "Validation (SPEC section 7)",
        checks=(Check("bow", 3.0, MM, 1.0),),
        paragraphs=("curvature F 12, p 1.2e-07; again p = 0.0000",),
        tables=(Table("walls", ("case", "p-value"), (("late", "1.2e-07"),)),),
    )
    problems = report_problems(render_report("T", "intro", sections))
    assert "cites an internal document: 'SPEC section 7'" in problems
    assert "p-value written as 'p 1.2e-07'" in problems
    assert "p-value written as 'p = 0.0000'" in problems
    assert "p-value cell written as '1.2e-07'" in problems


@pytest.mark.parametrize(
    ("text", "bad"),
    [
        ("p < 0.001, p = 0.004, p = 0.79, p > 0.99, tolerance p ≤ 0.01", []),
        ("(p 0.79, not significant)", ["p 0.79"]),
        ("p = 3e-05", ["p = 3e-05"]),
        ("p=0.5", ["p=0.5"]),
        ("p < 0.05", ["p < 0.05"]),
        ("flagged when p < 0.01. Tolerance p ≤ 0.01.", []),
        ("p = 0.0004", ["p = 0.0004"]),
        ("step 5, group 3, 1 passes, p-value", []),
    ],
)
def test_p_value_forms(text: str, bad: list[str]) -> None:
    assert p_value_problems(text) == bad
