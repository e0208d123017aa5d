"""Planar patches found automatically where lines overlap: ground, walls, roofs.

With the starting mount every line is georeferenced into the local frame and cut
into cubic voxels. For each (voxel, line) the returns' principal axes give a local
plane: its normal (smallest axis), its thickness (square root of the smallest
variance) and its extent (the middle variance: a pole or an edge is not a plane). A
voxel is a patch candidate when at least two lines each see it flat (thickness below
``max_thickness_m``), with normals within ``max_normal_angle_deg`` of each other and
offsets along the normal within ``max_line_offset_m`` (what a wrong mount can
separate, but not a car that moved between the lines). Vegetation, cars, people and
water fail one of these tests.

Neighbouring candidates (26-neighbourhood) with the same plane are merged (region
growing), so a wall or a roof becomes one patch with one plane for all lines that see
it. Patches are then chosen for geometry, not quantity: the largest of each
orientation class (near-horizontal; walls by azimuth modulo 180 deg, slopes by azimuth),
at most ``max_patches_per_class`` each (twice that per wall class), so that flat ground
cannot drown the walls that carry the heading and the roofs that carry the pitch.
Every (patch, line) keeps at most ``max_points_per_line`` returns, drawn at random,
seeded by the line and its returns (`kinsync.calibration.features.thin_returns`: the
same whatever the order of the lines): millions of returns become a few thousand per
patch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.adjustment import Observation
from kinsync.calibration.features import PlaneFeature, plane_from_points, thin_returns
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.errors import InputError
from kinsync.robust import robust_sigma

__all__ = ["PatchOptions", "PlanePatches", "find_plane_patches"]


@dataclass(frozen=True)
class PatchOptions:
    """Settings of the patch search.

    Attributes
    ----------
    voxel_m : float
        Edge of the voxels (m).
    min_points_per_line : int
        Returns a line needs in a voxel to count.
    max_thickness_m : float
        Largest thickness of a line's returns in a voxel (m).
    min_extent_m : float
        Smallest in-plane extent (m, standard deviation along the middle axis).
    max_normal_angle_deg : float
        Largest angle between two lines' normals in a voxel (deg).
    max_line_offset_m : float
        Largest offset between two lines' planes in a voxel (m).
    max_patch_m : float
        Largest distance of a voxel from its patch's seed (m): patches stay local, so
        that a road's camber or a slope's bend does not become a plane's residual.
    max_patches_per_class : int
        Patches kept per orientation class (twice as many per class of walls, whose
        classes span 180 deg of azimuth where slopes' span 360 deg).
    max_points_per_line : int
        Returns kept per (patch, line).
    min_lines : int
        Lines that must see a patch.
    seed : int
        Seed of the random thinning.
    """

    voxel_m: float = 2.0
    min_points_per_line: int = 15
    max_thickness_m: float = 0.05
    min_extent_m: float = 0.3
    max_normal_angle_deg: float = 10.0
    max_line_offset_m: float = 1.0
    max_patch_m: float = 12.0
    max_patches_per_class: int = 12
    max_points_per_line: int = 200
    min_lines: int = 2
    seed: int = 0

    def __post_init__(self) -> None:
        for name in (
            "voxel_m",
            "max_thickness_m",
            "min_extent_m",
            "max_line_offset_m",
            "max_patch_m",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                msg = f"patch option {name} must be a positive number, got {v!r}"
                raise InputError(msg)
        for name in ("min_points_per_line", "max_patches_per_class", "max_points_per_line"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 3):
                msg = f"patch option {name} must be an integer >= 3, got {v!r}"
                raise InputError(msg)
        if not (isinstance(self.min_lines, int) and self.min_lines >= 1):
            msg = f"patch option min_lines must be an integer >= 1, got {self.min_lines!r}"
            raise InputError(msg)


@dataclass(frozen=True, eq=False)
class PlanePatches:
    """The patches found, ready for the adjustment.

    Attributes
    ----------
    features : tuple of PlaneFeature
        One plane per patch, fitted with the starting mount.
    observations : tuple of Observation
        The thinned returns of each line on each patch.
    n_candidates : int
        Voxels that passed the flatness and overlap tests.
    n_patches_found : int
        Patches after merging, before the choice by orientation.
    """

    features: tuple[PlaneFeature, ...]
    observations: tuple[Observation, ...]
    n_candidates: int
    n_patches_found: int


@dataclass
class _Voxels:
    """Per (voxel, line) statistics of every line's returns."""

    keys: IntArray  # voxel key of each group
    line: IntArray  # line of each group
    count: IntArray
    centroid: FloatArray  # (g, 3)
    normal: FloatArray  # (g, 3)
    thickness: FloatArray  # (g,)
    extent: FloatArray  # (g,)


def _voxel_key(ijk: IntArray) -> IntArray:
    """One int64 per voxel index triple (21 bits each, offset to be positive)."""
    off = ijk + (1 << 20)
    key: IntArray = (off[:, 0] << 42) | (off[:, 1] << 21) | off[:, 2]
    return key


def _unkey(key: IntArray) -> IntArray:
    mask = (1 << 21) - 1
    out: IntArray = np.column_stack([(key >> 42) & mask, (key >> 21) & mask, key & mask])
    return out - (1 << 20)


def _group_stats(
    x: FloatArray, line: IntArray, voxel_m: float
) -> tuple[_Voxels, IntArray, IntArray]:
    """Statistics per (voxel, line); also each return's voxel key and group index.

    ``line`` (n,): each return's line, never decreasing (the returns line by line).
    """
    ijk = np.floor(x / voxel_m).astype(np.int64)
    vkey = _voxel_key(ijk)
    # Groups in (voxel, line) order from one stable sort: the returns come line by
    # line (``line`` never decreases), so a stable sort by voxel keeps its lines in order.
    order = np.argsort(vkey, kind="stable")
    k_sorted, l_sorted = vkey[order], line[order]
    new_group = np.empty(order.size, dtype=np.bool_)
    new_group[:1] = True
    new_group[1:] = (k_sorted[1:] != k_sorted[:-1]) | (l_sorted[1:] != l_sorted[:-1])
    first = np.flatnonzero(new_group)
    inverse = np.empty(order.size, dtype=np.int64)
    inverse[order] = np.cumsum(new_group) - 1
    count = np.bincount(inverse)
    corner = ijk * voxel_m
    rel = x - corner  # small numbers: sums of squares stay exact enough
    sums = np.column_stack([np.bincount(inverse, rel[:, j]) for j in range(3)])
    mean = sums / count[:, None]
    sq = np.empty((first.size, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            sq[:, a, b] = sq[:, b, a] = np.bincount(inverse, rel[:, a] * rel[:, b]) / count
    cov = sq - mean[:, :, None] * mean[:, None, :]
    w, v = np.linalg.eigh(cov)
    group_voxel = k_sorted[first]
    vox_corner = _unkey(group_voxel) * voxel_m
    stats = _Voxels(
        keys=group_voxel,
        line=l_sorted[first].astype(np.int64),
        count=count,
        centroid=mean + vox_corner,
        normal=v[:, :, 0],
        thickness=np.sqrt(np.maximum(w[:, 0], 0.0)),
        extent=np.sqrt(np.maximum(w[:, 1], 0.0)),
    )
    return stats, vkey, inverse


def _flat(st: _Voxels, opt: PatchOptions) -> NDArray[np.bool_]:
    """Which (voxel, line) groups are flat: enough returns, thin, spread out."""
    flat: NDArray[np.bool_] = (
        (st.count >= opt.min_points_per_line)
        & (st.thickness <= opt.max_thickness_m)
        & (st.extent >= opt.min_extent_m)
    )
    return flat


def _candidates(st: _Voxels, opt: PatchOptions) -> tuple[IntArray, FloatArray, FloatArray]:
    """Voxels seen flat by enough lines that agree: keys, mean normal, mean centroid."""
    idx = np.flatnonzero(_flat(st, opt))
    if idx.size == 0:
        return np.empty(0, np.int64), np.empty((0, 3)), np.empty((0, 3))
    order = idx[np.argsort(st.keys[idx], kind="stable")]
    keys = st.keys[order]
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    ends = np.r_[starts[1:], keys.size]
    cos_max = math.cos(math.radians(opt.max_normal_angle_deg))
    out_k, out_n, out_c = [], [], []
    for s, e in zip(starts, ends, strict=True):
        if e - s < opt.min_lines:
            continue
        members = order[s:e]
        normals = st.normal[members]
        ref = normals[np.argmax(st.count[members])]
        normals = normals * np.sign(normals @ ref)[:, None]
        if np.min(normals @ ref) < cos_max:
            continue
        n = normals.mean(axis=0)
        n /= np.linalg.norm(n)
        offsets = st.centroid[members] @ n
        if np.ptp(offsets) > opt.max_line_offset_m:
            continue
        out_k.append(keys[s])
        out_n.append(n)
        out_c.append(st.centroid[members].mean(axis=0))
    return np.array(out_k, dtype=np.int64), np.array(out_n), np.array(out_c)


def _merge(
    keys: IntArray, normals: FloatArray, centroids: FloatArray, opt: PatchOptions
) -> IntArray:
    """Seeded region growing: a label per candidate voxel; a region is one plane.

    Seeds are taken in key order; a neighbouring candidate (26-neighbourhood) joins the
    region when its normal is within ``max_normal_angle_deg`` of the seed's and its
    centroid lies on the seed's plane (within 4 thicknesses or a tenth of a voxel), so
    that a region cannot drift round an edge or along a curved surface.
    """
    where = {int(k): i for i, k in enumerate(keys)}
    ijk = _unkey(keys)
    cos_max = math.cos(math.radians(opt.max_normal_angle_deg))
    tol = max(opt.max_thickness_m * 4.0, 0.1 * opt.voxel_m)
    steps = np.array(
        [
            (a, b, c)
            for a in (-1, 0, 1)
            for b in (-1, 0, 1)
            for c in (-1, 0, 1)
            if (a, b, c) != (0, 0, 0)
        ]
    )
    labels = np.full(keys.size, -1, dtype=np.int64)
    for seed in range(keys.size):
        if labels[seed] >= 0:
            continue
        labels[seed] = seed
        n0, c0 = normals[seed], centroids[seed]
        queue = [seed]
        while queue:
            i = queue.pop()
            for nb in _voxel_key(ijk[i] + steps):
                j = where.get(int(nb))
                if j is None or labels[j] >= 0:
                    continue
                rel = centroids[j] - c0
                if abs(normals[j] @ n0) < cos_max or abs(rel @ n0) > tol:
                    continue
                if float(np.linalg.norm(rel)) > opt.max_patch_m:
                    continue
                labels[j] = seed
                queue.append(j)
    return labels


_WALL_CLASSES = range(1, 13)
"""The orientation classes of walls (`_orientation_class`)."""


def _orientation_class(normal: FloatArray) -> int:
    """The orientation class of a plane from its unit normal (local NED).

    0: near-horizontal (tilt below 15 deg). 1 + sector: walls (tilt above 75 deg), by the
    normal's azimuth modulo 180 deg in 15 deg sectors: a wall's normal has no sign, and
    orienting it by its tiny vertical component (as slopes are) put the patches of one
    quay wall into two opposite classes by chance (15 and 5 of them at one placement of
    the voxel grid, 21 and 0 at another). 13 + sector: slopes, by the azimuth of the
    downward normal in 30 deg sectors.
    """
    tilt = math.degrees(math.acos(min(1.0, abs(float(normal[2])))))
    if tilt < 15.0:
        return 0
    if tilt > 75.0:
        return 1 + int((math.degrees(math.atan2(normal[1], normal[0])) % 180.0) // 15.0)
    n = normal if normal[2] <= 0 else -normal
    return 13 + int((math.degrees(math.atan2(n[1], n[0])) % 360.0) // 30.0)


def _flat_returns(x_all: FloatArray, idx: IntArray, opt: PatchOptions) -> IntArray | None:
    """One line's returns on a patch that lie on its plane (3 robust sigmas), or None.

    The plane is fitted by total least squares, twice (the second time without the
    returns beyond 3 robust sigmas); the line is dropped from the patch when its
    returns are too few or not flat (robust sigma above ``max_thickness_m``).
    """
    if idx.size < opt.min_points_per_line:
        return None
    keep = idx
    for _ in range(2):
        x = x_all[keep]
        centroid = x.mean(axis=0)
        normal = np.linalg.svd(x - centroid, full_matrices=False)[2][2]
        dist = (x_all[idx] - centroid) @ normal
        sigma = robust_sigma(dist - np.median(dist))
        keep = idx[np.abs(dist - np.median(dist)) <= max(3.0 * sigma, 1e-3)]
        if keep.size < opt.min_points_per_line:
            return None
    if sigma > opt.max_thickness_m:
        return None
    out: IntArray = keep
    return out


def _lines_agree(parts: list[FloatArray], opt: PatchOptions) -> bool:
    """Every line's plane within the normal angle and the offset of the first line's."""
    planes = [plane_from_points(x) for x in parts]
    ref = planes[0]
    cos_max = math.cos(math.radians(opt.max_normal_angle_deg))
    for pl, x in zip(planes[1:], parts[1:], strict=True):
        if abs(float(pl.normal @ ref.normal)) < cos_max:
            return False
        if abs(float(np.median(ref.residuals(x)))) > opt.max_line_offset_m:
            return False
    return True


def find_plane_patches(
    models: Sequence[LineModel],
    values: FloatArray,
    frame: LocalFrame,
    options: PatchOptions | None = None,
) -> PlanePatches:
    """Find planar patches seen by several lines, with the returns of each line on each.

    Parameters
    ----------
    models : sequence of LineModel
        The lines (all their returns are searched).
    values : ndarray, shape (7,)
        The starting mount parameters (rad, m, s).
    frame : LocalFrame
        Frame of the features.
    options : PatchOptions, optional

    Returns
    -------
    PlanePatches

    Raises
    ------
    InputError
        No patch seen by two lines (no overlap, or no flat surface).
    """
    opt = options or PatchOptions()
    xs, lines = [], []
    for li, model in enumerate(models):
        x = model.points(None, values, frame)
        xs.append(x)
        lines.append(np.full(x.shape[0], li, dtype=np.int64))
    x_all = np.concatenate(xs)
    line_all = np.concatenate(lines)
    ok = np.all(np.isfinite(x_all), axis=1)
    stats, vkey, _ = _group_stats(x_all[ok], line_all[ok], opt.voxel_m)
    keys, normals, centroids = _candidates(stats, opt)
    if keys.size == 0:
        raise _no_candidates(stats, opt, len(models))
    labels = _merge(keys, normals, centroids, opt)
    return _select(models, x_all, line_all, ok, vkey, keys, labels, normals, opt)


def _no_candidates(st: _Voxels, opt: PatchOptions, n_lines: int) -> InputError:
    """Why no voxel was a candidate: nothing flat at all, or no overlap."""
    with_flat = np.unique(st.line[_flat(st, opt)])
    if with_flat.size == 0:
        return InputError(
            f"no flat surface found in any of the {n_lines} lines (no {opt.voxel_m:g} m cell "
            f"(--patch-voxel-m) holds {opt.min_points_per_line} or more returns "
            f"(--patch-min-points-per-line) within {opt.max_thickness_m * 100:g} cm of a plane "
            "(--patch-max-thickness-m)): the returns are too sparse or not on surfaces "
            "(ground, walls, roofs); check that the points are the scanner's own frame (not "
            "georeferenced) and the file's units. These settings need about "
            f"{opt.min_points_per_line / opt.voxel_m**2:.3g} returns per m2 in each line; for "
            "sparser lines give larger cells or fewer returns"
        )
    return InputError(
        f"flat surfaces found in {with_flat.size} of {n_lines} lines, but none seen by "
        f"{opt.min_lines} lines: the lines do not overlap (check that the files are lines of "
        "one survey over the same area, and that the trajectory and the starting mount "
        "match them)"
    )


def _capped(by_class: dict[int, list[int]], max_per_class: int) -> list[int]:
    """The first ``max_per_class`` patches of each class, twice that of a wall class.

    A wall class has twice the share because its twelve 15 deg sectors span 180 deg
    only (a wall's normal points either way), where a slope's sectors span 360 deg.
    """
    return [
        p
        for c, ps in by_class.items()
        for p in ps[: max_per_class * (2 if c in _WALL_CLASSES else 1)]
    ]


def _select(
    models: Sequence[LineModel],
    x_all: FloatArray,
    line_all: IntArray,
    ok: FloatArray,
    vkey_ok: IntArray,
    keys: IntArray,
    labels: IntArray,
    normals: FloatArray,
    opt: PatchOptions,
) -> PlanePatches:
    """Choose patches by orientation class and size; thin their returns per line."""
    pos = np.clip(np.searchsorted(keys, vkey_ok), 0, keys.size - 1)
    point_label = np.where(keys[pos] == vkey_ok, labels[pos], -1)
    ok_idx = np.flatnonzero(ok)
    offsets = np.cumsum([0] + [m.line.t_s.size for m in models])
    labelled = np.flatnonzero(point_label >= 0)
    order = labelled[np.argsort(point_label[labelled], kind="stable")]
    sorted_labels = point_label[order]
    patches, first, sizes = np.unique(sorted_labels, return_index=True, return_counts=True)
    members_of = {
        int(p): ok_idx[order[f : f + n]] for p, f, n in zip(patches, first, sizes, strict=True)
    }
    normal_of = {int(p): normals[np.flatnonzero(labels == p)[0]] for p in patches}
    by_class: dict[int, list[int]] = {}
    for p in sorted(members_of, key=lambda q: -members_of[q].size):
        by_class.setdefault(_orientation_class(normal_of[p]), []).append(p)
    chosen = _capped(by_class, opt.max_patches_per_class)
    features: list[PlaneFeature] = []
    observations: list[Observation] = []
    for p in chosen:
        members = members_of[p]
        per_line = []
        for li in np.unique(line_all[members]):
            idx = _flat_returns(x_all, members[line_all[members] == li], opt)
            if idx is None:
                continue
            idx = idx - offsets[li]
            line = models[li].line
            idx = thin_returns(idx, opt.max_points_per_line, opt.seed, line.t_s, line.xyz_scanner_m)
            per_line.append((int(li), idx))
        if len(per_line) < opt.min_lines or not _lines_agree(
            [x_all[offsets[li] + idx] for li, idx in per_line], opt
        ):
            continue
        fid = len(features)
        pts = np.concatenate([x_all[offsets[li] + idx] for li, idx in per_line])
        features.append(plane_from_points(pts))
        observations.extend(Observation(li, fid, idx) for li, idx in per_line)
    if not features:
        msg = f"no flat surface is seen by {opt.min_lines} lines with enough returns"
        raise InputError(msg)
    return PlanePatches(
        features=tuple(features),
        observations=tuple(observations),
        n_candidates=int(keys.size),
        n_patches_found=int(patches.size),
    )
