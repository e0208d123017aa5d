"""A mount built in Python is warned of a latency in milliseconds, as a mount file is."""

from __future__ import annotations

import dataclasses
import warnings

import pytest

from kinsync.calibration.parameters import mount_from_values, mount_values
from kinsync.errors import KinsyncWarning
from kinsync.mount import Mount, mount_from_toml_text
from kinsync.mount_slips import WARN_LATENCY_S, derived_mounts

SLIP_5_S = (
    "latency_s = 5.0 s is beyond +-1 s, longer than any sensor or serial delay: latency_s "
    "is in seconds (5.0 ms would be 0.005)"
)


def test_a_latency_in_milliseconds_built_in_python_is_warned_of() -> None:
    """Mount(latency_s=5) (5 ms meant) was taken as 5 s without a word; the file was not."""
    with pytest.warns(KinsyncWarning) as caught:
        mount = Mount(latency_s=5)
    assert [str(w.message) for w in caught] == [f"mount {SLIP_5_S}"]
    assert caught[0].filename == __file__  # the caller's line, not kinsync's
    assert mount.latency_s == 5.0
    with pytest.warns(KinsyncWarning, match=r"^mount latency_s = -1\.5 s is beyond \+-1 s"):
        Mount().with_latency(-1.5)


def test_a_usual_latency_is_not_warned_of() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Mount(latency_s=WARN_LATENCY_S)
        Mount(latency_s=-0.999)


def test_a_mount_file_is_warned_of_once_naming_the_file() -> None:
    with pytest.warns(KinsyncWarning) as caught:
        mount_from_toml_text("[mount]\nlatency_s = 5\n", source="cal/mount.toml")
    assert [str(w.message) for w in caught] == [f"cal/mount.toml: [mount] {SLIP_5_S}"]


def test_mounts_made_from_a_mount_are_not_warned_of_again() -> None:
    """Sync's mount effect and a calibration move the values of the mount they were given:
    each moved mount would repeat the warning the mount was given."""
    with derived_mounts():
        mount = Mount(latency_s=5.0)
    values = mount_values(mount)
    values[6] += 0.001  # s
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        moved = mount_from_values(mount, values)
        turned = mount.with_profiler_azimuth(90.0)  # kinsync georef of a profile file
    assert moved.latency_s == pytest.approx(5.001)
    with pytest.warns(KinsyncWarning):  # derived_mounts ended: warned of again
        dataclasses.replace(mount, lever_arm_body_m=(0.0, 0.0, 1.0))
    assert (turned.profiler_azimuth_deg, turned.latency_s) == (90.0, 5.0)
