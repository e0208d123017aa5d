"""The README runs: every shell and Python block, in order, in a fresh folder.

A new user copies the README's blocks into a terminal from the checkout, one after the
other; this test does the same in a temporary folder laid out like a checkout (``configs``
beside it, ``../shared`` above it when the reference data are there). A block is left out
only behind a ``<!-- readme-test: skip (reason) -->`` line, for the two that run the
whole demo or the test suite itself. Usage synopses (``[--option]``) are ``text`` blocks.
A result a shell block shows in a comment as ``value ± sigma`` (``# latency 4.2689 ±
0.0407 ms``) must be printed, as written, by that block.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from kinsync.sim.profiler import DRIVE_SCAN_FILES

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SHARED = ROOT.parent / "shared"
SKIP = re.compile(r"<!-- readme-test: skip \((?P<reason>[^)]+)\) -->")
FENCE = re.compile(r"^```(?P<info>[\w-]*)\s*$")
RUNNABLE = ("sh", "python")
TIMEOUT_S = 600
SHOWN = re.compile(r"-?\d+(?:\.\d+)? ± \d+(?:\.\d+)?")


@dataclass(frozen=True)
class Block:
    """A fenced block of the README."""

    line: int
    info: str
    code: str
    skip_reason: str | None


def readme_blocks(text: str) -> list[Block]:
    """Every fenced block, with its language and the skip marker on the line above."""
    lines = text.splitlines()
    blocks: list[Block] = []
    i = 0
    while i < len(lines):
        start = FENCE.match(lines[i])
        if start is None:
            i += 1
            continue
        end = i + 1
        while end < len(lines) and lines[end].rstrip() != "```":
            end += 1
        assert end < len(lines), f"README line {i + 1}: the block is never closed"
        above = lines[i - 1] if i else ""
        marker = SKIP.fullmatch(above.strip())
        if "readme-test" in above and marker is None:
            pytest.fail(f"README line {i}: a skip marker needs a reason: {above!r}")
        blocks.append(
            Block(i + 1, start["info"], "\n".join(lines[i + 1 : end]) + "\n",
                  marker["reason"] if marker else None)
        )  # fmt: skip
        i = end + 1
    return blocks


def shown_results(code: str) -> list[str]:
    """The ``value ± sigma`` pairs a shell block's comments show as its output."""
    return [
        m for line in code.splitlines() if "#" in line for m in SHOWN.findall(line.split("#", 1)[1])
    ]


def test_shown_results_are_taken_from_comments_only() -> None:
    code = (
        "kinsync latency sphere table   # latency 4.2689 ± 0.0407 ms\n"
        "# drift 24.999815 ± 0.000225 ppm; time error (ms)  -2.009 ± 0.043\n"
        "echo '1.0 ± 2.0'\n"
    )
    assert shown_results(code) == ["4.2689 ± 0.0407", "24.999815 ± 0.000225", "-2.009 ± 0.043"]


def test_the_parser_finds_blocks_and_markers() -> None:
    text = (
        "x\n```sh\necho a\n```\n<!-- readme-test: skip (slow) -->\n```python\nprint(1)\n```\n"
        "```text\nusage: kinsync [--x]\n```\n"
    )
    blocks = readme_blocks(text)
    assert [(b.info, b.skip_reason) for b in blocks] == [
        ("sh", None), ("python", "slow"), ("text", None)
    ]  # fmt: skip
    assert blocks[0].code == "echo a\n"


def test_the_drive_scan_line_lists_every_file_it_writes() -> None:
    """The comment of ``simulate drive-scan`` listed all but ``control_points.csv``."""
    lines = [
        line
        for line in README.read_text(encoding="utf-8").splitlines()
        if line.startswith("kinsync simulate drive-scan ") and "#" in line
    ]
    assert lines
    for line in lines:
        listed = [name.strip() for name in line.split("#", 1)[1].split(",")]
        assert listed == list(DRIVE_SCAN_FILES), line


def test_only_whole_runs_are_skipped_and_synopses_are_not_shell() -> None:
    blocks = readme_blocks(README.read_text(encoding="utf-8"))
    skipped = [b for b in blocks if b.skip_reason]
    assert len(skipped) <= 2, [b.line for b in skipped]
    for block in blocks:
        if block.info == "sh":
            assert "[--" not in block.code, (
                f"README line {block.line}: an optional [--option] in a shell block does not "
                "run; write the usage in a text block"
            )
        assert block.info in (*RUNNABLE, "text", "toml", ""), (block.line, block.info)
        if block.info == "":
            assert "kinsync " not in block.code, f"README line {block.line}: say sh or text"


def _workspace(tmp_path: Path) -> Path:
    """A folder laid out like the checkout: configs beside it, ../shared above it."""
    work = tmp_path / "kinsync"
    work.mkdir()
    (work / "configs").symlink_to(ROOT / "configs", target_is_directory=True)
    if SHARED.is_dir():
        (tmp_path / "shared").symlink_to(SHARED, target_is_directory=True)
    return work


def _run(block: Block, work: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    if block.info == "sh":
        argv = ["bash", "-e", "-o", "pipefail", "-c", block.code]
    else:
        argv = [sys.executable, "-c", block.code]
    return subprocess.run(
        argv, cwd=work, env=env, capture_output=True, text=True, timeout=TIMEOUT_S, check=False
    )


@pytest.mark.slow
def test_every_readme_block_runs_in_order(tmp_path: Path) -> None:
    blocks = [b for b in readme_blocks(README.read_text(encoding="utf-8")) if b.info in RUNNABLE]
    assert len(blocks) >= 15
    work = _workspace(tmp_path)
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.pop("KINSYNC_DEBUG", None)
    ran = 0
    for block in blocks:
        if block.skip_reason is not None:
            continue
        if "../shared" in block.code and not SHARED.is_dir():
            continue  # the reference data are not beside this checkout
        result = _run(block, work, env)
        assert result.returncode == 0, (
            f"README line {block.line} ({block.info}) exited {result.returncode}:\n"
            f"{block.code}\n--- stderr ---\n{result.stderr[-3000:]}"
            f"\n--- stdout ---\n{result.stdout[-2000:]}"
        )
        assert "Traceback" not in result.stderr, (block.line, result.stderr[-3000:])
        if block.info == "sh":
            for shown in shown_results(block.code):
                assert shown in result.stdout, (
                    f"README line {block.line}: the block shows {shown!r} in a comment, the "
                    f"command printed:\n{result.stdout[-3000:]}"
                )
        ran += 1
    assert ran >= 15
