"""kinsync: time synchronisation and latency calibration of kinematic laser scanning.

Conventions (binding for every module; SPEC section 1)
------------------------------------------------------
Time
    Seconds, float64. The reference scale is GPS time: continuous seconds since the
    GPS epoch 1980-01-06T00:00:00 (``t_gps_s``). Readers of formats that carry GPS
    seconds of week, adjusted standard GPS time (GPS - 1e9 s, as in LAS) or UTC say
    which scale they read and convert; UTC -> GPS uses the leap-second table
    (18 s since 2017-01-01). Scales are never mixed silently.
Frames
    Navigation frame: local level North-East-Down (NED). Body frame: Forward-Right-Down
    (X forward, Y right, Z down). Earth frame: ECEF on WGS84, geodetic latitude,
    longitude (degrees) and ellipsoidal height (metres). Projected output through EPSG
    codes (pyproj).
Attitude
    Roll, pitch, yaw (heading) in the DIN 9300 / aerospace sequence: yaw about Down,
    then pitch about the new Y, then roll about the new X, so that
    ``R_body_to_ned = Rz(yaw) @ Ry(pitch) @ Rx(roll)``. Quaternions are scalar-first
    ``(w, x, y, z)``, unit norm, and represent the same body -> NED rotation.
Vehicle frame (reports)
    Validation reports use X right, Y forward, Z up, as surveyors read them.
Mount (system calibration)
    Lever arm of the scanner origin in the body frame (m), boresight rotation
    scanner -> body (roll, pitch, yaw in degrees, same sequence), GNSS antenna lever arm
    in the body frame (m), and latency tau (s).
Latency sign
    ``tau > 0`` means the navigation record lags the scanner: a record time-tagged ``t``
    describes the physical attitude (and position) at ``t - tau``. A point measured at
    ``t`` is therefore georeferenced with the navigation record tagged ``t + tau``
    (``Trajectory.shifted(-tau)`` gives the trajectory on the scanner's time scale).
Names
    Every quantity with a unit or a frame carries it in its name: ``t_gps_s``,
    ``pos_ecef_m``, ``rate_deg_s``, ``R_body_to_ned``, ``lever_arm_body_m``.
    Angles in public APIs are radians unless the name ends in ``_deg``.

Layers (docs/architecture.md; ``tests/test_architecture.py`` enforces them)
----------------------------------------------------------------------------
Lowest first; a module imports only from its own layer or a lower one:

core
    this package, ``errors``, ``frames``, ``trajectory``, ``mount``, ``messages``,
    ``crs``, ``robust``: conventions and the containers several domains share.
algorithms
    ``budget``, ``fit``, ``clock``, ``latency``, ``sync``, ``ins``, ``georef``,
    ``validation``, ``calibration``: each domain's containers and maths. They take and return
    containers, never paths; they never print, exit or open a file.
io
    file formats; takes only containers (classes, constants) from the algorithms.
pipelines
    files streamed through the algorithms (chunks, schedulers, atomic outputs).
sim
    simulators with known truth, producing the containers and files sensors do.
report, demo, cli
    figures and the HTML report; the demo's sections; the command line.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from kinsync._lazy import lazy_exports

if TYPE_CHECKING:
    from kinsync.errors import InputError, KinsyncError
    from kinsync.mount import Mount
    from kinsync.trajectory import Trajectory

__version__ = "0.1.0"

__all__ = ["InputError", "KinsyncError", "Mount", "Trajectory", "__version__"]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "InputError": "kinsync.errors",
        "KinsyncError": "kinsync.errors",
        "Mount": "kinsync.mount",
        "Trajectory": "kinsync.trajectory",
    },
    submodules=True,
)
"""The package's names are imported when first used (PEP 562): ``import kinsync`` loads no
numpy, so the ``kinsync`` program sets its Ctrl-C handling before the heavy imports; a
submodule is an attribute on first use (``kinsync.trajectory`` after ``import kinsync``)."""
