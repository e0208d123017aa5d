"""One simulation per folder: a simulator refuses a folder that holds another simulation.

Every simulator writes a ``truth.json``; two simulations in one folder (``simulate drive``
then ``simulate drive-scan --out`` the same folder) would leave one's data beside the
other's truth, and ``truth.json`` would describe only the last. Each simulation is known by
a file only it writes.

A simulation is written as one whole (`simulation_folder`, through
`kinsync.io.atomic.atomic_folder`): into a hidden temporary folder beside the output, then
renamed into place, so that an interrupted run leaves the earlier simulation untouched.
The output folder must be missing, empty, or hold an earlier simulation of the same
simulator and nothing else (it is replaced as a whole).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path

from kinsync._text import first_few
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_folder

__all__ = [
    "SIMULATION_FILES",
    "SIMULATION_SIGNATURES",
    "check_simulation_folder",
    "simulation_folder",
    "simulation_in",
]

SIMULATION_SIGNATURES: dict[str, str] = {
    "rotating-table": "passes.csv",
    "clock": "pps.csv",
    "drive": "imu.csv",
    "drive-scan": "scan.csv",
    "patch-test": "trajectory.out",
    "validation": "control.csv",
}
"""For each simulator (``kinsync simulate NAME``), a file that only it writes."""

SIMULATION_FILES: dict[str, re.Pattern[str]] = {
    name: re.compile(rf"truth\.json|{files}")
    for name, files in {
        "rotating-table": r"passes\.csv|pass_\d+\.(csv|las|laz)"
        r"|raw(/(pass_\d+\.csv|attitude\.csv|mount\.toml))?",
        "clock": r"pps\.csv|nmea\.csv",
        "drive": r"imu\.csv|gnss\.csv|truth\.csv|ins\.toml",
        "drive-scan": r"scan\.csv|trajectory\.csv|mount\.toml|sync_points\.csv"
        r"|control_points\.csv|pulses\.csv",
        "patch-test": r"trajectory\.out|mount\.toml|line_\d+\.(laz|las)",
        "validation": r"(targets|wall)_(scan|trajectory)\.csv|control\.csv|wall_box\.txt"
        r"|mount\.toml",
    }.items()
}
"""For each simulator, the paths (relative, ``/``-separated) of the files it writes."""


def simulation_in(folder: Path) -> str | None:
    """The simulation a folder holds (``"drive"``), or None.

    Parameters
    ----------
    folder : Path
        A folder, existing or not.

    Returns
    -------
    str or None
        The simulator's name when ``folder/truth.json`` and that simulator's own file are
        both there; None otherwise.
    """
    folder = Path(folder)
    if not (folder / "truth.json").is_file():
        return None
    for name, signature in SIMULATION_SIGNATURES.items():
        if (folder / signature).is_file():
            return name
    return None


def check_simulation_folder(folder: Path, simulation: str, option: str = "--out") -> None:
    """Refuse to write simulation ``simulation`` into a folder holding another one.

    Parameters
    ----------
    folder : Path
        The output folder.
    simulation : str
        The simulator about to write (a key of `SIMULATION_SIGNATURES`).
    option : str
        The option naming the folder, for the message.

    Raises
    ------
    InputError
        The folder holds the output of another simulator (writing the same simulator
        again, e.g. with another seed, is allowed: it replaces its own files).
    """
    found = simulation_in(folder)
    if found is not None and found != simulation:
        msg = (
            f"{option} {folder}: holds a `kinsync simulate {found}` simulation "
            f"({SIMULATION_SIGNATURES[found]}, truth.json); `simulate {simulation}` would "
            "overwrite its truth.json; give another folder"
        )
        raise InputError(msg)
    if not folder.is_dir():
        return
    entries = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))
    if not entries:
        return
    own = SIMULATION_FILES[simulation]
    foreign = entries if found is None else [e for e in entries if not own.fullmatch(e)]
    if foreign:
        what = "other files" if found is None else f"a `simulate {found}` and other files"
        msg = (
            f"{option} {folder}: the folder holds {what} ({first_few(foreign)}); give a new or "
            "empty folder (or one holding "
            f"only an earlier `simulate {simulation}`, which is replaced)"
        )
        raise InputError(msg)


@contextmanager
def simulation_folder(out_dir: Path, simulation: str, option: str = "--out") -> Iterator[Path]:
    """Write simulation ``simulation`` as one whole: yield the folder to write into.

    The files go to a hidden temporary folder beside ``out_dir``, renamed to ``out_dir``
    when the block ends without an error (an earlier simulation there is replaced as a
    whole); on any error or interruption ``out_dir`` is left as it was.

    Raises
    ------
    InputError
        ``out_dir`` is a file, or holds anything but an earlier simulation of the same
        simulator (`check_simulation_folder`).
    """
    check = partial(check_simulation_folder, simulation=simulation, option=option)
    with atomic_folder(out_dir, check, "give a folder for the simulation", option=option) as tmp:
        yield tmp
