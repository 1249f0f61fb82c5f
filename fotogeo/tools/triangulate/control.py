"""Automatic ground control for a block from reference orthophotos and a DEM (issue 13).

A new flight over an area that has an orthophoto needs no surveyed GCPs: the registration
pipeline already matches a frame to an orthophoto, and the DEM gives those matches heights,
which makes them 3-D control points (Dihkan 2019 for the matching; the terrain-aware fit of
:mod:`fotogeo.orientation.terrain` for the robust selection).

Signature (what :func:`fotogeo.tools.triangulate.triangulate` merges as control)::

    automatic_control(frames, names, camera, eos, reference, dem, crs, *,
                      per_frame=90, cells=3, options=None, progress=None) -> GcpList

* ``frames`` — frame raster paths; ``names`` — their keys (:func:`fotogeo.io.block.frame_key`);
* ``camera`` — the :class:`~fotogeo.geometry.camera.FrameCamera`; ``eos`` — the approximate
  exterior orientations in ``crs`` (used for footprints only: which reference tile to match);
* ``reference`` — one orthophoto path, a VRT, or a list of tiles (any CRS each);
* ``dem`` — a DEM path or :class:`~fotogeo.geometry.dem.Dem` (any CRS);
* ``crs`` — the block's projected map CRS; the GCPs' ground coordinates are given in it;
* returns a :class:`fotogeo.io.block.GcpList` — the structure ``read_gcp_list`` returns
  (``crs`` as text, ``name``, ``ground`` (n, 3), ``pixel`` (n, 2) corner convention, ``frame``
  keys; one row per image measurement).

Per frame:

1. the frame's footprint (approximate orientation, plane of the DEM's mean height) selects the
   reference tiles it overlaps; each is matched to the frame with
   :func:`fotogeo.tools.register.match.find_tie_points` (PCA fusion, SURF, ratio test, mutual check);
2. reference pixels -> reference map -> ``crs`` (:func:`fotogeo.crs.transform_points`), heights
   from the DEM (:class:`fotogeo.geometry.dem.DemSampler`, bilinear); matches without a height
   are dropped;
3. the matches of all tiles go through the registration's robust terrain fit
   (:func:`fotogeo.orientation.terrain.fit_terrain` with the collinearity model and the
   camera: homography RANSAC, Tukey refit, DLT relief filter) — its inliers are the candidates.

Across frames: the reference keypoints are detected identically for every frame matched to a
tile, so a reference keypoint (tile, position) matched in several frames is one GCP with
several image measurements; and a feature matched in two overlapping tiles — two keypoints
whose measurements in one frame lie within a pixel (:func:`merge_points`) — is one GCP too
(the mean of its two ground positions). One measurement per GCP and frame (the smallest fit
residual). Thinning (Gruber's positions, generalised): every frame is cut into ``cells x
cells`` regions with a budget of ``per_frame / cells²`` points each; candidates are taken in
order of (more frames first, smaller fit residual), and one is kept while any of its
measurements falls in a region still below its budget
(:func:`fotogeo.tools.triangulate.match.thin_to_budget`) — so the control is spread over
every frame and multi-ray points come first.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...crs import parse_crs, pixel_size_in, require_projected, transform_points
from ...errors import FotogeoError, InputError, MatchingError
from ...geometry.camera import OrientedFrame
from ...geometry.dem import Dem, DemSampler
from ...io.block import GcpList
from ...io.raster import open_raster, read_dem
from ...options import RegisterOptions
from ...pixels import outline, pixel_to_map
from ...progress import as_progress
from ..register.match import find_tie_points
from .match import image_regions, thin_to_budget


def _references(reference) -> list:
    refs = [reference] if isinstance(reference, (str, bytes)) or hasattr(reference, "__fspath__") else list(reference)
    if not refs:
        raise InputError("reference: give at least one orthophoto (a file, several tiles or a VRT)")
    infos = [open_raster(r, "reference") for r in refs]
    for info in infos:
        if not info.georeferenced:
            raise InputError(f"reference {str(info.path)!r} has no georeference (CRS and geotransform); automatic "
                             f"control needs a georeferenced orthophoto")
    return infos


def _footprint(camera, eo, height):
    """The frame's outline on the plane at ``height`` (shapely polygon in the block CRS) or None."""
    from shapely.geometry import Polygon
    w, h = camera.image_size
    g = OrientedFrame(camera, eo).pixel_to_world_at(outline(w, h, 8), height)
    return Polygon(g[:, :2]) if np.isfinite(g).all() else None


def _tile_outline(info, crs):
    """The reference tile's outline in the block CRS (shapely polygon)."""
    from shapely.geometry import Polygon
    edge = pixel_to_map(info.transform, outline(info.width, info.height, 8))
    return Polygon(transform_points(info.crs, crs, edge))


def _frame_matches(frame_info, tiles, tile_ids, crs, heights, opts, prog):
    """Matches of one frame with the reference tiles it overlaps: ``(frame px, XYZ, tile id, ref px, ref step m)``."""
    px, xyz, tile, ref_xy, steps = [], [], [], [], []
    for k, (t, info) in enumerate(zip(tile_ids, tiles)):
        try:
            f_xy, r_xy, _ = find_tie_points(info, frame_info, opts, prog.stage(k / len(tiles), (k + 1) / len(tiles),
                                                                             f"matching with {info.path.name}"))
        except MatchingError:
            continue
        XY = transform_points(info.crs, crs, pixel_to_map(info.transform, r_xy))
        Z = heights.heights(XY)
        ok = np.isfinite(Z)
        px.append(f_xy[ok])
        xyz.append(np.column_stack([XY[ok], Z[ok]]))
        tile.append(np.full(int(ok.sum()), t))
        ref_xy.append(r_xy[ok])
        steps.append(pixel_size_in(info.transform, info.crs, crs, info.width / 2, info.height / 2))
    if not px:
        return None
    return np.concatenate(px), np.concatenate(xyz), np.concatenate(tile), np.concatenate(ref_xy), max(steps)


def _robust_fit(px, xyz, camera, step, opts):
    """The registration's terrain fit (module docstring, step 3): its inliers, their residuals (px), the
    fitted collinearity model (the frame's pose)."""
    from ...orientation.terrain import fit_terrain
    fit = fit_terrain(px, xyz, model="collinearity", camera=camera, threshold_m=opts.ransac_threshold * step,
                      min_sigma_m=step, check_fraction=0.0, rng=opts.seed)
    return fit.inliers, np.hypot(*fit.residual_px.T), fit.model


def _crs_text(crs) -> str:
    auth = crs.to_authority()
    return f"{auth[0]}:{auth[1]}" if auth else crs.to_wkt()


def merge_points(frame, px, tile, ref_xy, same_px: float = 1.0) -> np.ndarray:
    """Point id (n,) of every measurement: one per (tile, reference keypoint), and one for the keypoints of
    different tiles whose measurements in a frame lie within ``same_px`` of each other (the same feature
    in two overlapping tiles).

    >>> merge_points(np.array([0, 0, 1]), np.array([[5.0, 5.0], [5.3, 5.0], [9.0, 9.0]]), np.array([0, 1, 0]),
    ...              np.array([[1.0, 1.0], [7.0, 7.0], [1.0, 1.0]])).tolist()
    [0, 0, 0]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    _, point = np.unique(np.column_stack([tile, np.round(ref_xy, 3)]), axis=0, return_inverse=True)
    point = point.ravel()
    a, b = [point[:0]], [point[:0]]
    for f in np.unique(frame):
        m = np.flatnonzero(frame == f)
        pairs = cKDTree(px[m]).query_pairs(same_px, output_type="ndarray")
        pairs = pairs[tile[m[pairs[:, 0]]] != tile[m[pairs[:, 1]]]]
        a.append(point[m[pairs[:, 0]]])
        b.append(point[m[pairs[:, 1]]])
    a, b = np.concatenate(a), np.concatenate(b)
    n = int(point.max()) + 1
    _, label = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)), directed=False)
    return label[point]


@dataclass(frozen=True)
class FrameFit:
    """One frame's registration to the reference: the fitted pose (None when it failed and why), matches,
    inliers and tiles."""

    name: str
    model: object = None  # the fitted Collinearity (its ``frame.eo`` is the pose), or None
    matches: int = 0
    inliers: int = 0
    tiles: tuple = ()
    reason: str = ""


#: a frame of unknown attitude may be tilted up to this (degrees): its tiles are those within reach of such a view
MAX_UNKNOWN_TILT = 45.0


def reach_disc(camera, eo, mean_h):
    """Where a camera at ``eo``'s projection centre but of unknown attitude can see the plane at ``mean_h``: the
    disc of radius ``(Z − h)·tan(θ + t)`` about its nadir, ``θ`` the half field of view along the image diagonal
    and ``t`` :data:`MAX_UNKNOWN_TILT` (shapely polygon), or None below the plane."""
    from shapely.geometry import Point
    w, h = camera.image_size
    theta = np.arctan(0.5 * np.hypot(w, h) / float(camera.fx))
    height = eo.Z - mean_h
    if not height > 0:
        return None
    return Point(eo.X, eo.Y).buffer(height * np.tan(min(theta + np.radians(MAX_UNKNOWN_TILT), np.radians(85.0))))


def _near_tiles(info, camera, eo, mean_h, outlines, crs, level: bool = False) -> list:
    """The reference tiles a frame overlaps: its footprint under ``eo`` (``level``: its attitude unknown, the
    :func:`reach_disc` of its position); ``eo`` None: under the frame raster's own approximate georeference,
    and every tile when it has none or it meets none."""
    from shapely.geometry import Polygon
    if eo is not None:
        foot = reach_disc(camera, eo, mean_h) if level else _footprint(camera, eo, mean_h)
        return [k for k, o in enumerate(outlines) if foot is not None and o.intersects(foot)]
    near = []
    if info.georeferenced:
        foot = Polygon(transform_points(info.crs, crs, pixel_to_map(info.transform, outline(info.width, info.height, 8))))
        near = [k for k, o in enumerate(outlines) if foot.is_valid and o.intersects(foot)]
    return near or list(range(len(outlines)))


def _candidates(frames, names, camera, eos, tiles, crs, heights, mean_h, opts, prog, fits, level):
    """Inlier matches of every frame with its reference tiles: ``(frame, px, XYZ, tile, ref px, residual px)``;
    every frame's :class:`FrameFit` goes into ``fits``."""
    outlines = [_tile_outline(info, crs) for info in tiles]
    rows = []
    for i, f in enumerate(frames):
        stage = prog.stage(i / len(frames), (i + 1) / len(frames), f"control for frame {names[i]}")
        info = open_raster(f, "frame")
        near = _near_tiles(info, camera, eos[i], mean_h, outlines, crs, bool(level and level[i]))
        got = _frame_matches(info, [tiles[k] for k in near], near, crs, heights, opts, stage) if near else None
        used = tuple(tiles[k].path.name for k in near)
        if got is None:
            why = "no reference tile under its footprint" if not near else "no matches with the reference"
            fits[names[i]] = FrameFit(names[i], tiles=used, reason=why)
            continue
        px, xyz, tile, ref_xy, step = got
        try:
            inl, res, model = _robust_fit(px, xyz, camera, step, opts)
        except FotogeoError as e:
            fits[names[i]] = FrameFit(names[i], matches=len(px), tiles=used, reason=str(e).split(";")[0][:160])
            continue
        fits[names[i]] = FrameFit(names[i], model, len(px), int(inl.sum()), used)
        rows.append((np.full(int(inl.sum()), i), px[inl], xyz[inl], tile[inl], ref_xy[inl], res[inl]))
    if not rows:
        tried = [fits[n] for n in names]
        said = ", ".join(f"{t.name} {t.matches}" for t in tried[:12]) + (f" and {len(tried) - 12} more"
                                                                           if len(tried) > 12 else "")
        why = f"{tried[0].name}: {tried[0].reason}"[:160]  # the others' reasons alike or in report.json
        raise MatchingError(f"no frame could be matched to the reference {', '.join(str(t.path) for t in tiles[:3])} "
                            f"({len(tried)} frame(s) tried, matches: {said}; {why}); check that the orthophoto covers "
                            f"the frames and the approximate orientation")
    return (np.concatenate(c) for c in zip(*rows))


def automatic_control(frames, names, camera, eos, reference, dem, crs, *, per_frame: int = 90, cells: int = 3,
                      options: RegisterOptions | None = None, progress=None) -> GcpList:
    """Control points of the block from ``reference`` orthophoto(s) and ``dem`` (module docstring)."""
    return control_and_fits(frames, names, camera, eos, reference, dem, crs, per_frame=per_frame, cells=cells,
                            options=options, progress=progress)[0]


def control_and_fits(frames, names, camera, eos, reference, dem, crs, *, per_frame: int = 90, cells: int = 3,
                     options: RegisterOptions | None = None, progress=None, level=None) -> tuple:
    """``(GcpList, {name: FrameFit})``: :func:`automatic_control` and every frame's registration to the
    reference (its fitted pose, :mod:`fotogeo.tools.triangulate.register`). An ``eos`` entry None: the frame's
    tiles are chosen by its raster's own georeference, or all when it has none; ``level[i]`` True: frame
    ``i``'s attitude is unknown (a GPS position only), its tiles are those in its :func:`reach_disc`."""
    prog = as_progress(progress)
    if per_frame < cells * cells:
        raise InputError(f"per_frame must be at least {cells * cells} (one point per region); got {per_frame}")
    if len(frames) != len(names) or len(frames) != len(eos):
        raise InputError("frames, names and eos must have one entry per frame")
    crs = require_projected(parse_crs(crs, "map CRS of the block"), "map CRS of the block")
    tiles = _references(reference)
    d = dem if isinstance(dem, Dem) else read_dem(dem)
    fits = {}
    frame, px, xyz, tile, ref_xy, res = _candidates(frames, names, camera, eos, tiles, crs, DemSampler(d, crs),
                                                    float(np.nanmean(d.data)), options or RegisterOptions(), prog,
                                                    fits, level)
    point = merge_points(frame, px, tile, ref_xy)
    first = np.lexsort((res, frame, point))  # one measurement per (point, frame): the smallest residual
    once = first[np.r_[True, (np.diff(point[first]) != 0) | (np.diff(frame[first]) != 0)]]
    frame, px, xyz, res, point = frame[once], px[once], xyz[once], res[once], point[once]
    score = -np.bincount(point)[point] * 1e3 + np.minimum(res, 999.0)  # more rays first, then the smaller residual
    keep = np.isin(point, thin_to_budget(point, frame, image_regions(px, camera, cells), score,
                                         max(1, per_frame // (cells * cells))))
    ids = {p: k for k, p in enumerate(dict.fromkeys(point[keep]))}
    idx = np.array([ids[p] for p in point[keep]], dtype=np.intp)
    ground = np.zeros((len(ids), 3))
    np.add.at(ground, idx, xyz[keep])  # one keypoint: one XYZ; one feature in two tiles: their mean
    ground /= np.bincount(idx)[:, None]
    prog(1.0, f"{len(ids)} control points in {len(set(frame[keep]))} frames")
    gcp = GcpList(_crs_text(crs), np.array([f"auto{k}" for k in idx], dtype=object), ground[idx], px[keep],
                  np.array([names[f] for f in frame[keep]], dtype=object))
    return gcp, fits


def reference_sigmas(reference, dem, crs, sigma_xy=None, sigma_z=None) -> tuple:
    """``(σ_xy, σ_z)`` in metres of the automatic control: the values given, else derived from the inputs —
    σ_xy half the coarsest reference orthophoto's pixel (a feature matched to half a pixel), σ_z half the
    DEM's pixel, at least σ_xy (a height read off a DEM of that spacing). On the NGI pair (5 m
    orthophotos, 24 m DEM): 2.5 m and 12 m, where the control placed by the images alone is off by
    0.8 / 1.4 m in X / Y and 9.9 m in height (:mod:`fotogeo.orientation.bundle_control`); the fixed
    0.5 m / 1 m held those points 5-10 times tighter than the images could place them."""
    if sigma_xy is not None and sigma_z is not None:
        return float(sigma_xy), float(sigma_z)
    crs = parse_crs(crs, "map CRS of the block")
    if sigma_xy is None:
        sigma_xy = 0.5 * max(_pixel_size(info, crs) for info in _references(reference))
    if sigma_z is None:
        info = open_raster(dem, "DEM") if isinstance(dem, (str, bytes)) or hasattr(dem, "__fspath__") else None
        step = _pixel_size(info, crs) if info is not None and info.georeferenced else 2.0 * float(sigma_xy)
        sigma_z = max(0.5 * step, float(sigma_xy))
    return float(sigma_xy), float(sigma_z)


def _pixel_size(info, crs) -> float:
    """The pixel side of a raster at its centre, in ``crs`` metres."""
    return pixel_size_in(info.transform, info.crs, crs, info.width / 2, info.height / 2)
