"""Method B: synchronisation of a profile scanner to a trajectory in object space."""

from __future__ import annotations

from kinsync.sync.object_space import (
    Alternative,
    Crossing,
    MatchedSighting,
    ObjectSpaceConfig,
    ObjectSpaceResult,
    PulseOffset,
    Sighting,
    detect_sightings,
    find_crossings,
    pulse_offset,
    synchronise_object_space,
)

__all__ = [
    "Alternative",
    "Crossing",
    "MatchedSighting",
    "ObjectSpaceConfig",
    "ObjectSpaceResult",
    "PulseOffset",
    "Sighting",
    "detect_sightings",
    "find_crossings",
    "pulse_offset",
    "synchronise_object_space",
]
