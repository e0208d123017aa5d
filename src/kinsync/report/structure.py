"""What a judged report must look like, checked on its HTML without a browser.

`report_problems` reads a page written by `kinsync.report.html.render_report` and
lists every way it falls short of a report that speaks to a surveyor:

- the summary table of verdicts comes before any topic;
- every topic opens with its verdict, before any paragraph, table or figure;
- every check in the summary says PASS or FAIL, and the page ends with a conclusion;
- no text cites a document the reader does not have (``SPEC section 3``);
- p-values are written ``p < 0.001``, ``p = 0.004``, ``p = 0.79``, ``p > 0.99`` (a
  column headed "p-value" holds the same without the ``p``), never ``p 1.2e-07``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from html.parser import HTMLParser

from kinsync.report.html import internal_references

__all__ = ["p_value_problems", "report_problems"]

_P_IN_TEXT = re.compile(r"(?<![\w.-])p\s*(=|<|>|≤|≥)?\s*(-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)")
_P_CELL = re.compile(r"^(?:< 0\.001|> 0\.99|0\.\d{2,3}|n/a)$")
_P_EQUAL = re.compile(r"^0\.(?:00[1-9]|0[1-9]|[1-9]\d)$")
_EVIDENCE = ("p", "table", "figure")


def _good_p(op: str | None, number: str) -> bool:
    if op == "<":
        return number in ("0.001", "0.01")  # a bound, or a test's level
    if op == ">":
        return number == "0.99"
    if op in ("≤", "≥"):  # a tolerance's limit: p ≤ 0.01
        return re.fullmatch(r"0?\.\d+|[01]", number) is not None
    if op == "=":
        return _P_EQUAL.match(number) is not None
    return False


def p_value_problems(text: str) -> list[str]:
    """Every p-value in ``text`` that is not written ``p < 0.001`` / ``p = 0.04`` style."""
    return [
        m.group(0).strip() for m in _P_IN_TEXT.finditer(text) if not _good_p(m.group(1), m.group(2))
    ]


@dataclass
class _Topic:
    title: str = ""
    first_block: str = ""
    verdict: bool = False


class _Page(HTMLParser):
    """The parts of a page the rules look at, in document order."""

    def __init__(self) -> None:
        super().__init__()
        self.order: list[str] = []
        self.topics: list[_Topic] = []
        self.verdict_cells: list[str] = []
        self.p_cells: list[str] = []
        self.text: list[str] = []
        self._stack: list[tuple[str, str]] = []
        self._headers: list[str] = []
        self._column = -1
        self._in_head = False
        self._in_verdicts = False
        self._cell: list[str] | None = None
        self._topic_depth = -1
        self._in_h2 = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag in ("br", "img", "meta", "hr", "input", "link"):
            return
        cls = dict(attrs).get("class") or ""
        self._stack.append((tag, cls))
        if tag == "section":
            self.order.append(f"section.{cls}")
            if cls == "topic":
                self.topics.append(_Topic())
                self._topic_depth = len(self._stack)
        elif tag == "table":
            self._headers, self._column = [], -1
            self._in_verdicts = "verdicts" in cls.split()
            self.order.append("table.verdicts" if self._in_verdicts else "table")
        elif tag == "thead":
            self._in_head = True
        elif tag == "tr":
            self._column = -1
        elif tag in ("td", "th"):
            self._column += 1
            self._cell = []
        elif tag == "h2":
            self._in_h2 = True
        topic = self.topics[-1] if self.topics and self._topic_depth > 0 else None
        if topic is not None and len(self._stack) == self._topic_depth + 1:
            if tag == "div" and cls.startswith("verdict"):
                topic.verdict = not topic.first_block
                topic.first_block = topic.first_block or "verdict"
            elif tag in _EVIDENCE and not topic.first_block:
                topic.first_block = tag

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            cell = " ".join(self._cell).strip()
            if self._in_head:
                self._headers.append(cell)
            else:
                header = self._headers[self._column] if self._column < len(self._headers) else ""
                if self._in_verdicts and header == "verdict":
                    self.verdict_cells.append(cell)
                if header.lower() == "p-value":
                    self.p_cells.append(cell)
            self._cell = None
        elif tag == "thead":
            self._in_head = False
        elif tag == "table":
            self._in_verdicts = False
        elif tag == "h2":
            self._in_h2 = False
        while self._stack:
            open_tag, _ = self._stack.pop()
            if len(self._stack) < self._topic_depth:
                self._topic_depth = -1
            if open_tag == tag:
                break

    def handle_data(self, data: str) -> None:
        if any(t in ("style", "script") for t, _ in self._stack):
            return
        if self._cell is not None:
            self._cell.append(data)
        if self._in_h2 and self.topics and self._topic_depth > 0 and not self.topics[-1].title:
            self.topics[-1].title = data.strip()
        if data.strip():
            self.text.append(data.strip())


def report_problems(page: str) -> list[str]:
    """Everything that keeps ``page`` from being a judged report; empty when it is one.

    Parameters
    ----------
    page : str
        The HTML of a report (`kinsync.report.html.render_report`).

    Returns
    -------
    list of str
        One sentence per problem, naming the topic or the text at fault.
    """
    parsed = _Page()
    parsed.feed(page)
    parsed.close()
    problems: list[str] = []
    order = parsed.order
    if "table.verdicts" not in order:
        problems.append("no summary table of verdicts")
    elif "section.topic" in order and order.index("table.verdicts") > order.index("section.topic"):
        problems.append("the summary table of verdicts comes after the first topic")
    if not parsed.topics:
        problems.append("no topic sections")
    for topic in parsed.topics:
        if not topic.verdict:
            what = f"opens with a {topic.first_block}" if topic.first_block else "is empty"
            problems.append(f"topic {topic.title!r} has no verdict before its evidence ({what})")
    bad_cells = [c for c in parsed.verdict_cells if c not in ("PASS", "FAIL")]
    if bad_cells:
        problems.append(f"verdict cells other than PASS/FAIL: {bad_cells}")
    if parsed.order.count("table.verdicts") and not parsed.verdict_cells:
        problems.append("the summary table of verdicts is empty")
    sections = [o for o in order if o.startswith("section.")]
    if "section.conclusion" not in sections:
        problems.append("no conclusion")
    elif sections[-1] != "section.conclusion":
        problems.append("the conclusion is not the last section")
    text = "\n".join(parsed.text)
    problems.extend(f"cites an internal document: {r!r}" for r in internal_references(text))
    problems.extend(f"p-value written as {p!r}" for p in p_value_problems(text))
    problems.extend(
        f"p-value cell written as {c!r}" for c in parsed.p_cells if not _P_CELL.match(c)
    )
    return problems
