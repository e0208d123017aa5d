"""An interrupted re-run of a simulator leaves the earlier simulation as it was.

Each simulation is written into a hidden folder beside its output and renamed into
place when complete (`kinsync.sim.folder.simulation_folder`): the output folder holds
the complete old simulation or the complete new one, never a mix, and never an empty
or half-written folder that blocks the next run.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import kinsync.sim.clock as clock_module
import kinsync.sim.patch_test as patch_test_module
import kinsync.sim.rotating_table as table_module
from kinsync.sim.clock import ClockSimConfig, simulate_clock, write_clock_simulation
from kinsync.sim.patch_test import PatchTestConfig, simulate_patch_test, write_patch_test
from kinsync.sim.rotating_table import simulate_rotating_table, write_simulation
from kinsync.sim.table_config import RotatingTableConfig


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file below ``folder`` (relative path -> bytes)."""
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _interrupt_after_first(
    monkeypatch: pytest.MonkeyPatch, module: object, name: str
) -> list[Path]:
    """Make ``module.name`` (a writer) write its first file, then raise KeyboardInterrupt."""
    original: Callable[..., Any] = getattr(module, name)
    written: list[Path] = []

    def first_then_interrupt(*args: Any, **kwargs: Any) -> Any:
        original(*args, **kwargs)
        written.append(Path(str(args[1] if len(args) > 1 else kwargs.get("path", ""))))
        raise KeyboardInterrupt

    monkeypatch.setattr(module, name, first_then_interrupt)
    return written


def _check_rerun(
    tmp_path: Path,
    write_old: Callable[[Path], object],
    write_new: Callable[[Path], object],
    monkeypatch: pytest.MonkeyPatch,
    module: object,
    writer: str,
) -> None:
    out = tmp_path / "sim"
    write_old(out)
    before = _snapshot(out)
    with monkeypatch.context() as patch:
        written = _interrupt_after_first(patch, module, writer)
        with pytest.raises(KeyboardInterrupt):
            write_new(out)
        assert written, "the interruption did not happen while writing"
    assert _snapshot(out) == before  # the earlier simulation, byte for byte
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim"]  # no temporary left
    write_new(out)  # the folder is not blocked
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim"]
    fresh = tmp_path / "fresh" / "sim"
    write_new(fresh)
    assert _snapshot(out) == _snapshot(fresh) != before  # the new simulation, and only it


def test_patch_test(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    def config(seed: int) -> PatchTestConfig:
        return PatchTestConfig(density=0.01, passes_per_direction=1, nav_rate_hz=50.0, seed=seed)

    old, new = simulate_patch_test(config(1)), simulate_patch_test(config(2))
    _check_rerun(
        tmp_path,
        lambda out: write_patch_test(old, out),
        lambda out: write_patch_test(new, out),
        monkeypatch,
        patch_test_module,
        "_write_line",
    )


def test_rotating_table_raw(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    def sim(seed: int) -> table_module.RotatingTableSimulation:
        return simulate_rotating_table(RotatingTableConfig(rates_deg_s=(6.0,), passes=1, seed=seed))

    old, new = sim(1), sim(2)
    _check_rerun(
        tmp_path,
        lambda out: write_simulation(old, out, raw=True),
        lambda out: write_simulation(new, out, raw=True),
        monkeypatch,
        table_module,
        "write_numeric_csv",
    )


def test_clock(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    old = simulate_clock(ClockSimConfig(duration_s=30.0, seed=1))
    new = simulate_clock(ClockSimConfig(duration_s=30.0, seed=2))
    _check_rerun(
        tmp_path,
        lambda out: write_clock_simulation(old, out),
        lambda out: write_clock_simulation(new, out),
        monkeypatch,
        clock_module,
        "write_numeric_csv",
    )


def _dead_pid() -> int:
    """The id of a process that has exited."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_temporaries_of_a_killed_run_do_not_block(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    old = simulate_clock(ClockSimConfig(duration_s=30.0, seed=1))
    new = simulate_clock(ClockSimConfig(duration_s=30.0, seed=2))
    out = tmp_path / "sim"
    write_clock_simulation(old, out)
    before = _snapshot(out)
    pid = _dead_pid()
    # killed while writing: a half-written temporary folder beside the output
    part = tmp_path / f".sim.{pid}.abcd1234.part"
    part.mkdir()
    (part / "pps.csv").write_text("t_local_s\n1.0\n")
    write_clock_simulation(new, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim"]
    assert _snapshot(out) != before
    # killed between setting the old folder aside and renaming the new one in: the next
    # run puts it back (here that run is interrupted too, so the folder stays the old one)
    after = _snapshot(out)
    out.rename(tmp_path / f".sim.{pid}.efgh5678.old")
    with monkeypatch.context() as patch:
        _interrupt_after_first(patch, clock_module, "write_numeric_csv")
        with pytest.raises(KeyboardInterrupt):
            write_clock_simulation(old, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim"]
    assert _snapshot(out) == after
