"""Scenes of the patch-test simulator: a town block (vehicle) and a harbour (vessel).

Both scenes live in one local-level NED frame tangent at ``origin_lat_lon_h`` (m), with
``D = 0`` on the ground (vehicle) or the still-water level (vessel). They are laid out
in *street coordinates* — ``u`` along the street or channel in the direction of the
outbound lines, ``w`` across it to the right of an outbound driver, ``D`` down — and
turned into NED by the street azimuth ``a`` (deg, clockwise from North):
``N = u cos a - w sin a``, ``E = u sin a + w cos a``.

**Vehicle: a town block** (`vehicle_scene`). A flat ground; a 280 m main street along
``u`` (lines from ``u = -140`` to ``+140`` m; outbound lane at ``w = +1.75`` m, return
lane at ``w = -1.75`` m); six closed gable-roofed buildings, three on each side, 5-9 m
to the eaves, set square to the street, turned 35 deg and -40 deg to it, or turned
90 deg (gable end to the street), so that walls face six azimuths and the roof planes
(20-35 deg pitch) face across, along and obliquely to the street; a free-standing
garden wall at the kerb; optionally two 0.25 m spheres on 1.6 m posts at the kerb.

**Vessel: a harbour channel** (`vessel_scene`). A 52 m wide channel along ``u``
(outbound lane ``w = +9`` m, return lane ``w = -9`` m, lines from ``u = -110`` to
``+110`` m): on the right bank a vertical quay wall (2.5 m freeboard) at ``w = +22`` m,
its deck, and a gable-roofed shed turned -25 deg to the quay; on the left bank a shore
sloping up at 15 deg from the waterline at ``w = -30`` m; optionally two 0.4 m spheres on
1.2 m posts 1.2 m behind the quay edge. The water returns nothing (near-infrared is absorbed or
reflected away): returns that hit it are dropped, and it hides whatever lies below it.

Each planar face is one `ScenePlane` (a point, the outward unit normal and the
outline, in the scene frame) cast as one `kinsync.sim.scene.Panel`; each sphere is one
`SceneSphere`. Their ``hit_id`` is what `kinsync.sim.scene.Scene.cast` reports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.frames import ecef_to_ned
from kinsync.sim.scene import Panel, Scene, Target, Vector3

__all__ = [
    "PatchTestScene",
    "PlaneKind",
    "ScenarioLayout",
    "ScenePlane",
    "SceneSphere",
    "street_to_ned",
    "vehicle_scene",
    "vessel_scene",
]

PlaneKind = Literal["ground", "wall", "roof", "shore", "deck"]
"""What a planar feature is."""

_KINDS: tuple[PlaneKind, ...] = ("ground", "wall", "roof", "shore", "deck")


def _vector3(values: Any, name: str) -> Vector3:
    vals = tuple(values)
    if len(vals) != 3:
        msg = f"{name}: expected 3 numbers, got {vals!r}"
        raise InputError(msg)
    x, y, z = (finite_number(v, name) for v in vals)
    return (x, y, z)


@dataclass(frozen=True)
class ScenePlane:
    """A planar face of the scene: where it is, which way it faces, its outline.

    Attributes
    ----------
    name : str
        Unique name, e.g. ``"B2 wall 125"`` (building B2, wall facing azimuth 125 deg).
    kind : {"ground", "wall", "roof", "shore", "deck"}
        What it is.
    point_ned_m : tuple of 3 float
        A point of the plane (the outline's area centroid), scene frame (m).
    normal_ned : tuple of 3 float
        Unit normal, scene frame, pointing to the side the scanner sees it from (out of
        a building, up from the ground, a roof, the shore or the deck, towards the water
        from the quay wall).
    outline_ned_m : tuple of 3-tuples
        Corners of the face in order, scene frame (m); the ground's outline is the area
        the lines scan (the ground plane itself is unbounded).
    hit_id : int
        `kinsync.sim.scene.Scene.cast` id of the face.
    """

    name: str
    kind: PlaneKind
    point_ned_m: Vector3
    normal_ned: Vector3
    outline_ned_m: tuple[Vector3, ...]
    hit_id: int

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            msg = f"plane {self.name!r}: kind must be one of {_KINDS}, got {self.kind!r}"
            raise InputError(msg)
        object.__setattr__(self, "point_ned_m", _vector3(self.point_ned_m, "point_ned_m"))
        n = np.array(_vector3(self.normal_ned, "normal_ned"))
        norm = float(np.linalg.norm(n))
        if abs(norm - 1.0) > 1e-9:
            msg = f"plane {self.name!r}: normal_ned must be a unit vector, |n| = {norm!r}"
            raise InputError(msg)
        outline = tuple(_vector3(v, "outline_ned_m") for v in self.outline_ned_m)
        if len(outline) < 3:
            msg = f"plane {self.name!r}: the outline needs at least 3 corners"
            raise InputError(msg)
        object.__setattr__(self, "outline_ned_m", outline)

    @property
    def offset_m(self) -> float:
        """``normal . x`` of the plane's points (m)."""
        return float(np.dot(self.normal_ned, self.point_ned_m))

    def distance_m(self, xyz_ned_m: FloatArray) -> FloatArray:
        """Signed distance of points to the plane along the normal, shape (N,) (m).

        Parameters
        ----------
        xyz_ned_m : ndarray, shape (N, 3)
            Points in the scene frame (m).
        """
        out: FloatArray = np.asarray(xyz_ned_m, dtype=np.float64) @ np.array(self.normal_ned)
        return out - self.offset_m

    def as_document(self) -> dict[str, Any]:
        """JSON-ready form (``truth.json``)."""
        return {
            "name": self.name,
            "kind": self.kind,
            "hit_id": self.hit_id,
            "point_ned_m": list(self.point_ned_m),
            "normal_ned": list(self.normal_ned),
            "outline_ned_m": [list(v) for v in self.outline_ned_m],
        }


@dataclass(frozen=True)
class SceneSphere:
    """A sphere of known radius (a calibration target on a post).

    Attributes
    ----------
    name : str
        Unique name (``"SP1"``).
    centre_ned_m : tuple of 3 float
        Centre, scene frame (m).
    radius_m : float
        Radius (m), > 0.
    hit_id : int
        `kinsync.sim.scene.Scene.cast` id of the sphere.
    """

    name: str
    centre_ned_m: Vector3
    radius_m: float
    hit_id: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre_ned_m", _vector3(self.centre_ned_m, "centre_ned_m"))
        object.__setattr__(
            self, "radius_m", positive_number(self.radius_m, f"sphere {self.name!r} radius_m")
        )

    def distance_m(self, xyz_ned_m: FloatArray) -> FloatArray:
        """Signed distance of points to the sphere's surface, shape (N,) (m; > 0 outside)."""
        d = np.asarray(xyz_ned_m, dtype=np.float64) - np.array(self.centre_ned_m)
        out: FloatArray = np.linalg.norm(d, axis=1) - self.radius_m
        return out

    def as_document(self) -> dict[str, Any]:
        """JSON-ready form (``truth.json``)."""
        return {
            "name": self.name,
            "hit_id": self.hit_id,
            "centre_ned_m": list(self.centre_ned_m),
            "radius_m": self.radius_m,
        }


@dataclass(frozen=True)
class ScenarioLayout:
    """Where the lines run, in street coordinates (m), and how the platform turns.

    Attributes
    ----------
    line_start_u_m, line_end_u_m : float
        Along-street extent of every line (outbound lines run from start to end).
    outbound_lane_w_m, return_lane_w_m : float
        Across-street position of the outbound and the return lines.
    body_height_m : float
        Height of the body reference point above ``D = 0`` (ground or water).
    lateral_acc_m_s2 : float
        Largest lateral acceleration in the turnarounds (sets their radius from speed).
    min_turn_radius_m : float
        Tightest turnaround radius.
    max_acc_m_s2 : float
        Peak longitudinal acceleration when speeding up and slowing down.
    """

    line_start_u_m: float
    line_end_u_m: float
    outbound_lane_w_m: float
    return_lane_w_m: float
    body_height_m: float
    lateral_acc_m_s2: float
    min_turn_radius_m: float
    max_acc_m_s2: float

    def __post_init__(self) -> None:
        for name in ("line_start_u_m", "line_end_u_m", "outbound_lane_w_m", "return_lane_w_m"):
            finite_number(getattr(self, name), f"scenario layout {name}")
        for name in ("body_height_m", "lateral_acc_m_s2", "min_turn_radius_m", "max_acc_m_s2"):
            positive_number(getattr(self, name), f"scenario layout {name}")
        if self.line_end_u_m <= self.line_start_u_m:
            msg = "scenario layout: line_end_u_m must exceed line_start_u_m"
            raise InputError(msg)
        if self.outbound_lane_w_m <= self.return_lane_w_m:
            msg = "scenario layout: the return lane must lie left of (below) the outbound lane"
            raise InputError(msg)

    @property
    def line_length_m(self) -> float:
        """Length of one line (m)."""
        return self.line_end_u_m - self.line_start_u_m


@dataclass(frozen=True, eq=False)
class PatchTestScene:
    """The scene of a patch test: planar faces and spheres with their casting scene.

    Attributes
    ----------
    scenario : {"vehicle", "vessel"}
    origin_lat_lon_h : tuple of 3 float
        Geodetic origin of the scene frame (deg, deg, m ellipsoidal, WGS84): the local
        NED frame tangent there holds every coordinate below.
    street_azimuth_deg : float
        Azimuth of the outbound direction ``+u`` (deg, clockwise from North).
    layout : ScenarioLayout
        Lines and lanes in street coordinates.
    planes : tuple of ScenePlane
    spheres : tuple of SceneSphere
    scene : kinsync.sim.scene.Scene
        What the beams are cast against (ground plane, panels, spheres).
    water_hit_id : int or None
        Hit id of the water surface, whose returns are dropped (vessel); None on land.
    """

    scenario: str
    origin_lat_lon_h: Vector3
    street_azimuth_deg: float
    layout: ScenarioLayout
    planes: tuple[ScenePlane, ...]
    spheres: tuple[SceneSphere, ...]
    scene: Scene
    water_hit_id: int | None

    @property
    def features(self) -> tuple[ScenePlane | SceneSphere, ...]:
        """Planes, then spheres."""
        return (*self.planes, *self.spheres)

    def feature_name(self, hit_id: int) -> str:
        """Name of the plane or sphere with this hit id (`InputError` if none)."""
        for f in self.features:
            if f.hit_id == hit_id:
                return f.name
        msg = f"scene: no feature has hit id {hit_id}"
        raise InputError(msg)

    def ecef_to_scene(self, pos_ecef_m: FloatArray) -> FloatArray:
        """ECEF positions (N, 3) to the scene frame (local NED at the origin), (N, 3) (m)."""
        return ecef_to_ned(pos_ecef_m, *self.origin_lat_lon_h)

    def street_to_ned(self, uwd_m: FloatArray) -> FloatArray:
        """Street coordinates ``(u, w, D)`` (N, 3) to the scene frame, (N, 3) (m)."""
        return street_to_ned(uwd_m, self.street_azimuth_deg)

    def distance_to_hit_feature_m(self, xyz_ned_m: FloatArray, hit_id: IntArray) -> FloatArray:
        """Distance of each point to the feature it hit (plane: signed; sphere: radial).

        Parameters
        ----------
        xyz_ned_m : ndarray, shape (N, 3)
            Points in the scene frame (m).
        hit_id : ndarray of int, shape (N,)
            What each point hit (`PatchTestSimulation.line_hit_ids`).

        Returns
        -------
        ndarray, shape (N,)
            Distance (m); NaN for a hit id that is no feature.
        """
        xyz = np.asarray(xyz_ned_m, dtype=np.float64)
        out = np.full(xyz.shape[0], np.nan)
        for f in self.features:
            m = hit_id == f.hit_id
            if np.any(m):
                out[m] = f.distance_m(xyz[m])
        return out

    def as_document(self) -> dict[str, Any]:
        """JSON-ready form (``truth.json``)."""
        lay = self.layout
        return {
            "frame": "local NED tangent at origin_lat_lon_h (m); D = 0 on the ground/water",
            "origin_lat_lon_h": list(self.origin_lat_lon_h),
            "street_azimuth_deg": self.street_azimuth_deg,
            "lines_u_m": [lay.line_start_u_m, lay.line_end_u_m],
            "lanes_w_m": {"outbound": lay.outbound_lane_w_m, "return": lay.return_lane_w_m},
            "water_returns_dropped": self.water_hit_id is not None,
            "planes": [p.as_document() for p in self.planes],
            "spheres": [s.as_document() for s in self.spheres],
        }


def street_to_ned(uwd_m: FloatArray, street_azimuth_deg: float) -> FloatArray:
    """Street coordinates ``(u, w, D)`` (N, 3) to NED (N, 3) (m); see the module docstring."""
    a = math.radians(street_azimuth_deg)
    c, s = math.cos(a), math.sin(a)
    p = np.asarray(uwd_m, dtype=np.float64)
    return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])


class _SceneBuilder:
    """Collects faces in street coordinates; orients their normals; numbers them."""

    def __init__(self, street_azimuth_deg: float) -> None:
        self.azimuth_deg = street_azimuth_deg
        self.faces: list[tuple[str, PlaneKind, Panel, FloatArray]] = []
        self.spheres: list[tuple[str, Vector3, float]] = []

    def ned(self, uwd: list[tuple[float, float, float]]) -> FloatArray:
        return street_to_ned(np.array(uwd, dtype=np.float64), self.azimuth_deg)

    def face(
        self,
        label: str,
        kind: PlaneKind,
        corners_uwd: list[tuple[float, float, float]],
        away_from_uwd: tuple[float, float, float],
    ) -> None:
        """Add a face; its normal points away from ``away_from_uwd`` (street coords)."""
        v = self.ned(corners_uwd)
        panel = Panel(tuple((float(p[0]), float(p[1]), float(p[2])) for p in v), label)
        n = panel.normal_ned
        if float(n @ (panel.centroid_ned_m - self.ned([away_from_uwd])[0])) < 0.0:
            n = -n
        self.faces.append((label, kind, panel, n))

    def named(self, prefix: str, kind: PlaneKind, normal_ned: FloatArray) -> str:
        """``"<prefix> <kind> <azimuth of the horizontal normal>"``."""
        az = math.degrees(math.atan2(normal_ned[1], normal_ned[0])) % 360.0
        return f"{prefix} {kind} {az:03.0f}"

    def gable_building(
        self,
        name: str,
        centre_uw: tuple[float, float],
        length_m: float,
        width_m: float,
        axis_deg: float,
        eave_m: float,
        pitch_deg: float,
        base_down_m: float = 0.0,
    ) -> None:
        """A closed building: ridge along ``axis_deg`` (from ``+u`` towards ``+w``).

        Long walls up to the eaves, pentagonal gable ends up to the ridge, two roof
        planes of ``pitch_deg`` meeting at the ridge (no overhang).
        """
        a = math.radians(axis_deg)
        el = np.array([math.cos(a), math.sin(a)])
        et = np.array([-math.sin(a), math.cos(a)])
        c = np.array(centre_uw)
        hl, hw = 0.5 * length_m, 0.5 * width_m
        z0 = base_down_m
        ze = base_down_m - eave_m
        zr = ze - hw * math.tan(math.radians(pitch_deg))
        inside = (float(c[0]), float(c[1]), 0.5 * (z0 + ze))

        def at(s_l: float, s_t: float, z: float) -> tuple[float, float, float]:
            p = c + s_l * el + s_t * et
            return (float(p[0]), float(p[1]), z)

        start = len(self.faces)
        for side in (-1.0, 1.0):
            self.face(
                "",
                "wall",
                [
                    at(-hl, side * hw, z0),
                    at(hl, side * hw, z0),
                    at(hl, side * hw, ze),
                    at(-hl, side * hw, ze),
                ],
                inside,
            )
            self.face(
                "",
                "wall",
                [
                    at(side * hl, -hw, z0),
                    at(side * hl, hw, z0),
                    at(side * hl, hw, ze),
                    at(side * hl, 0.0, zr),
                    at(side * hl, -hw, ze),
                ],
                inside,
            )
            self.face(
                "",
                "roof",
                [at(-hl, side * hw, ze), at(hl, side * hw, ze), at(hl, 0.0, zr), at(-hl, 0.0, zr)],
                inside,
            )
        for i in range(start, len(self.faces)):
            _label, kind, panel, n = self.faces[i]
            self.faces[i] = (self.named(name, kind, n), kind, panel, n)

    def sphere(self, name: str, centre_uwd: tuple[float, float, float], radius_m: float) -> None:
        p = self.ned([centre_uwd])[0]
        self.spheres.append((name, (float(p[0]), float(p[1]), float(p[2])), radius_m))

    def build(
        self,
        scenario: str,
        origin_lat_lon_h: Vector3,
        layout: ScenarioLayout,
        ground: tuple[str, PlaneKind, list[tuple[float, float, float]]] | None,
        water: bool,
    ) -> PatchTestScene:
        panels = tuple(Panel(f[2].vertices_ned_m, f[0]) for f in self.faces)
        targets = tuple(
            Target(name, centre, radius_m=r, kind="control") for name, centre, r in self.spheres
        )
        scene = Scene(
            origin_lat_lon_h=origin_lat_lon_h, ground_down_m=0.0, panels=panels, targets=targets
        )
        planes: list[ScenePlane] = []
        if ground is not None:
            gname, gkind, outline = ground
            v = self.ned(outline)
            planes.append(
                ScenePlane(
                    name=gname,
                    kind=gkind,
                    point_ned_m=_as3(v.mean(axis=0)),
                    normal_ned=(0.0, 0.0, -1.0),
                    outline_ned_m=tuple(_as3(p) for p in v),
                    hit_id=0,
                )
            )
        for k, (label, kind, panel, n) in enumerate(self.faces):
            planes.append(
                ScenePlane(
                    name=label,
                    kind=kind,
                    point_ned_m=_as3(panel.centroid_ned_m),
                    normal_ned=_as3(n),
                    outline_ned_m=panel.vertices_ned_m,
                    hit_id=scene.first_panel_id + k,
                )
            )
        names = [p.name for p in planes] + [s[0] for s in self.spheres]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            msg = f"scene: feature name(s) {dupes} used more than once"
            raise InputError(msg)
        spheres = tuple(
            SceneSphere(name, centre, r, scene.first_target_id + k)
            for k, (name, centre, r) in enumerate(self.spheres)
        )
        return PatchTestScene(
            scenario=scenario,
            origin_lat_lon_h=origin_lat_lon_h,
            street_azimuth_deg=self.azimuth_deg,
            layout=layout,
            planes=tuple(planes),
            spheres=spheres,
            scene=scene,
            water_hit_id=0 if water else None,
        )


def _as3(p: FloatArray) -> Vector3:
    return (float(p[0]), float(p[1]), float(p[2]))


VEHICLE_LAYOUT = ScenarioLayout(
    line_start_u_m=-140.0,
    line_end_u_m=140.0,
    outbound_lane_w_m=1.75,
    return_lane_w_m=-1.75,
    body_height_m=1.0,
    lateral_acc_m_s2=2.5,
    min_turn_radius_m=10.0,
    max_acc_m_s2=1.5,
)
"""Town block: a 280 m main street, lanes 3.5 m apart, turns at up to 2.5 m/s^2."""

VESSEL_LAYOUT = ScenarioLayout(
    line_start_u_m=-110.0,
    line_end_u_m=110.0,
    outbound_lane_w_m=9.0,
    return_lane_w_m=-9.0,
    body_height_m=0.5,
    lateral_acc_m_s2=0.6,
    min_turn_radius_m=15.0,
    max_acc_m_s2=0.3,
)
"""Harbour channel: 220 m lines 18 m apart, turns at up to 0.6 m/s^2."""

# (name, centre u, centre w, length, width, ridge axis from +u (deg), eaves, roof pitch)
_TOWN_BUILDINGS: tuple[tuple[str, float, float, float, float, float, float, float], ...] = (
    ("B1", -75.0, 16.0, 36.0, 12.0, 0.0, 6.0, 35.0),
    ("B2", -15.0, 21.0, 24.0, 14.0, 35.0, 8.0, 25.0),
    ("B3", 50.0, 17.0, 20.0, 14.0, 90.0, 6.0, 30.0),
    ("B4", -50.0, -18.0, 30.0, 12.0, 0.0, 6.0, 35.0),
    ("B5", 20.0, -20.0, 22.0, 14.0, -40.0, 9.0, 20.0),
    ("B6", 85.0, -16.0, 18.0, 12.0, 90.0, 5.0, 30.0),
)


def vehicle_scene(
    origin_lat_lon_h: Vector3,
    street_azimuth_deg: float,
    *,
    spheres: bool,
    ground_margin_m: float,
) -> PatchTestScene:
    """The town block of the vehicle scenario (see the module docstring).

    Parameters
    ----------
    origin_lat_lon_h : tuple of 3 float
        Geodetic origin of the scene frame, on the ground at the street's centre.
    street_azimuth_deg : float
        Azimuth of the outbound direction (deg).
    spheres : bool
        Add two 0.25 m spheres on posts at the kerb.
    ground_margin_m : float
        The ground feature's outline reaches this far beyond the lines (m).
    """
    b = _SceneBuilder(street_azimuth_deg)
    for name, u, w, length, width, axis, eave, pitch in _TOWN_BUILDINGS:
        b.gable_building(name, (u, w), length, width, axis, eave, pitch)
    b.face(
        "G1 wall",
        "wall",
        [(95.0, 7.0, 0.0), (125.0, 8.5, 0.0), (125.0, 8.5, -1.8), (95.0, 7.0, -1.8)],
        (110.0, 30.0, -0.9),
    )
    if spheres:
        b.sphere("SP1", (-35.0, 6.5, -1.6), 0.25)
        b.sphere("SP2", (60.0, -6.5, -1.6), 0.25)
    lay = VEHICLE_LAYOUT
    r = ground_margin_m
    ground = [
        (lay.line_start_u_m - r, -r, 0.0),
        (lay.line_end_u_m + r, -r, 0.0),
        (lay.line_end_u_m + r, r, 0.0),
        (lay.line_start_u_m - r, r, 0.0),
    ]
    return b.build("vehicle", origin_lat_lon_h, lay, ("ground", "ground", ground), water=False)


def vessel_scene(
    origin_lat_lon_h: Vector3,
    street_azimuth_deg: float,
    *,
    spheres: bool,
) -> PatchTestScene:
    """The harbour channel of the vessel scenario (see the module docstring).

    Parameters
    ----------
    origin_lat_lon_h : tuple of 3 float
        Geodetic origin of the scene frame, at the still-water level mid-channel.
    street_azimuth_deg : float
        Azimuth of the outbound direction along the channel (deg).
    spheres : bool
        Add two 0.4 m spheres on posts at the quay edge.
    """
    b = _SceneBuilder(street_azimuth_deg)
    quay_w, freeboard = 22.0, 2.5
    b.face(
        "quay wall",
        "wall",
        [
            (-120.0, quay_w, 0.0),
            (120.0, quay_w, 0.0),
            (120.0, quay_w, -freeboard),
            (-120.0, quay_w, -freeboard),
        ],
        (0.0, quay_w + 10.0, -1.0),
    )
    b.face(
        "quay deck",
        "deck",
        [
            (-120.0, quay_w, -freeboard),
            (120.0, quay_w, -freeboard),
            (120.0, 75.0, -freeboard),
            (-120.0, 75.0, -freeboard),
        ],
        (0.0, 40.0, 0.0),
    )
    b.gable_building("shed", (15.0, 45.0), 40.0, 16.0, -25.0, 7.0, 18.0, base_down_m=-freeboard)
    shore_w, slope_deg, run_m = -30.0, 15.0, 40.0
    top = -run_m * math.tan(math.radians(slope_deg))
    b.face(
        "shore",
        "shore",
        [
            (-140.0, shore_w, 0.0),
            (140.0, shore_w, 0.0),
            (140.0, shore_w - run_m, top),
            (-140.0, shore_w - run_m, top),
        ],
        (0.0, shore_w, 10.0),
    )
    if spheres:
        b.sphere("SP1", (-50.0, quay_w + 1.2, -freeboard - 1.2), 0.4)
        b.sphere("SP2", (60.0, quay_w + 1.2, -freeboard - 1.2), 0.4)
    return b.build("vessel", origin_lat_lon_h, VESSEL_LAYOUT, None, water=True)
