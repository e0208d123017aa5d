"""A scene for simulated kinematic scanning: ground, walls and retro-reflective targets.

Everything lives in one local-level NED frame tangent at ``origin_lat_lon_h`` (m):

- the **ground**, a horizontal plane ``D = ground_down_m``;
- **walls**, vertical rectangles standing on a horizontal segment between two (N, E)
  points, from ``bottom_down_m`` up to ``top_down_m`` (``top_down_m < bottom_down_m``);
- **panels**, flat convex polygons of any orientation (sloping roofs and shores, walls
  of any azimuth, gable ends), `Panel.rectangle` for the common rectangular case;
- **targets**, spheres of known centre and radius with a retro-reflective coating
  (high intensity): *sync* targets (Method B, SPEC section 4) and *control* targets
  (validation, SPEC section 7).

`Scene.cast` intersects rays with every primitive, vectorised with numpy, and returns
the range to the nearest hit and what was hit (panels out of reach of every ray of a
call are skipped, so a large scene costs little when the rays come in short chunks).
`build_drive_scene` places the primitives along a driven trajectory: two sync targets
beside the road at the start and the end of the drive, control targets on both sides, a
wall along the tightest curve.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Literal, NamedTuple, cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    ecef_to_ned,
    geodetic_to_ecef,
    ned_to_ecef,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
)
from kinsync.trajectory import Trajectory

__all__ = [
    "NO_HIT",
    "Panel",
    "Scene",
    "SceneLayout",
    "Target",
    "Wall",
    "build_drive_scene",
    "trajectory_to_local",
]

NO_HIT = -1
"""``hit_id`` of a ray that hits nothing within the range limit."""

TargetKind = Literal["sync", "control"]


def _vec(values: tuple[float, ...], n: int, name: str) -> tuple[float, ...]:
    if len(values) != n:
        msg = f"{name}: expected {n} numbers, got {values!r}"
        raise InputError(msg)
    return tuple(finite_number(v, name) for v in values)


@dataclass(frozen=True)
class Wall:
    """A vertical rectangular wall.

    Attributes
    ----------
    start_ne_m, end_ne_m : tuple of 2 float
        Ends of its foot, (North, East) in the scene frame (m), distinct.
    top_down_m, bottom_down_m : float
        Down coordinates of its top and bottom edges (m), ``top < bottom``.
    """

    start_ne_m: tuple[float, float]
    end_ne_m: tuple[float, float]
    top_down_m: float
    bottom_down_m: float

    def __post_init__(self) -> None:
        a = _vec(self.start_ne_m, 2, "wall start_ne_m")
        b = _vec(self.end_ne_m, 2, "wall end_ne_m")
        if math.hypot(b[0] - a[0], b[1] - a[1]) <= 0.0:
            msg = f"wall: start and end coincide at {a}"
            raise InputError(msg)
        top = finite_number(self.top_down_m, "wall top_down_m")
        bottom = finite_number(self.bottom_down_m, "wall bottom_down_m")
        if top >= bottom:
            msg = f"wall: top_down_m ({top}) must be above (smaller than) bottom_down_m ({bottom})"
            raise InputError(msg)
        object.__setattr__(self, "start_ne_m", a)
        object.__setattr__(self, "end_ne_m", b)


Vector3 = tuple[float, float, float]

_PLANAR_TOL_M = 1e-6
"""Largest distance of a panel vertex from the panel's plane (m)."""


@dataclass(frozen=True)
class Panel:
    """A flat convex polygon: a roof plane, a sloping shore, a wall of any azimuth.

    Attributes
    ----------
    vertices_ned_m : tuple of (N, E, D) tuples
        Corners in order around the outline (either sense), scene frame (m): at least
        3, coplanar (within 1e-6 m), convex, no two consecutive ones equal.
    name : str
        Name used in messages (and by scene builders to match panels to features).

    Notes
    -----
    Rays hit either face. A closed building made of panels hides what is inside it.
    """

    vertices_ned_m: tuple[Vector3, ...]
    name: str = ""

    def __post_init__(self) -> None:
        label = f"panel {self.name!r}"
        raw = tuple(self.vertices_ned_m)
        if len(raw) < 3:
            msg = f"{label}: needs at least 3 vertices, got {len(raw)}"
            raise InputError(msg)
        verts = tuple(tuple(_vec(tuple(v), 3, f"{label} vertex {i}")) for i, v in enumerate(raw))
        object.__setattr__(self, "vertices_ned_m", verts)
        v = np.array(verts)
        edges = np.roll(v, -1, axis=0) - v
        lengths = np.linalg.norm(edges, axis=1)
        if np.any(lengths <= 0.0):
            i = int(np.flatnonzero(lengths <= 0.0)[0])
            msg = f"{label}: vertices {i} and {(i + 1) % len(v)} coincide"
            raise InputError(msg)
        # Newell's normal: robust for any planar polygon, |n| = 2 * area.
        n = np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)
        size = float(np.max(lengths))
        if float(np.linalg.norm(n)) <= 1e-9 * size * size:
            msg = f"{label}: the vertices enclose no area (collinear?)"
            raise InputError(msg)
        n /= np.linalg.norm(n)
        off = np.abs((v - v.mean(axis=0)) @ n)
        if float(off.max()) > _PLANAR_TOL_M:
            msg = (
                f"{label}: the vertices are not coplanar (vertex {int(np.argmax(off))} lies "
                f"{float(off.max()):.3g} m off the plane)"
            )
            raise InputError(msg)
        turn = np.cross(edges, np.roll(edges, -1, axis=0)) @ n
        if np.any(turn < -1e-9 * size * size):
            msg = f"{label}: the outline is not convex; split it into convex panels"
            raise InputError(msg)

    @property
    def vertices_array_ned_m(self) -> FloatArray:
        """Vertices, shape (K, 3), scene frame (m)."""
        return np.array(self.vertices_ned_m)

    @property
    def normal_ned(self) -> FloatArray:
        """Unit normal, shape (3,): right-handed about the vertex order."""
        v = self.vertices_array_ned_m
        n = np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)
        out: FloatArray = n / np.linalg.norm(n)
        return out

    @property
    def centroid_ned_m(self) -> FloatArray:
        """Area centroid, shape (3,), scene frame (m)."""
        v = self.vertices_array_ned_m
        n = self.normal_ned
        tri_area = np.cross(v[1:-1] - v[0], v[2:] - v[0]) @ n
        tri_centre = (v[0] + v[1:-1] + v[2:]) / 3.0
        out: FloatArray = (tri_area[:, None] * tri_centre).sum(axis=0) / tri_area.sum()
        return out

    @property
    def area_m2(self) -> float:
        """Area (m^2)."""
        v = self.vertices_array_ned_m
        return float(0.5 * np.sum(np.cross(v[1:-1] - v[0], v[2:] - v[0]) @ self.normal_ned))

    @classmethod
    def rectangle(
        cls, corner_ned_m: Vector3, edge_u_ned_m: Vector3, edge_v_ned_m: Vector3, name: str = ""
    ) -> Panel:
        """The parallelogram ``corner + s u + t v``, ``0 <= s, t <= 1``.

        A rectangle when ``u`` and ``v`` are perpendicular; corner and edges in the scene
        frame (m).
        """
        c = np.array(_vec(tuple(corner_ned_m), 3, f"panel {name!r} corner_ned_m"))
        u = np.array(_vec(tuple(edge_u_ned_m), 3, f"panel {name!r} edge_u_ned_m"))
        w = np.array(_vec(tuple(edge_v_ned_m), 3, f"panel {name!r} edge_v_ned_m"))
        corners = (c, c + u, c + u + w, c + w)
        return cls(tuple(_as_vector3(p) for p in corners), name)

    def _casting_terms(self) -> tuple[FloatArray, float, FloatArray, FloatArray]:
        """Normal, plane offset, inward edge normals (K, 3) and their offsets (K,)."""
        v = self.vertices_array_ned_m
        n = self.normal_ned
        edges = np.roll(v, -1, axis=0) - v
        inward = np.cross(n, edges)  # points into the polygon for the right-handed order
        return n, float(n @ v[0]), inward, np.einsum("ij,ij->i", inward, v)

    def bounding_sphere(self) -> tuple[FloatArray, float]:
        """Centre (3,) and radius of a sphere holding the panel (m, scene frame)."""
        v = self.vertices_array_ned_m
        centre: FloatArray = v.mean(axis=0)
        return centre, float(np.max(np.linalg.norm(v - centre, axis=1)))


def _as_vector3(p: FloatArray) -> Vector3:
    return (float(p[0]), float(p[1]), float(p[2]))


@dataclass(frozen=True)
class Target:
    """A retro-reflective sphere.

    Attributes
    ----------
    name : str
        Name (written to the sync-point or control-point file).
    centre_ned_m : tuple of 3 float
        Centre in the scene frame (m).
    radius_m : float
        Radius (m), > 0.
    kind : {"sync", "control"}
        Sync target (Method B) or control point (validation).
    """

    name: str
    centre_ned_m: tuple[float, float, float]
    radius_m: float = 0.15
    kind: TargetKind = "sync"

    def __post_init__(self) -> None:
        c = _vec(self.centre_ned_m, 3, f"target {self.name!r} centre_ned_m")
        object.__setattr__(self, "centre_ned_m", c)
        positive_number(self.radius_m, f"target {self.name!r} radius_m")
        if self.kind not in ("sync", "control"):
            msg = f"target {self.name!r}: kind must be 'sync' or 'control', got {self.kind!r}"
            raise InputError(msg)


@dataclass(frozen=True)
class Scene:
    """Ground, walls, panels and targets in a local NED frame.

    Attributes
    ----------
    origin_lat_lon_h : tuple of 3 float
        Geodetic origin of the scene frame (deg, deg, m).
    ground_down_m : float
        Down coordinate of the ground plane (m).
    walls : tuple of Wall
    targets : tuple of Target
        Names unique.
    panels : tuple of Panel
        Flat convex polygons of any orientation.
    """

    origin_lat_lon_h: tuple[float, float, float]
    ground_down_m: float
    walls: tuple[Wall, ...] = ()
    targets: tuple[Target, ...] = ()
    panels: tuple[Panel, ...] = ()

    def __post_init__(self) -> None:
        o = _vec(self.origin_lat_lon_h, 3, "scene origin_lat_lon_h")
        if abs(o[0]) > 90.0:
            msg = f"scene origin latitude {o[0]} outside [-90, 90]"
            raise InputError(msg)
        object.__setattr__(self, "origin_lat_lon_h", o)
        finite_number(self.ground_down_m, "scene ground_down_m")
        names = [t.name for t in self.targets]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            msg = f"scene: target name(s) {dupes} used more than once"
            raise InputError(msg)

    @property
    def first_panel_id(self) -> int:
        """``hit_id`` of the first panel; walls are ``1 .. len(walls)``, ground 0."""
        return 1 + len(self.walls)

    @property
    def first_target_id(self) -> int:
        """``hit_id`` of the first target: after the ground (0), the walls and the panels."""
        return 1 + len(self.walls) + len(self.panels)

    def targets_of_kind(self, kind: TargetKind) -> tuple[Target, ...]:
        """The sync or the control targets, in scene order."""
        return tuple(t for t in self.targets if t.kind == kind)

    def target_lat_lon_h(self, targets: tuple[Target, ...]) -> FloatArray:
        """Geodetic centres (lat_deg, lon_deg, h_m) of targets, shape (K, 3)."""
        if not targets:
            return np.empty((0, 3))
        ned = np.array([t.centre_ned_m for t in targets])
        return ecef_to_geodetic(ned_to_ecef(ned, *self.origin_lat_lon_h))

    def cast(
        self, origin_ned_m: FloatArray, direction_ned: FloatArray, max_range_m: float
    ) -> tuple[FloatArray, IntArray]:
        """Intersect rays with the scene; nearest hit per ray.

        Parameters
        ----------
        origin_ned_m : ndarray, shape (N, 3)
            Ray origins, scene frame (m).
        direction_ned : ndarray, shape (N, 3)
            Unit ray directions, scene frame.
        max_range_m : float
            Hits farther than this are ignored (m).

        Returns
        -------
        range_m : ndarray, shape (N,)
            Distance to the nearest hit (m); ``inf`` where nothing is hit.
        hit_id : ndarray of int64, shape (N,)
            `NO_HIT`, 0 for the ground, ``1 .. len(walls)`` for walls, panels from
            `first_panel_id`, then targets from `first_target_id`, in scene order.
        """
        o = np.asarray(origin_ned_m, dtype=np.float64)
        d = np.asarray(direction_ned, dtype=np.float64)
        n = o.shape[0]
        best = np.full(n, np.inf)
        hit = np.full(n, NO_HIT, dtype=np.int64)

        def keep(t: FloatArray, ok: BoolArray, ident: int) -> None:
            better = ok & (t < best) & (t <= max_range_m)
            best[better] = t[better]
            hit[better] = ident

        with np.errstate(divide="ignore", invalid="ignore"):
            # Ground: D = ground.
            t_g = (self.ground_down_m - o[:, 2]) / d[:, 2]
            keep(t_g, (d[:, 2] > 1e-12) & (t_g > 0), 0)
            for k, wall in enumerate(self.walls, start=1):
                a = np.array(wall.start_ne_m)
                b = np.array(wall.end_ne_m)
                length = float(np.hypot(*(b - a)))
                u = (b - a) / length
                normal = np.array([-u[1], u[0]])
                denom = d[:, :2] @ normal
                t_w = ((a - o[:, :2]) @ normal) / denom
                foot = o[:, :2] + t_w[:, None] * d[:, :2]
                along = (foot - a) @ u
                down = o[:, 2] + t_w * d[:, 2]
                ok = (
                    (np.abs(denom) > 1e-12)
                    & (t_w > 0)
                    & (along >= 0)
                    & (along <= length)
                    & (down >= wall.top_down_m)
                    & (down <= wall.bottom_down_m)
                )
                keep(t_w, ok, k)
            if self.panels and n:
                self._cast_panels(o, d, max_range_m, best, hit)
            for k, target in enumerate(self.targets, start=self.first_target_id):
                c = np.array(target.centre_ned_m)
                oc = o - c
                b_half = np.einsum("ij,ij->i", oc, d)
                cc = np.einsum("ij,ij->i", oc, oc) - target.radius_m**2
                disc = b_half * b_half - cc
                t_s = -b_half - np.sqrt(np.maximum(disc, 0.0))
                keep(t_s, (disc >= 0) & (cc > 0) & (t_s > 0), k)
        return best, hit

    @cached_property
    def _panel_table(self) -> _PanelTable:
        return _panel_table(self.panels, self.first_panel_id)

    def _cast_panels(
        self,
        o: FloatArray,
        d: FloatArray,
        max_range_m: float,
        best: FloatArray,
        hit: IntArray,
    ) -> None:
        """Update ``best``/``hit`` with the panels in reach of any of the rays."""
        tab = self._panel_table
        lo, hi = o.min(axis=0), o.max(axis=0)
        gap = np.linalg.norm(
            np.maximum(0.0, np.maximum(lo - tab.centre_m, tab.centre_m - hi)), axis=1
        )
        near = np.flatnonzero(gap - tab.radius_m <= max_range_m)
        if near.size == 0:
            return
        _cast_panels_kernel(
            np.ascontiguousarray(o),
            np.ascontiguousarray(d),
            np.ascontiguousarray(tab.normal[near]),
            np.ascontiguousarray(tab.offset_m[near]),
            np.ascontiguousarray(tab.edge_normal[near]),
            np.ascontiguousarray(tab.edge_offset_m[near]),
            np.ascontiguousarray(tab.n_edges[near]),
            np.ascontiguousarray(tab.hit_id[near]),
            float(max_range_m),
            best,
            hit,
        )


class _PanelTable(NamedTuple):
    """Panels as arrays for the casting kernel (K: most vertices of any panel)."""

    normal: FloatArray  # (P, 3)
    offset_m: FloatArray  # (P,)
    edge_normal: FloatArray  # (P, K, 3), inward, zero-padded
    edge_offset_m: FloatArray  # (P, K)
    n_edges: IntArray  # (P,)
    hit_id: IntArray  # (P,)
    centre_m: FloatArray  # (P, 3), bounding sphere
    radius_m: FloatArray  # (P,)


def _panel_table(panels: tuple[Panel, ...], first_id: int) -> _PanelTable:
    n_p = len(panels)
    k_max = max(len(p.vertices_ned_m) for p in panels)
    normal = np.zeros((n_p, 3))
    offset = np.zeros(n_p)
    edge_normal = np.zeros((n_p, k_max, 3))
    edge_offset = np.zeros((n_p, k_max))
    n_edges = np.zeros(n_p, dtype=np.int64)
    centre = np.zeros((n_p, 3))
    radius = np.zeros(n_p)
    for i, panel in enumerate(panels):
        n, off, inward, inward_off = panel._casting_terms()
        k = inward.shape[0]
        normal[i], offset[i], n_edges[i] = n, off, k
        edge_normal[i, :k] = inward
        edge_offset[i, :k] = inward_off
        centre[i], radius[i] = panel.bounding_sphere()
    return _PanelTable(
        normal,
        offset,
        edge_normal,
        edge_offset,
        n_edges,
        np.arange(first_id, first_id + n_p, dtype=np.int64),
        centre,
        radius,
    )


def _cast_panels_loop(
    o: FloatArray,
    d: FloatArray,
    normal: FloatArray,
    offset: FloatArray,
    edge_normal: FloatArray,
    edge_offset: FloatArray,
    n_edges: IntArray,
    ids: IntArray,
    max_range_m: float,
    best: FloatArray,
    hit: IntArray,
) -> None:
    """Nearest panel hit per ray, nearer than ``best`` (updated in place with ``hit``)."""
    for i in range(o.shape[0]):
        ox, oy, oz = o[i, 0], o[i, 1], o[i, 2]
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        for p in range(normal.shape[0]):
            nx, ny, nz = normal[p, 0], normal[p, 1], normal[p, 2]
            denom = dx * nx + dy * ny + dz * nz
            if abs(denom) <= 1e-12:
                continue
            t = (offset[p] - (ox * nx + oy * ny + oz * nz)) / denom
            if t <= 0.0 or t >= best[i] or t > max_range_m:
                continue
            fx, fy, fz = ox + t * dx, oy + t * dy, oz + t * dz
            inside = True
            for k in range(n_edges[p]):
                e = edge_normal[p, k]
                if fx * e[0] + fy * e[1] + fz * e[2] < edge_offset[p, k] - 1e-9:
                    inside = False
                    break
            if inside:
                best[i] = t
                hit[i] = ids[p]


_cast_panels_kernel = cast(Callable[..., None], cached_njit(nogil=True)(_cast_panels_loop))


def trajectory_to_local(
    trajectory: Trajectory, origin_lat_lon_h: tuple[float, float, float]
) -> tuple[FloatArray, FloatArray]:
    """Positions and attitudes of a trajectory's records in a local NED frame.

    Parameters
    ----------
    trajectory : Trajectory
        Geodetic or local trajectory.
    origin_lat_lon_h : tuple of 3 float
        Origin of the local frame (deg, deg, m).

    Returns
    -------
    pos_local_m : ndarray, shape (N, 3)
        Body reference point, local NED (m).
    R_body_to_local : ndarray, shape (N, 3, 3)
        Attitude body -> local NED (the record's own NED frame turned into the local
        one, exact on the ellipsoid).
    """
    R_le = rotation_ned_to_ecef(origin_lat_lon_h[0], origin_lat_lon_h[1])
    R_bn = quaternion_to_matrix(trajectory.q_body_to_ned)
    if trajectory.lat_lon_h is not None:
        llh = trajectory.lat_lon_h
        ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2])
        R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    else:
        assert trajectory.pos_ned_m is not None
        assert trajectory.origin_lat_lon_h is not None
        ecef = ned_to_ecef(trajectory.pos_ned_m, *trajectory.origin_lat_lon_h)
        R_ne = np.broadcast_to(
            rotation_ned_to_ecef(trajectory.origin_lat_lon_h[0], trajectory.origin_lat_lon_h[1]),
            (len(trajectory), 3, 3),
        )
    pos = ecef_to_ned(ecef, *origin_lat_lon_h)
    R_bl = np.einsum("ji,njk,nkl->nil", R_le, R_ne, R_bn)
    return pos, R_bl


@dataclass(frozen=True)
class SceneLayout:
    """Where `build_drive_scene` puts things (distances in m, times in s).

    Attributes
    ----------
    body_height_m : float
        Height of the body reference point above the ground.
    sync_lead_m : float
        The sync targets stand beside the road ``sync_lead_m`` along the path after the
        start and before the end of the drive (so the vehicle is moving there).
    sync_offset_m : float
        Lateral distance of sync targets from the body reference point, to the right.
    target_height_m : float
        Height of target centres above the ground.
    target_radius_m : float
        Target sphere radius.
    n_control : int
        Control targets, spread evenly over the drive, alternately right and left.
    control_offset_m : float
        Lateral distance of control targets.
    wall_offset_m, wall_length_m, wall_height_m : float
        Wall along the tightest curve: distance outward from the trajectory, length,
        height above the ground.
    """

    body_height_m: float = 0.8
    sync_lead_m: float = 12.0
    sync_offset_m: float = 3.5
    target_height_m: float = 1.0
    target_radius_m: float = 0.15
    n_control: int = 4
    control_offset_m: float = 4.0
    wall_offset_m: float = 5.0
    wall_length_m: float = 16.0
    wall_height_m: float = 3.0

    def __post_init__(self) -> None:
        for name in (
            "body_height_m",
            "sync_lead_m",
            "sync_offset_m",
            "target_height_m",
            "target_radius_m",
            "control_offset_m",
            "wall_offset_m",
            "wall_length_m",
            "wall_height_m",
        ):
            positive_number(getattr(self, name), f"scene layout {name}")
        if isinstance(self.n_control, bool) or self.n_control < 0:
            msg = f"scene layout n_control must be >= 0, got {self.n_control!r}"
            raise InputError(msg)


def build_drive_scene(trajectory: Trajectory, layout: SceneLayout | None = None) -> Scene:
    """Place ground, a wall and sync/control targets along a driven trajectory.

    The ground is a horizontal plane ``body_height_m`` below the mean body height.
    Sync targets ``S1`` and ``S2`` stand ``sync_offset_m`` to the right of the vehicle
    ``sync_lead_m`` along the path after the start and before the end; control targets
    ``C1..Cn`` are spread over the drive, alternately right and left; one wall stands
    ``wall_offset_m`` outside the tightest curve (largest yaw rate), along the heading
    there. The scene frame is tangent at the first record's position.

    Parameters
    ----------
    trajectory : Trajectory
        The true (noise-free) trajectory, a path longer than ``2 * sync_lead_m``.
    layout : SceneLayout, optional

    Returns
    -------
    Scene
    """
    lay = layout or SceneLayout()
    if trajectory.lat_lon_h is not None:
        llh0 = trajectory.lat_lon_h[0]
        origin = (float(llh0[0]), float(llh0[1]), float(llh0[2]))
    else:
        assert trajectory.pos_ned_m is not None
        assert trajectory.origin_lat_lon_h is not None
        o = ecef_to_geodetic(ned_to_ecef(trajectory.pos_ned_m[0], *trajectory.origin_lat_lon_h))
        origin = (float(o[0]), float(o[1]), float(o[2]))
    pos, R = trajectory_to_local(trajectory, origin)
    ground = float(np.mean(pos[:, 2])) + lay.body_height_m
    centre_down = ground - lay.target_height_m

    yaw = np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))

    def beside(t_s: float, offset_m: float, name: str, kind: TargetKind) -> Target:
        p = [float(np.interp(t_s, trajectory.t_s, pos[:, i])) for i in range(2)]
        heading = float(np.interp(t_s, trajectory.t_s, yaw))
        right = (-math.sin(heading), math.cos(heading))
        return Target(
            name=name,
            centre_ned_m=(p[0] + offset_m * right[0], p[1] + offset_m * right[1], centre_down),
            radius_m=lay.target_radius_m,
            kind=kind,
        )

    path_m = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pos[:, :2], axis=0).T))])
    total = float(path_m[-1])
    if total <= 2.0 * lay.sync_lead_m + 1.0:
        msg = (
            f"scene: the trajectory's path is {total:.1f} m long; the sync targets need more "
            f"than 2 x sync_lead_m = {2 * lay.sync_lead_m:g} m"
        )
        raise InputError(msg)

    def time_at(distance_m: float) -> float:
        k = min(int(np.searchsorted(path_m, distance_m)), len(trajectory) - 1)
        return float(trajectory.t_s[k])

    targets = [
        beside(time_at(lay.sync_lead_m), lay.sync_offset_m, "S1", "sync"),
        beside(time_at(total - lay.sync_lead_m), lay.sync_offset_m, "S2", "sync"),
    ]
    span = total - 2.0 * lay.sync_lead_m
    for i in range(lay.n_control):
        t_c = time_at(lay.sync_lead_m + span * (i + 0.5) / lay.n_control)
        side = 1.0 if i % 2 == 0 else -1.0
        targets.append(beside(t_c, side * lay.control_offset_m, f"C{i + 1}", "control"))
    walls: tuple[Wall, ...] = ()
    if len(trajectory) >= 3:
        rate = np.gradient(yaw, trajectory.t_s)
        k = int(np.argmax(np.abs(rate)))
        if abs(rate[k]) > 1e-3:
            heading = yaw[k]
            fwd = np.array([math.cos(heading), math.sin(heading)])
            right = np.array([-math.sin(heading), math.cos(heading)])
            outward = -right if rate[k] > 0 else right  # turning right: the outside is left
            mid = pos[k, :2] + lay.wall_offset_m * outward
            half = 0.5 * lay.wall_length_m * fwd
            walls = (
                Wall(
                    start_ne_m=(float(mid[0] - half[0]), float(mid[1] - half[1])),
                    end_ne_m=(float(mid[0] + half[0]), float(mid[1] + half[1])),
                    top_down_m=ground - lay.wall_height_m,
                    bottom_down_m=ground,
                ),
            )
    return Scene(origin_lat_lon_h=origin, ground_down_m=ground, walls=walls, targets=tuple(targets))
