"""Where the demo looks for the reference sets: the variable first, never a package's ``..``."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from kinsync.demo import reference_data
from kinsync.demo.method_a import find_cidco_folder
from kinsync.demo.navego import find_navego_folder, navego_candidates
from kinsync.demo.reference_data import REFERENCE_DATA_VARIABLE, reference_candidates


def test_the_variable_names_a_folder_of_sets_searched_first(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "navego-synthetic").mkdir()
    (tmp_path / "navego-synthetic" / "imu_gnss_spec.json").write_text("{}")
    (tmp_path / "cidco-port-de-quebec" / "sphere1").mkdir(parents=True)
    monkeypatch.setenv(REFERENCE_DATA_VARIABLE, str(tmp_path))
    assert navego_candidates()[0] == tmp_path / "navego-synthetic"
    assert find_navego_folder() == tmp_path / "navego-synthetic"
    assert find_cidco_folder() == tmp_path / "cidco-port-de-quebec"


def test_an_installed_package_searches_no_folder_beside_itself(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A wheel's demo searched <venv>/lib/shared/data/..., and the report showed it.
    monkeypatch.delenv(REFERENCE_DATA_VARIABLE, raising=False)
    monkeypatch.chdir(tmp_path)
    root = Path(__file__).resolve().parents[2]
    assert reference_candidates("x") == [
        Path(os.path.normpath(tmp_path / ".." / "shared" / "data" / "x")),
        root.parent / "shared" / "data" / "x",
    ]
    monkeypatch.setattr(reference_data, "_checkout_root", lambda: None)
    assert reference_candidates("x") == [
        Path(os.path.normpath(tmp_path / ".." / "shared" / "data" / "x"))
    ]
