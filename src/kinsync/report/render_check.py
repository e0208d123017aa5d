"""Check that a report page renders in a real browser (headless Chromium).

The demo report must open offline in a browser. This loads the page from disk in
headless Chromium with the network disabled, lets a tiny probe script count the
embedded figures that decoded (``naturalWidth > 0``) and the topics that open with a
verdict, reads the probe's answer from the rendered DOM, looks through the rendered
text for citations of internal documents (``SPEC section 3``, which no reader has),
and optionally takes a screenshot.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from kinsync.errors import InputError, KinsyncError
from kinsync.report.html import internal_references

__all__ = ["RenderCheck", "check_renders", "find_chromium"]

_CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
_PROBE = """
<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var h = document.querySelectorAll('h2').length;
  var t = document.querySelectorAll('table').length;
  var topics = Array.prototype.slice.call(document.querySelectorAll('section.topic'));
  var judged = topics.filter(function (s) { return s.querySelector('.verdict'); }).length;
  var failed = document.querySelectorAll('.verdict li .badge.fail').length;
  document.body.setAttribute('data-render-probe', [imgs.length, ok, h, t, topics.length,
                                                   judged, failed].join(','));
});
</script>
"""
_VERDICT = re.compile(r'data-render-probe="(\d+),(\d+),(\d+),(\d+),(\d+),(\d+),(\d+)"')
_TAG = re.compile(r"<(script|style)\b.*?</\1>|<[^>]*>", flags=re.DOTALL | re.IGNORECASE)


@dataclass(frozen=True)
class RenderCheck:
    """What the browser saw.

    Attributes
    ----------
    browser : str
        Path of the browser used.
    n_images, n_images_decoded : int
        Embedded figures in the page, and how many the browser decoded.
    n_sections, n_tables : int
        ``<h2>`` sections and tables in the rendered DOM.
    n_topics, n_topics_judged : int
        Topic sections, and those that open with a verdict.
    n_failed_checks : int
        Checks shown as failed in the topics' verdicts.
    internal_references : tuple of str
        Citations of internal documents in the rendered text (should be none).
    title : str
        The page title as rendered.
    screenshot : Path or None
        Screenshot written, when asked for.
    """

    browser: str
    n_images: int
    n_images_decoded: int
    n_sections: int
    n_tables: int
    n_topics: int
    n_topics_judged: int
    n_failed_checks: int
    internal_references: tuple[str, ...]
    title: str
    screenshot: Path | None

    @property
    def ok(self) -> bool:
        """Every figure decoded, the page has a section, and it cites no internal document."""
        return (
            self.n_images == self.n_images_decoded
            and self.n_sections > 0
            and not self.internal_references
        )

    @property
    def every_topic_judged(self) -> bool:
        """The page has topics and each opens with a verdict."""
        return self.n_topics > 0 and self.n_topics_judged == self.n_topics


def find_chromium() -> str | None:
    """Path of a Chromium/Chrome executable on ``PATH``, or None."""
    for name in _CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return None


def _run(browser: str, args: list[str], timeout_s: float) -> subprocess.CompletedProcess[str]:
    base = [
        browser,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        "--proxy-server=127.0.0.1:9",  # network off: the page must be self-contained
        "--virtual-time-budget=5000",
    ]
    try:
        return subprocess.run(  # noqa: S603 - fixed browser path, our own arguments
            base + args, capture_output=True, text=True, timeout=timeout_s, check=False
        )
    except subprocess.TimeoutExpired as err:
        msg = f"{browser} did not finish rendering within {timeout_s:g} s"
        raise KinsyncError(msg) from err


def check_renders(
    html_path: Path,
    *,
    screenshot: Path | None = None,
    browser: str | None = None,
    timeout_s: float = 120.0,
) -> RenderCheck:
    """Render ``html_path`` in headless Chromium and report what decoded.

    Parameters
    ----------
    html_path : Path
        The report page (self-contained HTML).
    screenshot : Path, optional
        Where to write a PNG screenshot (1280 px wide, full first screen).
    browser : str, optional
        Browser executable; default: the first Chromium/Chrome on ``PATH``.
    timeout_s : float
        Limit for each browser run.

    Raises
    ------
    InputError
        The page does not exist, or no browser is installed.
    KinsyncError
        The browser failed or its output holds no verdict.
    """
    if not html_path.is_file():
        msg = f"{html_path}: no such report page"
        raise InputError(msg)
    exe = browser or find_chromium()
    if exe is None:
        msg = "no Chromium/Chrome found on PATH; install chromium to check the report renders"
        raise InputError(msg)
    page = html_path.read_text(encoding="utf-8")
    probed = page.replace("</body>", _PROBE + "</body>") if "</body>" in page else page + _PROBE
    with tempfile.TemporaryDirectory(prefix="kinsync-render-") as tmp:
        probe_path = Path(tmp) / "page.html"
        probe_path.write_text(probed, encoding="utf-8")
        profile = Path(tmp) / "profile"
        common = [f"--user-data-dir={profile}"]
        proc = _run(exe, [*common, "--dump-dom", probe_path.as_uri()], timeout_s)
        match = _VERDICT.search(proc.stdout)
        if match is None:
            tail = (proc.stderr or "").strip().splitlines()[-1:] or ["no output"]
            msg = (
                f"{exe} rendered {html_path} without a verdict (exit {proc.returncode}): {tail[0]}"
            )
            raise KinsyncError(msg)
        title_m = re.search(r"<title>(.*?)</title>", proc.stdout, flags=re.DOTALL)
        shot: Path | None = None
        if screenshot is not None:
            screenshot.parent.mkdir(parents=True, exist_ok=True)
            _run(
                exe,
                [
                    *common,
                    f"--screenshot={screenshot}",
                    "--window-size=1280,1600",
                    html_path.as_uri(),
                ],
                timeout_s,
            )
            shot = screenshot if screenshot.is_file() else None
    n_img, n_ok, n_h2, n_tab, n_topics, n_judged, n_failed = (int(g) for g in match.groups())
    text = _TAG.sub(" ", proc.stdout)
    return RenderCheck(
        browser=exe,
        n_images=n_img,
        n_images_decoded=n_ok,
        n_sections=n_h2,
        n_tables=n_tab,
        n_topics=n_topics,
        n_topics_judged=n_judged,
        n_failed_checks=n_failed,
        internal_references=tuple(internal_references(text)),
        title=(title_m.group(1).strip() if title_m else ""),
        screenshot=shot,
    )
