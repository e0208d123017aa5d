"""WGS84 Earth model for navigation.

Radii of curvature, normal gravity, Earth rate and transport rate in the local NED frame.

Every function is compiled with numba (``njit``) so the strapdown and filter loops call
it directly; called from Python it works on floats (and on arrays for the radii and
gravity).

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, sections 2.4 (radii), 2.4.7 (Somigliana normal
gravity and its height dependence), 5.4 (NED mechanisation rates).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import FloatArray

__all__ = [
    "A_M",
    "E2",
    "GM_M3_S2",
    "OMEGA_IE_RAD_S",
    "F",
    "earth_rate_ned_rad_s",
    "normal_gravity_m_s2",
    "radii_m",
    "transport_rate_ned_rad_s",
]

A_M = 6378137.0
"""WGS84 semi-major axis (m)."""
F = 1.0 / 298.257223563
"""WGS84 flattening."""
E2 = F * (2.0 - F)
"""First eccentricity squared."""
B_M = A_M * (1.0 - F)
OMEGA_IE_RAD_S = 7.292115e-5
"""Earth rotation rate (rad/s)."""
GM_M3_S2 = 3.986004418e14
"""Earth's gravitational constant (m^3/s^2)."""
_G_EQUATOR = 9.7803253359
_G_POLE = 9.8321849378
_K_SOMIGLIANA = (B_M * _G_POLE) / (A_M * _G_EQUATOR) - 1.0
_M_RATIO = OMEGA_IE_RAD_S**2 * A_M**2 * B_M / GM_M3_S2

_jit = cached_njit()


def _radii_m(lat_rad: Any) -> tuple[Any, Any]:  # pragma: no cover - numba
    s2 = np.sin(lat_rad) ** 2
    den = 1.0 - E2 * s2
    r_n = A_M / np.sqrt(den)
    r_m = A_M * (1.0 - E2) / (den * np.sqrt(den))
    return r_m, r_n


def _normal_gravity_m_s2(lat_rad: Any, h_m: Any) -> Any:  # pragma: no cover - numba
    s2 = np.sin(lat_rad) ** 2
    g0 = _G_EQUATOR * (1.0 + _K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (
        1.0 - 2.0 / A_M * (1.0 + F + _M_RATIO - 2.0 * F * s2) * h_m + 3.0 * h_m * h_m / (A_M * A_M)
    )


def _earth_rate_ned_rad_s(lat_rad: float) -> FloatArray:  # pragma: no cover - numba
    out = np.empty(3)
    out[0] = OMEGA_IE_RAD_S * np.cos(lat_rad)
    out[1] = 0.0
    out[2] = -OMEGA_IE_RAD_S * np.sin(lat_rad)
    return out


def _transport_rate_ned_rad_s(
    lat_rad: float, h_m: float, vel_ned_m_s: FloatArray
) -> FloatArray:  # pragma: no cover - numba
    s2 = np.sin(lat_rad) ** 2
    den = 1.0 - E2 * s2
    r_n = A_M / np.sqrt(den)
    r_m = A_M * (1.0 - E2) / (den * np.sqrt(den))
    out = np.empty(3)
    out[0] = vel_ned_m_s[1] / (r_n + h_m)
    out[1] = -vel_ned_m_s[0] / (r_m + h_m)
    out[2] = -vel_ned_m_s[1] * np.tan(lat_rad) / (r_n + h_m)
    return out


radii_m = _jit(_radii_m)
radii_m.__doc__ = """Meridian and normal (prime vertical) radii of curvature.

Parameters
----------
lat_rad : float or ndarray
    Geodetic latitude (rad).

Returns
-------
(r_m, r_n) : floats or ndarrays, same shape as ``lat_rad``
    Meridian radius R_M and normal radius R_N (m).
"""

normal_gravity_m_s2 = _jit(_normal_gravity_m_s2)
normal_gravity_m_s2.__doc__ = """Magnitude of normal gravity (Somigliana, with height terms).

Parameters
----------
lat_rad : float or ndarray
    Geodetic latitude (rad).
h_m : float or ndarray
    Ellipsoidal height (m).

Returns
-------
float or ndarray
    Gravity (m/s^2), acting along +Down in NED (plumb-line deflection neglected).
"""

earth_rate_ned_rad_s = _jit(_earth_rate_ned_rad_s)
earth_rate_ned_rad_s.__doc__ = """Earth rotation rate expressed in NED, shape (3,), rad/s."""

transport_rate_ned_rad_s = _jit(_transport_rate_ned_rad_s)
transport_rate_ned_rad_s.__doc__ = """Transport rate (NED over the ellipsoid), shape (3,), rad/s.

Parameters
----------
lat_rad : float
    Latitude (rad).
h_m : float
    Height (m).
vel_ned_m_s : ndarray, shape (3,)
    Velocity over the Earth in NED (m/s).
"""
