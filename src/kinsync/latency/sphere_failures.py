"""Why no sphere was found in a pool of passes, in the latency command's words.

`pool_failure` turns the sphere fitter's message (written for a Python caller) into
the latency command's terms, with what to check: the sphere in view, the frame, the
radius, a region of interest, the unit of the points.
"""

from __future__ import annotations

from kinsync.errors import ConvergenceError, InputError
from kinsync.latency.roi import ROI_OPTION

__all__ = ["pool_failure"]

_FIT_PHRASES = (
    # The sphere fitter's messages speak to a Python caller (its function and parameter
    # names); a pool that fails is reported in the terms of the latency command.
    ("segment_sphere: ", ""),
    ("fit_sphere: ", ""),
    ("; raise max_iterations or check the points", ""),
    ("; raise max_iterations or fit without origin_m", ""),
    (
        (
            "origin_m lies inside the fitted sphere; the ray model needs the scanner outside "
            "the target (check origin_m and its frame)"
        ),
        (
            "the fitted sphere encloses the scanner at the table centre (the origin of the "
            "table-centred frame)"
        ),
    ),
    (
        ("origin_m does not look like the scanner that saw these points (check it and its frame)"),
        (
            "they do not look as seen from the table centre: the points must be in the "
            "table frame, centred on the table axis where the scanner sits (vessel survey "
            "passes are not rotating-table passes)"
        ),
    ),
    ("face origin_m", "face the table centre"),
    ("seen from origin_m", "seen from the table centre"),
)

_MAX_SPREAD_TO_RADIUS = 200.0
"""A cloud spreading more than this many sphere radii hints at points not in metres."""


def _unit_hint(spread_m: float, radius_m: float | None) -> str:
    """A hint at millimetres or feet when the cloud is far larger than the sphere."""
    if radius_m is None or spread_m <= _MAX_SPREAD_TO_RADIUS * radius_m:
        return ""
    return (
        f"; the points spread {spread_m:.3g} m, {spread_m / radius_m:.0f} times the sphere's "
        f"radius {radius_m:g} m: are they in millimetres or feet? pass files are in metres"
    )


def pool_failure(
    err: InputError | ConvergenceError,
    radius_m: float | None,
    spread_m: float = 0.0,
    *,
    roi_given: bool = False,
) -> str:
    """Why no sphere was found in a pool, in the latency command's terms, with what to do."""
    text = str(err)
    for phrase, plain in _FIT_PHRASES:
        text = text.replace(phrase, plain)
    roi_advice = (
        f"check that the region of interest (roi_ned_m, {ROI_OPTION}) holds the sphere"
        if roi_given
        else f"give a region of interest around the sphere (roi_ned_m, {ROI_OPTION}) to leave out "
        "floor and walls"
    )
    text = text.replace("check the radius or the region of interest", roi_advice)
    text += _unit_hint(spread_m, radius_m)
    radius = (
        f"that the sphere radius (radius_m, --radius-m, {radius_m:g} m) is right"
        if radius_m is not None
        else "the sphere radius (give it: radius_m, --radius-m)"
    )
    return (
        f"{text}; check that the sphere is in view in these passes, that the points are "
        f"in the table-centred frame, and {radius}"
    )
