"""A self-contained HTML report: inline CSS, figures embedded as base64 PNG.

The page needs no network and no other file, so it opens offline in any browser and
can be mailed as it is. When its sections carry checks (`kinsync.report.verdict`), the
page leads with a summary table of every check, opens each topic with its verdict
(what was measured, the value with its σ, the tolerance, pass or fail, and what those
checks do not cover) before the evidence, and ends with a conclusion and the table of
the tolerances with their reasons. Topics that were not run (`Skipped`) are named with
why in the summary and the conclusion: the count of checks covers only the topics run.
"""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from kinsync.report.verdict import JUDGING_RULE, Check, Tolerance, count_passed

__all__ = [
    "INTERNAL_REFERENCE",
    "Figure",
    "Section",
    "Skipped",
    "Table",
    "internal_references",
    "render_report",
    "summary_line",
]

INTERNAL_REFERENCE = re.compile(
    r"\bSPEC(?:\.md)?(?:\s+sections?\s*\d[\d\s,.-]*)?(?=\W|$)|\bDESIGN\.md\b"
    r"|\b(?i:(?:kinsync\s+)?issue\s+\d+)\b"
)
"""Text that points at the project's own documents, which a report's reader does not have."""


def internal_references(text: str) -> list[str]:
    """Every place ``text`` cites an internal document (``SPEC section 3``, ``issue 17``).

    A report is read by people who have none of the project's own documents: it must
    explain in place or cite a published reference instead.
    """
    return [m.group(0).strip() for m in INTERNAL_REFERENCE.finditer(text)]


_CSS = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222;
       line-height: 1.45; padding: 0 1em; }
h1 { border-bottom: 2px solid #246; padding-bottom: .2em; }
h2 { color: #246; margin-top: 2em; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.92em; }
th, td { border: 1px solid #bbb; padding: .3em .6em; text-align: right; }
th { background: #e8eef5; }
td:first-child, th:first-child { text-align: left; }
figure { margin: 1em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: .95em; color: #444; }
.note { color: #555; font-size: .92em; }
.verdict { border-left: 6px solid; padding: .4em 1em; margin: 1em 0; background: #f6f6f6; }
.verdict.pass { border-color: #1b7837; }
.verdict.fail { border-color: #b2182b; background: #fbeff0; }
.verdict ul { margin: .3em 0; padding-left: 1.3em; }
.skipped { border-left: 6px solid #b8860b; padding: .4em 1em; background: #fdf8ea; }
table.about td { text-align: left; }
.badge { font-weight: bold; padding: 0 .35em; border-radius: 3px; color: #fff; }
.badge.pass { background: #1b7837; }
.badge.fail { background: #b2182b; }
table.verdicts td { text-align: left; }
table.verdicts td.result { text-align: right; white-space: nowrap; }
table.tolerances td { text-align: left; }
"""


@dataclass(frozen=True)
class Table:
    """A table: a caption, column headers and rows of already formatted cells."""

    caption: str
    headers: Sequence[str]
    rows: Sequence[Sequence[str]]


@dataclass(frozen=True)
class Figure:
    """A PNG figure with a caption."""

    caption: str
    png: bytes


@dataclass(frozen=True)
class Section:
    """One section of the report: heading, verdict, paragraphs, tables and figures, in order.

    ``checks`` are the topic's verdict: rendered first, before the evidence. ``caveats``
    say, from the topic's own numbers, what its checks do not cover (a σ found too small,
    a figure outside a tolerance that no check judges): shown in the verdict and
    repeated in the conclusion, so that a pass is not read as more than was checked.
    """

    title: str
    paragraphs: Sequence[str] = ()
    tables: Sequence[Table] = ()
    figures: Sequence[Figure] = ()
    anchor: str = field(default="")
    checks: Sequence[Check] = ()
    caveats: Sequence[str] = ()


@dataclass(frozen=True)
class Skipped:
    """A topic the report would hold but that was not run, and why.

    Attributes
    ----------
    title : str
        The topic, as its section would be titled.
    reason : str
        Why it was not run and what would run it (e.g. the folders searched for its data).
    """

    title: str
    reason: str


def _table_html(t: Table) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in t.headers)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in t.rows
    )
    return (
        f"<table><caption>{html.escape(t.caption)}</caption>"
        f"<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    )


def _figure_html(f: Figure) -> str:
    data = base64.b64encode(f.png).decode("ascii")
    cap = html.escape(f.caption)
    return (
        f'<figure><img alt="{cap}" src="data:image/png;base64,{data}">'
        f"<figcaption>{cap}</figcaption></figure>"
    )


def _badge(passed: bool) -> str:
    word = "PASS" if passed else "FAIL"
    return f'<span class="badge {word.lower()}">{word}</span>'


def _caveats_html(caveats: Sequence[str]) -> str:
    if not caveats:
        return ""
    items = "".join(f"<li>{html.escape(c)}</li>" for c in caveats)
    return f"<p>Not covered by these checks:</p><ul>{items}</ul>"


def _verdict_html(checks: Sequence[Check], caveats: Sequence[str] = ()) -> str:
    passed, total = count_passed(checks)
    ok = passed == total
    items = "".join(f"<li>{_badge(c.passed)} {html.escape(c.sentence())}</li>" for c in checks)
    return (
        f'<div class="verdict {"pass" if ok else "fail"}"><p><strong>Verdict:</strong> '
        f"{_badge(ok)} {passed} of {total} checks pass.</p><ul>{items}</ul>"
        f"{_caveats_html(caveats)}</div>"
    )


def summary_line(sections: Sequence[Section], skipped: Sequence[Skipped] = ()) -> str:
    """``35 of 38 checks pass``, saying when it covers only the topics run.

    Parameters
    ----------
    sections : sequence of Section
        The topics run.
    skipped : sequence of Skipped
        The topics not run.

    Returns
    -------
    str
        E.g. ``33 of 33 checks pass in the 11 topics run (2 topics not run: NaveGo; CIDCO)``.
    """
    passed, total = count_passed([c for s in sections for c in s.checks])
    line = f"{passed} of {total} checks pass"
    if skipped:
        topics = sum(bool(s.checks) for s in sections)
        names = "; ".join(k.title for k in skipped)
        noun = "topic" if len(skipped) == 1 else "topics"
        line += f" in the {topics} topics run ({len(skipped)} {noun} not run: {names})"
    return line


def _skipped_html(skipped: Sequence[Skipped]) -> str:
    if not skipped:
        return ""
    items = "".join(
        f"<li><strong>{html.escape(k.title)}</strong>: {html.escape(k.reason)}</li>"
        for k in skipped
    )
    return (
        '<div class="skipped"><p>Not run, so neither counted nor judged here:</p>'
        f"<ul>{items}</ul></div>"
    )


def _about_html(about: Sequence[tuple[str, str]]) -> str:
    if not about:
        return ""
    rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v in about)
    return (
        '<table class="about"><caption>How this report was made</caption>'
        f"<tbody>{rows}</tbody></table>"
    )


def _summary_html(sections: Sequence[Section], skipped: Sequence[Skipped] = ()) -> str:
    rows = []
    for i, s in enumerate(sections):
        for c in s.checks:
            detail = f" ({c.detail})" if c.detail else ""
            rows.append(
                f'<tr><td><a href="#s{i}">{html.escape(s.title)}</a></td>'
                f"<td>{html.escape(c.quantity + detail)}</td>"
                f'<td class="result">{html.escape(c.measured())}</td>'
                f'<td class="result">{html.escape(c.tolerance.describe())}</td>'
                f"<td>{_badge(c.passed)}</td></tr>"
            )
    head = "".join(
        f"<th>{h}</th>" for h in ("topic", "what was measured", "result", "tolerance", "verdict")
    )
    return (
        f'<h2 id="summary">Summary: {html.escape(summary_line(sections, skipped))}</h2>'
        f"{_skipped_html(skipped)}"
        f"<p>{html.escape(JUDGING_RULE)} Each tolerance and the reason for it are listed "
        'in the <a href="#conclusion">conclusion</a>.</p>'
        f'<table class="verdicts"><thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table>"
    )


def _tolerances(sections: Sequence[Section]) -> list[Tolerance]:
    seen: dict[str, Tolerance] = {}
    for s in sections:
        for c in s.checks:
            seen.setdefault(c.tolerance.name, c.tolerance)
    return list(seen.values())


def _conclusion_html(
    sections: Sequence[Section], conclusion: Sequence[str], skipped: Sequence[Skipped] = ()
) -> str:
    failed = [(s.title, c) for s in sections for c in s.checks if not c.passed]
    topics = [s for s in sections if s.checks]
    topics_ok = sum(all(c.passed for c in s.checks) for s in topics)
    overall = (
        f"{summary_line(sections, skipped)}; {topics_ok} of {len(topics)} topics pass every check."
    )
    parts = [
        '<h2 id="conclusion">Conclusion</h2>',
        f"<p><strong>{html.escape(overall)}</strong></p>",
    ]
    if failed:
        items = "".join(
            f"<li>{html.escape(t)}: {html.escape(c.sentence())} "
            f'<span class="note">Tolerance: {html.escape(c.tolerance.why)}</span></li>'
            for t, c in failed
        )
        parts.append(f"<p>Failed checks:</p><ul>{items}</ul>")
    else:
        parts.append("<p>No check failed" + (" in the topics run." if skipped else ".") + "</p>")
    caveats = [(s.title, c) for s in sections for c in s.caveats]
    if caveats:
        items = "".join(f"<li>{html.escape(t)}: {html.escape(c)}</li>" for t, c in caveats)
        parts.append(f"<p>What the checks do not cover:</p><ul>{items}</ul>")
    parts.append(_skipped_html(skipped))
    parts.extend(f"<p>{html.escape(p)}</p>" for p in conclusion)
    rows = "".join(
        f"<tr><td>{html.escape(t.name)}</td><td>{html.escape(t.describe())}</td>"
        f"<td>{html.escape(t.why)}</td></tr>"
        for t in _tolerances(sections)
    )
    parts.append(
        '<table class="tolerances"><caption>Tolerances, fixed before the run, and why</caption>'
        f"<thead><tr><th>tolerance</th><th>limit</th><th>why this limit</th></tr></thead>"
        f"<tbody>{rows}</tbody></table>"
    )
    return "\n".join(parts)


def render_report(
    title: str,
    intro: str,
    sections: Sequence[Section],
    conclusion: Sequence[str] = (),
    *,
    skipped: Sequence[Skipped] = (),
    about: Sequence[tuple[str, str]] = (),
) -> str:
    """Render a complete HTML document.

    Parameters
    ----------
    title : str
        Page title and main heading.
    intro : str
        A paragraph under the heading.
    sections : sequence of Section
        Rendered in order, with a table of contents. When any carries checks, the page
        opens with a summary table of every check and ends with a conclusion (failed
        checks first) and the table of tolerances.
    conclusion : sequence of str
        Paragraphs added to the conclusion (with checks only).
    skipped : sequence of Skipped
        Topics not run: named with why under the summary and in the conclusion, whose
        counts then say they cover only the topics run.
    about : sequence of (str, str)
        What produced the report (version, date, command, folders, seeds): a table
        under the introduction.
    """
    judged = any(s.checks for s in sections)
    toc = "".join(
        f'<li><a href="#s{i}">{html.escape(s.title)}</a></li>' for i, s in enumerate(sections)
    )
    if judged:
        toc += '<li><a href="#conclusion">Conclusion</a></li>'
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><p>{html.escape(intro)}</p>",
        _about_html(about),
    ]
    if judged:
        parts.append(f'<section class="summary">{_summary_html(sections, skipped)}</section>')
    parts.append(f"<nav><ol>{toc}</ol></nav>")
    for i, s in enumerate(sections):
        parts.append(f'<section class="topic"><h2 id="s{i}">{html.escape(s.title)}</h2>')
        if s.checks:
            parts.append(_verdict_html(s.checks, s.caveats))
        parts.extend(f"<p>{html.escape(p)}</p>" for p in s.paragraphs)
        parts.extend(_table_html(t) for t in s.tables)
        parts.extend(_figure_html(f) for f in s.figures)
        parts.append("</section>")
    if judged:
        parts.append(
            f'<section class="conclusion">{_conclusion_html(sections, conclusion, skipped)}'
            "</section>"
        )
    parts.append("</body></html>")
    return "\n".join(parts)
