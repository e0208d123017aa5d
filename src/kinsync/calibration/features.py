"""Features the calibration aligns: planes and spheres, the nuisance parameters.

A feature is one physical surface seen by several lines; every line's returns on it
must fit one shape. Each kind gives, for georeferenced returns ``x`` (local frame, m):

- the residual ``e`` (m): the signed distance to the surface;
- ``d e / d x``, shape (n, 3), to chain with the mount derivatives;
- ``d e / d (feature parameters)``, shape (n, q), and the update of its parameters.

Plane (q = 3): unit normal ``n`` and offset ``d`` about a fixed reference point
``r0`` (its first centroid, which keeps ``d`` small): ``e = n . (x - r0) - d``. The
normal is updated in its tangent plane (two angles), so it stays a unit vector.

Sphere (q = 4, or 3 with a known radius): centre ``c`` and radius ``R``:
``e = |x - c| - R`` (the orthogonal distance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar, Literal

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray, IntArray
from kinsync.errors import InputError

__all__ = [
    "Feature",
    "FeatureKind",
    "PlaneFeature",
    "SphereFeature",
    "plane_from_points",
    "thin_returns",
]

FeatureKind = Literal["plane", "sphere"]


def _tangent_basis(normal: FloatArray) -> FloatArray:
    """Two unit vectors orthogonal to ``normal`` and to each other, shape (2, 3)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    w = np.cross(normal, u)
    return np.vstack([u, w])


@dataclass(frozen=True, eq=False)
class PlaneFeature(ReadOnlyArrays):
    """A plane ``n . (x - r0) = d`` in the local frame.

    Attributes
    ----------
    normal : ndarray, shape (3,)
        Unit normal (local frame).
    offset_m : float
        Offset ``d`` along the normal from the reference point (m).
    reference_m : ndarray, shape (3,)
        Fixed reference point ``r0`` (local frame, m).
    """

    normal: FloatArray
    offset_m: float
    reference_m: FloatArray

    kind: ClassVar[FeatureKind] = "plane"

    @property
    def n_params(self) -> int:
        """Nuisance parameters: two tilt angles and the offset."""
        return 3

    @property
    def anchor_m(self) -> FloatArray:
        """A point on the feature where its gradients are defined (local frame, m)."""
        return self.reference_m

    def residuals(self, x: FloatArray) -> FloatArray:
        """Signed distances (m) of points ``x`` (n, 3) to the plane, shape (n,)."""
        out: FloatArray = (x - self.reference_m) @ self.normal - self.offset_m
        return out

    def gradient_x(self, x: FloatArray) -> FloatArray:
        """``d e / d x``, shape (n, 3): the normal for every point."""
        return np.broadcast_to(self.normal, x.shape)

    def jacobian(self, x: FloatArray) -> FloatArray:
        """``d e / d (tilt_u, tilt_w, offset)``, shape (n, 3)."""
        basis = _tangent_basis(self.normal)
        rel = x - self.reference_m
        return np.column_stack([rel @ basis[0], rel @ basis[1], -np.ones(len(x))])

    def updated(self, delta: FloatArray) -> PlaneFeature:
        """The plane moved by a step of its three parameters."""
        basis = _tangent_basis(self.normal)
        n = self.normal + delta[0] * basis[0] + delta[1] * basis[1]
        n /= np.linalg.norm(n)
        return replace(self, normal=n, offset_m=float(self.offset_m + delta[2]))

    def describe(self) -> str:
        """Short text: the normal's direction."""
        down = float(self.normal[2])
        tilt = math.degrees(math.acos(min(1.0, abs(down))))
        azimuth = math.degrees(math.atan2(self.normal[1], self.normal[0])) % 360.0
        return f"plane, tilt {tilt:.0f} deg, normal azimuth {azimuth:.0f} deg"


@dataclass(frozen=True, eq=False)
class SphereFeature(ReadOnlyArrays):
    """A sphere ``|x - c| = R`` in the local frame.

    Attributes
    ----------
    centre_m : ndarray, shape (3,)
        Centre (local frame, m).
    radius_m : float
        Radius (m), > 0.
    radius_known : bool
        True: the radius is given and held; False: it is estimated.
    """

    centre_m: FloatArray
    radius_m: float
    radius_known: bool

    kind: ClassVar[FeatureKind] = "sphere"

    @property
    def n_params(self) -> int:
        """Nuisance parameters: the centre, and the radius unless it is known."""
        return 3 if self.radius_known else 4

    @property
    def anchor_m(self) -> FloatArray:
        """A point on the feature where its gradients are defined (local frame, m)."""
        out: FloatArray = self.centre_m + np.array([self.radius_m, 0.0, 0.0])
        return out

    def residuals(self, x: FloatArray) -> FloatArray:
        """Orthogonal distances (m) of ``x`` (n, 3) to the sphere, shape (n,)."""
        out: FloatArray = np.linalg.norm(x - self.centre_m, axis=1) - self.radius_m
        return out

    def gradient_x(self, x: FloatArray) -> FloatArray:
        """``d e / d x``, shape (n, 3): the outward unit radial direction."""
        rel = x - self.centre_m
        out: FloatArray = rel / np.linalg.norm(rel, axis=1, keepdims=True)
        return out

    def jacobian(self, x: FloatArray) -> FloatArray:
        """``d e / d (centre[, radius])``, shape (n, 3) or (n, 4)."""
        radial = self.gradient_x(x)
        if self.radius_known:
            return -radial
        return np.column_stack([-radial, -np.ones(len(x))])

    def updated(self, delta: FloatArray) -> SphereFeature:
        """The sphere moved by a step of its parameters."""
        radius = self.radius_m if self.radius_known else float(self.radius_m + delta[3])
        if not radius > 0.0:
            radius = self.radius_m
        return replace(self, centre_m=self.centre_m + delta[:3], radius_m=radius)

    def describe(self) -> str:
        """Short text: the radius."""
        how = "known" if self.radius_known else "fitted"
        return f"sphere, radius {self.radius_m:.3f} m ({how})"


Feature = PlaneFeature | SphereFeature


def plane_from_points(x: FloatArray) -> PlaneFeature:
    """Total-least-squares plane through points ``x`` (n >= 3, local frame, m).

    Raises
    ------
    InputError
        Fewer than three points, or collinear ones.
    """
    if x.shape[0] < 3:
        msg = f"a plane needs at least 3 points, got {x.shape[0]}"
        raise InputError(msg)
    centroid = x.mean(axis=0)
    _, s, vt = np.linalg.svd(x - centroid, full_matrices=False)
    if s[1] <= 1e-9 * max(s[0], 1e-300):
        msg = "the points of a plane are collinear"
        raise InputError(msg)
    normal = vt[2] / np.linalg.norm(vt[2])
    if normal[2] > 0.0 or (abs(normal[2]) < 1e-9 and normal[0] < 0.0):
        normal = -normal  # a consistent orientation: up (negative Down), else north
    return PlaneFeature(normal=normal, offset_m=0.0, reference_m=centroid)


def thin_returns(
    idx: IntArray, limit: int, seed: int, line_t_s: FloatArray, line_xyz_m: FloatArray
) -> IntArray:
    """At most ``limit`` of one line's returns on one feature, drawn at random, sorted.

    The same returns are drawn whatever the order of the lines, which other lines are
    given (a shared random stream made the estimate and its sigma change with the file
    order, and with a file that was then rejected), what the files are called (a draw
    seeded by the line's name gave another estimate for the same returns in a renamed
    file, or in a .las instead of a .laz), the order of the returns within the file (a
    spatially sorted tile), and the time origin (GPS seconds of week or adjusted
    standard time): the draw is seeded by ``seed``, the time of the first of the
    returns from the line's first return (to 1 ms) and their number, and it draws from
    the returns ordered by time, then scanner-frame x, y, z. Seeded by the absolute
    time of the first return in file order, a shuffled file or times 1e5 s later moved
    the boresight by up to 1 sigma and its sigma by -33 to +15 %.

    Parameters
    ----------
    idx : ndarray of int, shape (n,)
        Indices of the returns within their line.
    limit : int
        Most returns kept.
    seed : int
        The options' seed.
    line_t_s : ndarray of float, shape (N,)
        The times of the line's returns (s), which ``idx`` indexes.
    line_xyz_m : ndarray of float, shape (N, 3)
        The line's returns in the scanner frame (m): ties in time (returns of one pulse)
        are ordered by them.

    Returns
    -------
    ndarray of int, shape (min(n, limit),)
    """
    if idx.size <= limit:
        return idx
    xyz = line_xyz_m[idx]
    canonical = idx[np.lexsort((xyz[:, 2], xyz[:, 1], xyz[:, 0], line_t_s[idx]))]
    t_rel_ms = round((float(line_t_s[canonical[0]]) - float(np.min(line_t_s))) * 1e3)
    key = [seed & 0xFFFFFFFF, t_rel_ms % (1 << 63), int(idx.size)]
    rng = np.random.default_rng(key)
    chosen: IntArray = np.sort(rng.choice(canonical, limit, replace=False))
    return chosen
