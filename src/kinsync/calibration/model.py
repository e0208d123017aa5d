"""Lines georeferenced with a candidate mount, and the derivatives with respect to it.

The model is the real georeferencing chain of SPEC section 5, through the compiled
kernel of `kinsync.georef.kernel` (cubic Hermite positions, slerp of the body -> ECEF
attitude)::

    x(t) = p(t + tau) + C(t + tau) (a + R_s^b x_s)

with ``p`` the body reference point and ``C`` the body -> ECEF rotation read at the
navigation tag ``t + tau`` (SPEC section 1), ``a`` the lever arm, ``R_s^b`` the
boresight and ``x_s`` the return in the scanner frame. For each return the kernel
gives ``p`` and the columns of ``C`` (georeferencing the origin and the unit vectors
with an identity mount), so that

- d x / d a = C;
- d x / d (boresight angle) = C (d R_s^b / d angle) x_s, with
  ``R = Rz(yaw) Ry(pitch) Rx(roll)`` differentiated analytically;
- d x / d tau = (x(t + tau + h) - x(t + tau - h)) / 2h through the same kernel, i.e. the
  trajectory's velocity plus its angular rate acting on the lever arm and the range,
  with the interpolation the georeferencing really uses (no small-angle shortcut).

Everything is expressed in one local Cartesian frame (`LocalFrame`: NED axes at a
geodetic origin, a rigid transform of ECEF, so planes stay planes and spheres spheres)
to keep the coordinates small.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.parameters import BORESIGHT, LATENCY, LEVER, mount_from_values
from kinsync.errors import InputError
from kinsync.frames import ecef_to_geodetic, euler_rpy_to_matrix, rot_x, rotation_ned_to_ecef
from kinsync.georef.kernel import georeference
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.mount import Mount

__all__ = ["LATENCY_STEP_S", "LineModel", "LocalFrame", "local_frame_for"]

LATENCY_STEP_S = 2.5e-4
"""Half step of the central difference in tau (s): small against the record interval."""

_IDENTITY_MOUNT = Mount()


@dataclass(frozen=True, eq=False)
class LocalFrame(ReadOnlyArrays):
    """A local Cartesian frame: NED axes at a geodetic origin (a rigid transform of ECEF).

    Attributes
    ----------
    origin_ecef_m : ndarray, shape (3,)
        Origin, ECEF (m).
    R_ecef_to_local : ndarray, shape (3, 3)
        Rotation ECEF -> local NED.
    """

    origin_ecef_m: FloatArray
    R_ecef_to_local: FloatArray

    def points(self, pos_ecef_m: FloatArray) -> FloatArray:
        """ECEF points (m), shape (n, 3), in the local frame (m)."""
        out: FloatArray = (pos_ecef_m - self.origin_ecef_m) @ self.R_ecef_to_local.T
        return out

    def vectors(self, vec_ecef: FloatArray) -> FloatArray:
        """ECEF vectors, shape (n, 3, k) (axis 1 the coordinates), in the local frame."""
        out: FloatArray = np.einsum("ij,njk->nik", self.R_ecef_to_local, vec_ecef)
        return out

    def lat_lon_h(self) -> tuple[float, float, float]:
        """Geodetic origin (deg, deg, m)."""
        lat, lon, h = ecef_to_geodetic(self.origin_ecef_m[None, :])[0]
        return float(lat), float(lon), float(h)


def local_frame_for(lines: Sequence[ScanLine]) -> LocalFrame:
    """The local frame at the mean trajectory position over one line's returns.

    The line is the first recorded (then the first by name), not the first given: the
    patches are voxels of this frame, and the first line given made the patches, and
    with them the estimate, change with the order of the files (and the first by name
    changed them with what the files were called).
    (`kinsync.calibration.estimator.calibrate_mount` frames the lines it keeps, so that
    a rejected line changes nothing either.)
    """
    line = min(lines, key=lambda ln: (ln.t_start_s, ln.name))
    gtraj = GeorefTrajectory.from_trajectory(line.trajectory)
    t_mid = 0.5 * (line.t_start_s + line.t_end_s)
    t_mid = min(max(t_mid, gtraj.t_start_s), gtraj.t_end_s)
    origin = np.array(
        [np.interp(t_mid, gtraj.t_s, gtraj.pos_ecef_m[:, j]) for j in range(3)], dtype=np.float64
    )
    lat, lon, _ = ecef_to_geodetic(origin[None, :])[0]
    R = rotation_ned_to_ecef(float(lat), float(lon)).T
    return LocalFrame(origin_ecef_m=origin, R_ecef_to_local=np.ascontiguousarray(R))


def _boresight_derivatives(rpy_rad: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """D R / d roll, d pitch, d yaw of ``R = Rz(yaw) Ry(pitch) Rx(roll)``, each (3, 3)."""
    r, p, y = (float(v) for v in rpy_rad)
    ex = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    ey = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    ez = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    Rz = euler_rpy_to_matrix(0.0, 0.0, y)
    Ry = euler_rpy_to_matrix(0.0, p, 0.0)
    Rx = rot_x(r)
    return Rz @ Ry @ Rx @ ex, Rz @ Ry @ ey @ Rx, Rz @ ez @ Ry @ Rx


@dataclass(frozen=True, eq=False)
class LineModel:
    """A line prepared for repeated georeferencing with candidate mounts.

    Attributes
    ----------
    line : ScanLine
        The line (all its returns).
    trajectory : GeorefTrajectory
        Its trajectory prepared once, at zero latency: a latency tau is applied by
        reading it at ``t + tau``, which is what the latency correction does.
    """

    line: ScanLine
    trajectory: GeorefTrajectory

    @classmethod
    def prepare(
        cls,
        line: ScanLine,
        cache: dict[int, GeorefTrajectory] | None = None,
        *,
        max_gap_s: float | None = None,
    ) -> LineModel:
        """Prepare ``line``; lines sharing one `Trajectory` object share its preparation.

        ``max_gap_s``: the trajectory's gap threshold (s, `GeorefTrajectory`); one cache
        holds one threshold.
        """
        key = id(line.trajectory)
        if cache is not None and key in cache:
            return cls(line, cache[key])
        gtraj = GeorefTrajectory.from_trajectory(line.trajectory, max_gap_s=max_gap_s)
        if cache is not None:
            cache[key] = gtraj
        return cls(line, gtraj)

    def inside(self, index: FloatArray | BoolArray | None, latency_s: float) -> BoolArray:
        """Which returns (of ``index``) have navigation tags ``t + tau`` in the span.

        Tags inside a data gap of the trajectory are not (`GeorefTrajectory.contains`).
        """
        t = self.line.t_s if index is None else self.line.t_s[index]
        return self.trajectory.contains(t + latency_s)

    def points(self, index: IntArray | None, values: FloatArray, frame: LocalFrame) -> FloatArray:
        """Returns ``index`` georeferenced with the seven ``values``, local frame (m), (n, 3).

        NaN where ``t + tau`` leaves the trajectory's span (never extrapolated).
        """
        t, xyz = self._select(index)
        mount = mount_from_values(_IDENTITY_MOUNT, values).with_latency(0.0)
        ecef, _ = georeference(t + values[LATENCY], xyz, self.trajectory, mount)
        return frame.points(ecef)

    def body_positions(
        self, index: IntArray | None, values: FloatArray, frame: LocalFrame
    ) -> FloatArray:
        """The body reference point at each return's navigation tag, local frame (m), (n, 3)."""
        t, xyz = self._select(index)
        p, _ = georeference(
            t + values[LATENCY], np.zeros_like(xyz), self.trajectory, _IDENTITY_MOUNT
        )
        return frame.points(p)

    def points_and_beams(
        self, index: IntArray | None, values: FloatArray, frame: LocalFrame
    ) -> tuple[FloatArray, FloatArray]:
        """Georeferenced returns (n, 3) and their unit beam directions (n, 3), local frame.

        Three kernel calls instead of `points_and_jacobian`'s eight: what a cost
        evaluation needs.
        """
        t, xyz = self._select(index)
        mount = mount_from_values(_IDENTITY_MOUNT, values).with_latency(0.0)
        tt = t + values[LATENCY]
        x, _ = georeference(tt, xyz, self.trajectory, mount)
        rng_m = np.linalg.norm(xyz, axis=1, keepdims=True)
        unit = xyz / np.where(rng_m > 0.0, rng_m, 1.0)
        tip, _ = georeference(tt, unit, self.trajectory, mount)
        origin, _ = georeference(tt, np.zeros_like(xyz), self.trajectory, mount)
        beam = (tip - origin) @ frame.R_ecef_to_local.T
        return frame.points(x), beam

    def points_and_jacobian(
        self,
        index: IntArray | None,
        values: FloatArray,
        estimated: tuple[int, ...],
        frame: LocalFrame,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Georeferenced returns, their derivatives and their beam directions.

        Parameters
        ----------
        index : ndarray of int or None
            Returns of the line to use (None: all).
        values : ndarray, shape (7,)
            The mount parameters (rad, m, s; `kinsync.calibration.parameters`).
        estimated : tuple of int
            Indices of the parameters to differentiate, length k.
        frame : LocalFrame
            Frame of the output.

        Returns
        -------
        x_local_m : ndarray, shape (n, 3)
            Georeferenced returns, local frame (m); NaN outside the trajectory span.
        jacobian : ndarray, shape (n, 3, k)
            d x / d parameter, local frame (m per rad, m per m, m per s).
        beam : ndarray, shape (n, 3)
            Unit direction of each return's beam from the scanner, local frame (range
            noise acts along it).
        """
        t, xyz = self._select(index)
        tau = float(values[LATENCY])
        tt = t + tau
        zeros = np.zeros_like(xyz)
        p, _ = georeference(tt, zeros, self.trajectory, _IDENTITY_MOUNT)
        C = np.empty((t.size, 3, 3))
        for j in range(3):
            unit = np.zeros_like(xyz)
            unit[:, j] = 1.0
            col, _ = georeference(tt, unit, self.trajectory, _IDENTITY_MOUNT)
            C[:, :, j] = col - p
        R = euler_rpy_to_matrix(*values[list(BORESIGHT)])
        body = values[list(LEVER)][None, :] + xyz @ R.T
        x_ecef = p + np.einsum("nij,nj->ni", C, body)
        jac = np.empty((t.size, 3, len(estimated)))
        derivs = _boresight_derivatives(values[list(BORESIGHT)])
        for col_out, k in enumerate(estimated):
            if k in BORESIGHT:
                jac[:, :, col_out] = np.einsum("nij,nj->ni", C, xyz @ derivs[k].T)
            elif k in LEVER:
                jac[:, :, col_out] = C[:, :, k - LEVER[0]]
            else:
                jac[:, :, col_out] = self._latency_derivative(t, xyz, values)
        x_local = frame.points(x_ecef)
        rng_m = np.linalg.norm(xyz, axis=1, keepdims=True)
        beam_body = (xyz / np.where(rng_m > 0.0, rng_m, 1.0)) @ R.T
        beam = np.einsum("nij,nj->ni", C, beam_body) @ frame.R_ecef_to_local.T
        return x_local, frame.vectors(jac), beam

    def _latency_derivative(self, t: FloatArray, xyz: FloatArray, values: FloatArray) -> FloatArray:
        mount = mount_from_values(_IDENTITY_MOUNT, values).with_latency(0.0)
        tau = float(values[LATENCY])
        h = LATENCY_STEP_S
        lo = np.maximum(t + tau - h, self.trajectory.t_start_s)
        hi = np.minimum(t + tau + h, self.trajectory.t_end_s)
        span = hi - lo
        if np.any(span <= 0.0):
            span = np.where(span <= 0.0, np.nan, span)
        x_hi, _ = georeference(hi, xyz, self.trajectory, mount)
        x_lo, _ = georeference(lo, xyz, self.trajectory, mount)
        out: FloatArray = (x_hi - x_lo) / span[:, None]
        return out

    def _select(self, index: IntArray | None) -> tuple[FloatArray, FloatArray]:
        if index is None:
            return self.line.t_s, self.line.xyz_scanner_m
        idx = np.asarray(index)
        if idx.dtype == np.bool_ and idx.shape != self.line.t_s.shape:
            msg = f"line {self.line.name!r}: selection mask of the wrong length"
            raise InputError(msg)
        return self.line.t_s[idx], self.line.xyz_scanner_m[idx]
