"""Start-up cost of the ``kinsync`` program: which modules a bare start and a command load.

Every run of ``kinsync`` pays for what ``import kinsync.cli`` loads, so the command
modules import their heavy library modules (matplotlib, scipy.stats, the INS, the
simulators, ...) inside the commands. Each check runs in a fresh interpreter, where
nothing has been imported yet, and reads ``sys.modules`` afterwards.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kinsync.io.mount_file import write_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

# Loaded by no bare start of the program (a module, or any of its submodules).
NOT_AT_START = (
    "matplotlib",
    "scipy.stats",
    "scipy.optimize",
    "kinsync.demo",
    "kinsync.ins.filter",
    "kinsync.ins.smoother",
    "kinsync.ins.forward_run",
    "kinsync.ins.gnss_observation",
    "kinsync.ins.alignment",
    "kinsync.sim.drive",
    "kinsync.sync.object_space",
    "kinsync.validation",
    "kinsync.georef",
    "kinsync.pipelines",
    "kinsync.latency",
    "dask",
)
# Loaded by ``kinsync georef``: it needs none of these.
NOT_FOR_GEOREF = (
    "matplotlib",
    "scipy.stats",
    "kinsync.ins",
    "kinsync.report",
    "kinsync.demo",
    "kinsync.sim",
)

# Runs ``kinsync ARGS...`` (argv[2:]) and writes its exit code and sys.modules to argv[1].
_RUN_MAIN = """
import json, sys
from kinsync.cli import main
code = None
try:
    main(sys.argv[2:])
except SystemExit as exc:
    code = exc.code
with open(sys.argv[1], "w", encoding="utf-8") as f:
    json.dump({"code": code, "modules": sorted(sys.modules)}, f)
"""

T0 = 1.3e9  # GPS seconds
N_POINTS = 50


def _loaded(modules: list[str], names: tuple[str, ...]) -> list[str]:
    """The entries of ``modules`` that are one of ``names`` or a submodule of one."""
    return [m for m in modules if any(m == n or m.startswith(n + ".") for n in names)]


def _fresh(code: str, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )


def _run_main(tmp_path: Path, *argv: str) -> tuple[int | None, list[str], str]:
    """Run ``kinsync ARGV`` in a fresh interpreter: exit code, modules loaded, stdout."""
    result_path = tmp_path / "modules.json"
    proc = _fresh(_RUN_MAIN, str(result_path), *argv, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(result_path.read_text(encoding="utf-8"))
    return doc["code"], doc["modules"], proc.stdout


def test_selftest_detects_a_loaded_module() -> None:
    modules = ["numpy", "scipy.stats._stats_py", "kinsync.ins", "kinsync.insight", "dask"]
    assert _loaded(modules, ("scipy.stats", "kinsync.ins", "dask")) == [
        "scipy.stats._stats_py",
        "kinsync.ins",
        "dask",
    ]
    assert _loaded(modules, ("matplotlib", "scipy.optimize")) == []


def test_import_cli_loads_no_heavy_module(tmp_path: Path) -> None:
    proc = _fresh(
        "import json, sys, kinsync.cli.app; print(json.dumps(sorted(sys.modules)))", cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    modules = json.loads(proc.stdout)
    assert "kinsync.cli.app" in modules  # every command module was imported
    assert _loaded(modules, NOT_AT_START) == []


def test_import_kinsync_cli_loads_nothing_before_main(tmp_path: Path) -> None:
    # The entry point's own import is light: main() sets the Ctrl-C handling before it
    # imports numpy and the commands (tests/cli/test_interruption.py).
    proc = _fresh(
        "import json, sys, kinsync.cli; print(json.dumps(sorted(sys.modules)))", cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    modules = json.loads(proc.stdout)
    assert "numpy" not in modules
    assert "kinsync.cli.app" not in modules
    assert "typer" not in modules


def test_the_package_names_and_submodules_load_when_used() -> None:
    import kinsync  # noqa: PLC0415

    assert kinsync.Mount.__name__ == "Mount"
    assert kinsync.trajectory.__name__ == "kinsync.trajectory"  # a submodule, as before
    assert {"Mount", "Trajectory", "InputError", "KinsyncError"} <= set(dir(kinsync))
    with pytest.raises(AttributeError, match="no attribute 'nosuch'"):
        _ = kinsync.nosuch


def test_help_loads_no_heavy_module(tmp_path: Path) -> None:
    code, modules, stdout = _run_main(tmp_path, "--help")
    assert code == 0
    for group in ("georef", "latency", "ins", "simulate", "sync", "validate", "demo"):
        assert group in stdout
    assert _loaded(modules, NOT_AT_START) == []


def test_budget_command_loads_no_heavy_module(tmp_path: Path) -> None:
    code, modules, stdout = _run_main(tmp_path, "budget", "latency", "--json")
    assert code == 0
    assert json.loads(stdout)["rows"]
    assert _loaded(modules, NOT_AT_START) == []


@pytest.fixture
def georef_inputs(tmp_path: Path) -> dict[str, Path]:
    """A 1 s trajectory CSV, a mount TOML and a few scanner-frame points inside its span."""
    t = T0 + np.arange(0.0, 1.0 + 1e-9, 0.01)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    traj = Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(s), 0.3 + 0.05 * s, lat_lon_h=llh
    )
    write_trajectory_csv(traj, tmp_path / "traj.csv")
    write_mount(
        Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0)),
        tmp_path / "mount.toml",
    )
    rng = np.random.default_rng(5)
    with TableChunkWriter(tmp_path / "points.csv") as w:
        w.write(
            {
                "t_s": T0 + np.sort(rng.uniform(0.1, 0.9, N_POINTS)),
                "x_m": rng.uniform(-1.0, 1.0, N_POINTS),
                "y_m": rng.uniform(-20.0, 20.0, N_POINTS),
                "z_m": rng.uniform(-5.0, 5.0, N_POINTS),
            }
        )
    return {
        "traj": tmp_path / "traj.csv",
        "mount": tmp_path / "mount.toml",
        "points": tmp_path / "points.csv",
        "out": tmp_path / "out.csv",
    }


def test_georef_loads_only_what_it_needs(tmp_path: Path, georef_inputs: dict[str, Path]) -> None:
    p = georef_inputs
    code, modules, stdout = _run_main(
        tmp_path,
        "georef",
        "--points",
        str(p["points"]),
        "--trajectory",
        str(p["traj"]),
        "--mount",
        str(p["mount"]),
        "--out",
        str(p["out"]),
        "--json",
    )
    assert code == 0
    doc = json.loads(stdout)
    assert doc["points_in"] == doc["points_out"] == N_POINTS
    assert len(p["out"].read_text(encoding="utf-8").splitlines()) == N_POINTS + 1  # + header
    assert "kinsync.pipelines.georef" in modules  # the command ran its pipeline here
    assert _loaded(modules, NOT_FOR_GEOREF) == []
