"""Help that says it all: flags without a value type, the latency sign, the boresight
matrix, counted nouns and tables that fit 80 columns when piped."""

from __future__ import annotations

import itertools
import json
import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from tests.cli._commands import commands

from kinsync._text import counted
from kinsync.io.mount_file import read_mount

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py

MOUNT = """[mount]
lever_arm_body_m = [0.1, -0.2, 0.3]
boresight_rpy_deg = [1.5, -30.0, 30.0]
antenna_lever_arm_body_m = [0.0, 0.0, -1.0]
latency_s = 0.004
"""
PLAN = ["latency", "plan", "--range-m", "1.5", "--radius-m", "0.1", "--range-noise-m", "0.002"]


@pytest.mark.parametrize("path", [p for p, _ in commands()], ids=" ".join)
def test_no_flag_is_shown_with_a_value_type(path: tuple[str, ...], run_cli: RunCli) -> None:
    """`--json <bool>` reads as if `--json true` worked; it does not, so no type is shown."""
    code, out, _ = run_cli([*path, "--help"])
    assert code == 0
    assert "<bool>" not in out
    flags = re.findall(r"(--[a-z][a-z0-9-]*)\s+(<\w+>)?", out)
    assert flags, out
    assert ("--json", "") in flags or "--json" not in out


def test_a_flag_given_a_value_is_refused(run_cli: RunCli) -> None:
    code, _, err = run_cli(["budget", "latency", "--json", "true"])
    assert code == 2
    assert "true" in err


def test_latency_help_gives_the_sign(run_cli: RunCli) -> None:
    _, out, _ = run_cli(["georef", "--help"])
    text = " ".join(out.replace("│", " ").split())
    assert "> 0 when the navigation data lag the scanner" in text
    assert "t + latency" in text
    assert "doubles the error" in text


def test_mount_check_prints_the_boresight_matrix(tmp_path: Path, run_cli: RunCli) -> None:
    path = tmp_path / "mount.toml"
    path.write_text(MOUNT)
    code, out, _ = run_cli(["mount", "check", str(path)])
    assert code == 0
    printed = [
        [float(v) for v in re.findall(r"[+-]\d\.\d{6}", line)]
        for line in out.splitlines()
        if len(re.findall(r"[+-]\d\.\d{6}", line)) == 3
    ]
    R = read_mount(path).R_scanner_to_body
    np.testing.assert_allclose(np.array(printed), R, atol=5e-7)
    assert "R_scanner_to_body" in out
    code, out, _ = run_cli(["mount", "check", str(path), "--json"])
    np.testing.assert_allclose(json.loads(out)["R_scanner_to_body"], R, atol=1e-12)


def test_mount_check_prints_the_strongest_correlations(tmp_path: Path, run_cli: RunCli) -> None:
    path = tmp_path / "mount.toml"
    path.write_text(
        MOUNT
        + "\n[uncertainty]\nlever_arm_body_m = [0.02, 0.02, 0.03]\nlatency_s = 0.002\n"
        + "[uncertainty.correlation]\n"
        + 'names = ["lever_x_m", "lever_z_m", "latency_ms"]\n'
        + "matrix = [[1, 0.1, -0.86], [0.1, 1, 0.3], [-0.86, 0.3, 1]]\n"
    )
    code, out, err = run_cli(["mount", "check", str(path)])
    assert code == 0, err
    text = " ".join(out.replace("│", " ").split())
    strongest = "lever_x_m/latency_ms -0.86, lever_z_m/latency_ms +0.30"
    assert f"correlation of the errors {strongest}" in text
    code, out, _ = run_cli(["mount", "check", str(path), "--json"])
    corr = json.loads(out)["uncertainty"]["correlation"]
    assert corr["names"] == ["lever_x_m", "lever_z_m", "latency_ms"]
    assert corr["matrix"][0][2] == -0.86


@pytest.mark.parametrize(
    ("n", "noun", "text"),
    [
        (1, "pass", "1 pass"),
        (2, "pass", "2 passes"),
        (0, "point", "0 points"),
        (1, "line", "1 line"),
        (3, "axis", "3 axes"),
        (2, "datum", "2 data"),
    ],
)
def test_counted_nouns(n: int, noun: str, text: str) -> None:
    plural = "data" if noun == "datum" else None
    assert counted(n, noun, plural) == text


def test_one_pass_is_not_one_passes(run_cli: RunCli) -> None:
    code, out, _ = run_cli([*PLAN, "--rates-deg-s", "6", "--passes", "1"])
    assert code == 0, out
    assert "1 pass each way" in out
    assert "1 passes" not in out


def _piped_commands(tmp_path: Path) -> list[list[str]]:
    mount = tmp_path / "mount.toml"
    mount.write_text(MOUNT)
    return [
        ["budget", "latency", "--latency-ms", "0.1", "--latency-ms", "1", "--latency-ms", "10"],
        ["budget", "serial", "--baud", "9600", "--bytes", "16", "--parity", "even"],
        ["budget", "period", "--profiles", "10000", "--period-error-s", "1e-6", "--speed-m-s", "2"],
        ["mount", "check", str(mount)],
        [*PLAN, "--rates-deg-s", "2,6,18", "--passes", "15", "--target-ms", "0.1"],
    ]


def test_tables_fit_80_columns_when_piped(
    tmp_path: Path, run_cli: RunCli, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Piped output (no terminal, no COLUMNS) is read in 80 columns: no table is wider and no
    header is cut to an ellipsis."""
    monkeypatch.delenv("COLUMNS", raising=False)
    for argv in _piped_commands(tmp_path):
        code, out, err = run_cli(argv)
        assert code == 0, (argv, err)
        table_lines = [line for line in out.splitlines() if line[:1] in "┏┃┡│└"]
        assert table_lines, (argv, out)
        too_wide = [line for line in table_lines if len(line) > 80]
        assert not too_wide, (argv, too_wide)
        assert "…" not in out, (argv, out)


def _click_commands(
    command: Any = None, path: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], Any]]:
    """Every group and command of the program as click sees it, with its argv path."""
    import typer  # noqa: PLC0415

    from kinsync.cli.app import app  # noqa: PLC0415

    command = typer.main.get_command(app) if command is None else command
    yield path, command
    for name, sub in getattr(command, "commands", {}).items():  # a group (typer's own click)
        yield from _click_commands(sub, (*path, name))


def _flat(text: str) -> str:
    """Rendered help without the panels' borders, whitespace collapsed (lines wrap)."""
    return " ".join(re.sub(r"[│╭╮╰╯─┌┐└┘]", " ", text).split())


@pytest.mark.parametrize(
    ("path", "command"),
    list(_click_commands()),
    ids=lambda x: " ".join(x) if isinstance(x, tuple) else "",
)
def test_bracketed_help_text_is_shown_not_eaten_as_markup(
    path: tuple[str, ...], command: Any, run_cli: RunCli
) -> None:
    """Rich markup ate "[xyz]" and "[profiler]": ``ins run --help`` showed
    "gyro__rad_s", ``sync apply --help`` "Mount TOML with a  azimuth_deg"."""
    code, out, _ = run_cli([*path, "--help"])
    assert code == 0
    sources = [command.help or ""] + [getattr(p, "help", None) or "" for p in command.params]
    shown = _flat(out)
    for source in sources:
        for bracketed in re.findall(r"\[[^\[\]]*\]", source):
            assert _flat(bracketed) in shown, (bracketed, out)


def test_help_fix_is_skipped_on_a_typer_without_display_type_rich() -> None:
    """typer 0.21-0.28 (within the declared typer>=0.21) has no ``display_type_rich``:
    the CLI must start there (it failed with AttributeError on every command). The
    installed typer is made to lack it in a fresh interpreter, so that no other test
    sees the class changed; that typer cannot render help without it, so only the
    start-up is checked (with typer 0.21.0 and 0.27.2 installed, this file's tests
    and test_cli_main.py passed)."""
    code = (
        "from typer.core import TyperOption\n"
        "for cls in TyperOption.__mro__:\n"
        "    if 'display_type_rich' in vars(cls):\n"
        "        delattr(cls, 'display_type_rich')\n"
        "import kinsync.cli.app\n"
        "from kinsync.cli._help import install_flag_display\n"
        "install_flag_display()\n"
        "assert not hasattr(TyperOption, 'display_type_rich')\n"
        "print('started')\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == "started\n"


@pytest.mark.parametrize("path", [p for p, _ in commands()], ids=" ".join)
def test_help_has_no_rst_markup(path: tuple[str, ...], run_cli: RunCli) -> None:
    """trajectory info's help showed ``warnings``, a docstring's RST, to the user."""
    code, out, _ = run_cli([*path, "--help"])
    assert code == 0
    assert "``" not in out


def test_help_paragraphs_are_not_broken_mid_sentence(run_cli: RunCli) -> None:
    """typer kept the docstrings' line ends after the first paragraph, and rich wrapped
    again at 80 columns: `demo --help` showed "... by name" / "and the" on lines of
    their own."""
    for path, _ in commands():
        code, out, _ = run_cli([*path, "--help"])
        assert code == 0
        prose = out.split("╭")[0]  # the text above the option panels
        lines = [line.strip() for line in prose.splitlines()]
        for line, following in itertools.pairwise(lines):
            # a line rich did not fill while the paragraph goes on: a kept line end
            broken = line and following and len(line) < 50 and not line.startswith("Usage")
            assert not broken, (path, line, following)
