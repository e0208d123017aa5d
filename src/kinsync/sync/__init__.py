"""Method B: synchronisation of a profile scanner to a trajectory in object space.

The whole method is described in `kinsync.sync.object_space`; its steps live in
`kinsync.sync.crossings` (geometric time), `kinsync.sync.sightings` (scanner time),
`kinsync.sync.clock_line` (matching and regression) and `kinsync.sync.pulses`
(counting faults); `kinsync.sync.scan` holds the scan and sync-point containers and
`kinsync.clock.profile` the profile clock the method estimates.
"""

from __future__ import annotations

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
