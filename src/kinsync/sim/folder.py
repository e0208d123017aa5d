"""One simulation per folder: a simulator refuses a folder that holds another simulation.

Every simulator writes a ``truth.json``; two simulations in one folder (``simulate drive``
then ``simulate drive-scan --out`` the same folder) would leave one's data beside the
other's truth, and ``truth.json`` would describe only the last. Each simulation is known by
a file only it writes.
"""

from __future__ import annotations

from pathlib import Path

from kinsync.errors import InputError

__all__ = ["SIMULATION_SIGNATURES", "check_simulation_folder", "simulation_in"]

SIMULATION_SIGNATURES: dict[str, str] = {
    "rotating-table": "passes.csv",
    "clock": "pps.csv",
    "drive": "imu.csv",
    "drive-scan": "scan.csv",
    "patch-test": "trajectory.out",
    "validation": "control.csv",
}
"""For each simulator (``kinsync simulate NAME``), a file that only it writes."""


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
