"""Method B: synchronisation of a profile scanner to a trajectory in object space.

The whole method is described in `kinsync.sync.object_space`; its steps live in
`kinsync.sync.crossings` (geometric time), `kinsync.sync.sightings` (scanner time),
`kinsync.sync.clock_line` (matching and regression) and `kinsync.sync.pulses`
(counting faults); `kinsync.sync.scan` holds the scan and sync-point containers and
`kinsync.clock.profile` the profile clock the method estimates.

The names below load their modules on first use (`kinsync._lazy`): the ``kinsync``
program reads the spans of `kinsync.sync.config` at start-up without loading the
method (scipy.optimize).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from kinsync._lazy import lazy_exports

if TYPE_CHECKING:
    from kinsync.sync.config import ObjectSpaceConfig
    from kinsync.sync.crossings import (
        Crossing,
        CrossingSearch,
        GapCrossing,
        find_crossings,
        require_profiler_azimuth,
        search_crossings,
    )
    from kinsync.sync.object_space import (
        Alternative,
        MatchedSighting,
        ObjectSpaceResult,
        synchronise_object_space,
    )
    from kinsync.sync.pulses import PulseOffset, pulse_offset
    from kinsync.sync.scan import ProfileScan, SyncPoints
    from kinsync.sync.sightings import Sighting, detect_sightings

__all__ = [
    "Alternative",
    "Crossing",
    "CrossingSearch",
    "GapCrossing",
    "MatchedSighting",
    "ObjectSpaceConfig",
    "ObjectSpaceResult",
    "ProfileScan",
    "PulseOffset",
    "Sighting",
    "SyncPoints",
    "detect_sightings",
    "find_crossings",
    "pulse_offset",
    "require_profiler_azimuth",
    "search_crossings",
    "synchronise_object_space",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "ObjectSpaceConfig": "kinsync.sync.config",
        "Crossing": "kinsync.sync.crossings",
        "CrossingSearch": "kinsync.sync.crossings",
        "GapCrossing": "kinsync.sync.crossings",
        "find_crossings": "kinsync.sync.crossings",
        "require_profiler_azimuth": "kinsync.sync.crossings",
        "search_crossings": "kinsync.sync.crossings",
        "Alternative": "kinsync.sync.object_space",
        "MatchedSighting": "kinsync.sync.object_space",
        "ObjectSpaceResult": "kinsync.sync.object_space",
        "synchronise_object_space": "kinsync.sync.object_space",
        "PulseOffset": "kinsync.sync.pulses",
        "pulse_offset": "kinsync.sync.pulses",
        "ProfileScan": "kinsync.sync.scan",
        "SyncPoints": "kinsync.sync.scan",
        "Sighting": "kinsync.sync.sightings",
        "detect_sightings": "kinsync.sync.sightings",
    },
)
