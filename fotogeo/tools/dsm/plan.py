"""The plan of a ``fotogeo dsm`` run before any dense matching: the terrain's heights, the pairs, each pair's
disparity range and the output grid.

* **Heights**: a DEM's range (``--dem``), else the heights of sparse matches of the pair of images whose centres
  are nearest (:func:`sparse_heights`);
* **pairs**: :func:`fotogeo.stereo.pairs.choose_pairs` on the footprints at the mean height, pairs whose base
  line points into either image or within :data:`EPIPOLE_MARGIN` degrees of its border (the epipole inside or next
  to the frame: forward motion; :func:`epipole_margin`, the border taken at the epipole's azimuth about the axis)
  left out before the per-image cap (:func:`forward_reason`: such a pair takes no image's place and covers no
  ground of the readmission). The border is taken, not the corners: a frame flown the way it looks has its
  border much nearer the optical axis towards the base than its diagonal, and the epipole of its strip partners
  lies outside the image though within the half diagonal field of view, where a bound on the diagonal left out every
  strip pair (docs/benchmarks/dsm.md, "Strip pairs of frames flown the way they look", with the measured angles); then
  pairs whose rectified images would outgrow what :func:`.rectify` takes at the run's resolution
  (:func:`size_reason`: the size grows like 1/sin² of the epipole's distance outside the image, so a margin alone
  does not say it fits);
* **disparity range** (:func:`disparity_bounds`): the rectified left image's rays on the planes of the lowest and
  highest height (from the DEM, or the pair's sparse matches' 1st–99th percentiles without their mismatches,
  reaching out to the heights neighbouring matches support, padded by half the percentiles' span and 10 m,
  :func:`matched_heights`), plus ``PAD_PX``;
* **grid**: ``--bounds``, else the union of the kept pairs' overlaps, its edges multiples of the resolution.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import InputError, ModelError
from ...pixels import outline
from ...stereo.fusion import GridSpec
from ...stereo.rectify import MAX_RECTIFIED_PIXELS, epipole_angle, rectified_extent, rectify

PAD_PX = 8.0
#: no ground lies lower than this (m; the Dead Sea shore is at −430 m above the geoid, which departs from the
#: ellipsoid by at most 106 m): frames whose footprints overlap only below it show different ground
LOWEST_GROUND = -1000.0
#: a pair is left out as forward motion when its epipole lies less than this many degrees outside either image
EPIPOLE_MARGIN = 5.0


def footprint(im, z: float) -> np.ndarray:
    """The outline of image ``im`` on the plane of height ``z``, ``(N, 3)`` (rays that miss it dropped)."""
    xyz = im.model.inverse(outline(im.width, im.height, 9), z)
    xyz = np.column_stack([xyz[:, :2], np.full(len(xyz), z)])
    return xyz[np.isfinite(xyz).all(axis=1)]


def pair_footprints(ims, p, zlim: tuple) -> list:
    """Pair ``p``'s :func:`footprint` s ``(N, 2)`` at its heights ``zlim``: its DEM's ground (:mod:`.dem_guide`)."""
    return [footprint(ims[k], z)[:, :2] for k in (p.i, p.j) for z in zlim]


def dem_range(source, ims) -> tuple:
    """``(low, high)``: the heights of the DEM height source ``source`` as the run uses them (its valid cells in the
    map CRS's unit, :attr:`z_range`), with a geoid's undulations added when it carries them
    (:class:`~fotogeo.geometry.vertical.ShiftedHeights`, ``--geoid``): their least and greatest under the images
    ``ims`` (their footprints' outlines), not over the whole geoid raster."""
    und = getattr(source, "undulation", None)
    lo, hi = (source if und is None else source.source).z_range
    if und is None:
        return float(lo), float(hi)
    n = np.asarray(und.heights(np.vstack([footprint(im, 0.5 * (lo + hi))[:, :2] for im in ims])), float)
    n = n[np.isfinite(n)]
    return (float(lo + n.min()), float(hi + n.max())) if n.size else tuple(float(z) for z in source.z_range)


def nearest_pair(views) -> tuple:
    """The two views whose projection centres are closest."""
    C = np.array([v.centre for v in views])
    d = np.linalg.norm(C[:, None] - C[None], axis=2) + np.eye(len(C)) * 1e300
    i, j = np.unravel_index(np.argmin(d), d.shape)
    return int(min(i, j)), int(max(i, j))


def extent_text(fp) -> str:
    """``"x 10..20, y 30..40"``: the bounding box of a footprint ``(N, 2+)`` (``"nowhere"`` when empty)."""
    fp = np.asarray(fp, float)
    if fp.size == 0:
        return "nowhere"
    (x0, y0), (x1, y1) = fp[:, :2].min(axis=0), fp[:, :2].max(axis=0)
    return f"x {x0:.0f}..{x1:.0f}, y {y0:.0f}..{y1:.0f}"


def footprints_apart(ims, views, i: int, j: int, min_overlap: float, steps: int = 40) -> str:
    """Why images ``i`` and ``j`` cannot show the same ground ("" when they may): their footprints overlap by
    ``min_overlap`` only on planes below ``LOWEST_GROUND`` (scanned from 1 m to 100 km below the lower camera),
    or on none. They are named on the plane of height 0 (or 1 m below the cameras when these stand lower)."""
    from ...stereo.pairs import overlap_share
    zc = min(views[i].centre[2], views[j].centre[2])
    first = next((zc - h for h in np.geomspace(1.0, 1e5, steps)
                  if overlap_share(footprint(ims[i], zc - h), footprint(ims[j], zc - h)) >= min_overlap), None)
    if first is not None and first >= LOWEST_GROUND:
        return ""
    z = min(0.0, zc - 1.0)
    where = (f"only on planes below {first:.0f} m, lower than any ground ({LOWEST_GROUND:g} m)" if first is not None
             else "on no plane below the cameras")
    return (f"their footprints overlap by {100 * min_overlap:.0f} % {where}: on the plane of height {z:g}, "
            f"{views[i].name!r} covers {extent_text(footprint(ims[i], z))} and {views[j].name!r} covers "
            f"{extent_text(footprint(ims[j], z))}; check the orientation's positions (X, Y) and heights, or give "
            f"images of the same ground")


def sparse_heights(views, sources, sparse_check, sparse_problem, max_px, ims=None, min_overlap=0.2) -> tuple:
    """``(low, high)`` heights of the sparse matches of the nearest pair, without their mismatches
    (:func:`plausible_heights`): the 1st and 99th percentile, the heights of the bulk that place the run's footprints
    (the pair choice, the grid), not a search range (each pair searches its own :func:`matched_heights`, which
    keeps a small roof; its extremes here grow the grid by edge cells few rays meet well). Refused when
    the pair's footprints cannot overlap (:func:`footprints_apart`, with ``ims`` the images' models), or its
    matches are too few or cannot be trusted."""
    i, j = nearest_pair(views)
    apart = footprints_apart(ims, views, i, j, min_overlap) if ims is not None else ""
    if apart:
        raise InputError(f"images {views[i].name!r} and {views[j].name!r} (the nearest pair) show different ground: "
                         f"{apart}")
    rp = rectify(views[i], views[j], min(1.0, 1500.0 / max(max(views[i].size), 1)))
    sp = sparse_check(rp, (views[i], views[j]), (sources[i], sources[j]), ids=(i, j))
    few = (f"only {sp['n']} sparse matches (textureless or cloud-covered where they overlap, or an orientation that "
           f"does not fit them?)")
    wrong = sparse_problem(sp, max_px)  # a DEM would not mend an orientation that does not fit
    if wrong or sp["n"] < 20:
        raise InputError(f"images {views[i].name!r} and {views[j].name!r} (the nearest pair): " + (wrong or (
            f"{few}; the heights cannot be bounded from them: give a coarse DEM of the area (--dem)")))
    z = sp["points"][:, 2]
    lo, hi = np.percentile(z[plausible_heights(z, min(views[i].centre[2], views[j].centre[2]))], [1, 99])
    return float(lo), float(hi)


def plausible_heights(z, ceiling: float) -> np.ndarray:
    """Which sparse matches' heights ``z`` are not mismatches (bool): those within ``max(6 NMAD, ½ of the cameras'
    height above the median)`` of the median (a few rays that meet hundreds of metres below the ground set the 1st
    percentile on a drone pair); ``ceiling`` the lower camera's height. The one filter of the pair's range
    (:func:`matched_heights`) and of its strips' local ranges (:func:`.local.guides`)."""
    z = np.asarray(z, float)
    med = float(np.median(z))
    window = max(6.0 * 1.4826 * float(np.median(np.abs(z - med))), 0.5 * max(float(ceiling) - med, 1.0))
    return np.abs(z - med) <= window


#: a sparse match's height is supported (:func:`supported`) by ``SUPPORT_K`` others among its ``SUPPORT_NEAR``
#: nearest within ``max(SUPPORT_BAND_M, SUPPORT_BAND_K · s)`` of it (``s`` the NMAD of those neighbours' heights)
SUPPORT_NEAR = 8
SUPPORT_K = 2
SUPPORT_BAND_M = 2.0
SUPPORT_BAND_K = 3.0


def supported(xy, z) -> np.ndarray:
    """Which heights ``z`` of sparse matches at ``xy`` ``(N, 2)`` (map or image coordinates: only the order of
    distances counts) a surface supports (bool): at least ``SUPPORT_K`` of the ``SUPPORT_NEAR`` matches nearest each
    lie within a band of its height. A roof or a tree carries several matches at its height, a mismatch stands
    alone; a range set by percentiles cuts what covers less of the overlap than the percentile (a roof over 1 % of
    it), which :func:`supported_range` adds back. The band is ``max(SUPPORT_BAND_M, SUPPORT_BAND_K · s)``, ``s`` the
    NMAD of the neighbours' heights among themselves: the relief around (a slope sampled sparsely, the ground beside
    a roof) widens it, flat ground under a lone mismatch does not. Fewer than ``SUPPORT_K + 1`` matches: all."""
    z = np.asarray(z, float).ravel()
    if len(z) <= SUPPORT_K:
        return np.ones(len(z), bool)
    from scipy.spatial import cKDTree
    k = min(SUPPORT_NEAR, len(z) - 1)
    _, idx = cKDTree(np.asarray(xy, float).reshape(-1, 2)).query(np.asarray(xy, float).reshape(-1, 2), k=k + 1)
    zn = z[idx[:, 1:]]  # the first neighbour is the match itself
    spread = 1.4826 * np.median(np.abs(zn - np.median(zn, axis=1)[:, None]), axis=1)
    band = np.maximum(SUPPORT_BAND_M, SUPPORT_BAND_K * spread)
    return (np.abs(zn - z[:, None]) <= band[:, None]).sum(axis=1) >= SUPPORT_K


def supported_span(xy, z, least: int = 1) -> tuple | None:
    """``(low, high)`` of the heights ``z`` at ``xy`` that are :func:`supported`; None when fewer than ``least`` are."""
    z = np.asarray(z, float).ravel()[supported(xy, z)]
    return (float(z.min()), float(z.max())) if len(z) >= max(least, 1) else None


def supported_range(xy, z, widen: float, pad: float) -> tuple:
    """``(low, high)``: the 1st and 99th percentiles of the heights ``z`` at ``xy`` (their bulk), reaching out to
    the lowest and highest heights neighbouring matches :func:`support <supported>` (a small roof: above the 99th
    percentile when it covers less than 1 % of the overlap; all the heights when none is), each end then moved out
    by ``widen`` times the bulk's span plus ``pad`` metres; never narrower than the percentiles (a mismatch, or a
    roof carrying one match). A frame pair's (:func:`matched_heights`) and an RPC pair's range without a DEM."""
    z = np.asarray(z, float).ravel()
    p1, p99 = (float(v) for v in np.percentile(z, [1, 99]))
    lo, hi = supported_span(xy, z) or (float(z.min()), float(z.max()))
    grow = widen * (p99 - p1) + pad
    return min(lo, p1) - grow, max(hi, p99) + grow


def below_cameras(z, ceiling: float) -> float:
    """The highest height a frame pair searches: its matches' median height (of ``z``) plus ¾ of the lower camera's
    (``ceiling``) above it; a range reaching above a camera has no disparity."""
    med = float(np.median(z))
    return med + 0.75 * max(float(ceiling) - med, 1.0)


def matched_heights(points, ceiling: float, widen: float = 0.0, pad: float = 0.0) -> tuple:
    """``(low, high)`` heights of sparse matches ``points`` ``(N, 3)`` without their mismatches
    (:func:`plausible_heights`): :func:`supported_range` of the rest, the high end :func:`below_cameras`."""
    P = np.asarray(points, float).reshape(-1, 3)
    kept = P[plausible_heights(P[:, 2], ceiling)]
    lo, hi = supported_range(kept[:, :2], kept[:, 2], widen, pad)
    return lo, min(hi, below_cameras(P[:, 2], ceiling))


def beyond_dem(zlim: tuple, xy, z, least: int, top: float = np.inf, pad: float = 10.0) -> tuple:
    """A DEM's heights ``zlim`` joined with the lowest and highest sparse heights ``z`` at ``xy`` that neighbouring
    matches :func:`support <supported>`, ``pad`` metres beyond (the high end at most ``top``), when ``least`` are
    supported. A DEM bounds neither the ground under its voids nor a DEM shifted from the orientation's heights; the
    percentiles (:func:`supported_range`) would let one mismatch among 25 matches widen [82, 117] to [-221, 1025] m.
    A frame pair's rule (:func:`with_matches`); an RPC pair's tie points still use :func:`supported_range`."""
    span = supported_span(xy, z, least)
    return zlim if span is None else (min(zlim[0], span[0] - pad), max(zlim[1], min(span[1] + pad, top)))


def with_matches(sp, zlim: tuple, ceiling: float, least: int) -> tuple:
    """The heights ``zlim`` (the DEM's) joined with those beyond them the pair's sparse matches ``sp`` without
    their mismatches (:func:`plausible_heights`) support (:func:`beyond_dem`), the high end :func:`below_cameras`,
    when the pair has ``least`` matches."""
    P = np.asarray(sp["points"], float).reshape(-1, 3)
    if sp["n"] < least or len(P) == 0:
        return zlim
    kept = P[plausible_heights(P[:, 2], ceiling)]
    return beyond_dem(zlim, kept[:, :2], kept[:, 2], least, below_cameras(P[:, 2], ceiling))


def epipole_margin(view, direction) -> float:
    """How far (degrees) the line ``direction`` (world ``(3,)``, either way along it) passes outside the frame's
    field of view: its angle ``θ`` from the optical axis minus the angle ``θ_edge(φ)`` of the image border's ray at
    the same azimuth ``φ`` about the axis (the border's rays through the camera model, distortion removed),
    negative when the epipole lies inside the image. A 3:2 frame pitched along the flight has its border much
    nearer the axis towards the base than along the diagonal: a bound on the diagonal refused such frames' strip
    pairs, whose epipole lies well outside the image (module docstring)."""
    edge = view.rays(outline(*view.size, 17)) @ view.rotation
    d = np.asarray(direction, float) @ view.rotation
    d = d if d[2] >= 0 else -d
    theta_e = np.degrees(np.arctan2(np.hypot(edge[:, 0], edge[:, 1]), edge[:, 2]))
    phi_e = np.arctan2(edge[:, 1], edge[:, 0])
    order = np.argsort(phi_e)
    theta = math.degrees(math.atan2(math.hypot(d[0], d[1]), d[2]))
    at = float(np.interp(math.atan2(d[1], d[0]), phi_e[order], theta_e[order], period=2 * math.pi))
    return theta - at


def forward_reason(p, views) -> str:
    """Why pair ``p`` is left out when its base line points into either image or within
    :data:`EPIPOLE_MARGIN` degrees of its border (module docstring), else ""."""
    b = np.asarray(views[p.j].centre, float) - np.asarray(views[p.i].centre, float)
    a = min(epipole_margin(views[p.i], b), epipole_margin(views[p.j], b))
    if a < EPIPOLE_MARGIN:
        where = "in the image" if a < 0 else f"{a:.0f} degrees outside the image"
        angle = min(epipole_angle(views[p.i], views[p.j]), epipole_angle(views[p.j], views[p.i]))
        return (f"the base line is {angle:.0f} degrees from a view direction (the epipole {where}): forward motion "
                "cannot be rectified")
    return ""


def size_reason(vi, vj, scale: float, fine: float, extent=None) -> str:
    """Why the pair of views ``vi``, ``vj`` cannot be rectified at ``scale`` (:func:`.rectify`'s own extent,
    :func:`.rectified_extent`, and its bound :data:`.MAX_RECTIFIED_PIXELS`), else "". ``fine``: the resolution
    (map units) at scale 1; the resolution that fits is ``fine / s*`` with ``s* = scale·√(MAX / (2 w h))`` (the
    pixels go with the square of the scale), rounded up to two digits. ``extent``: the pair's
    :func:`.rectified_extent` at ``scale`` when already computed."""
    try:
        _, _, _, _, _, (w, h) = extent or rectified_extent(vi, vj, scale)
    except ModelError as e:
        return str(e)
    if 2 * w * h <= MAX_RECTIFIED_PIXELS:
        return ""
    fit = fine / (scale * math.sqrt(MAX_RECTIFIED_PIXELS / (2.0 * w * h)))
    fit = math.ceil(fit / 10 ** (math.floor(math.log10(fit)) - 1)) * 10 ** (math.floor(math.log10(fit)) - 1)
    return (f"the rectified pair would have {w} x {h} pixels, more than {MAX_RECTIFIED_PIXELS // 2} per image "
            f"(its epipole lies near the image): give --resolution {fit:.3g} or coarser")


def rectified_stretch(p, views, extent=None) -> float:
    """How many times the larger frame's pixels each rectified image of pair ``p`` has (:func:`.rectified_extent`
    at scale 1; the pixels go with the square of the scale, so the ratio holds at every scale). It is what
    rectification does to the frames: a few times at most for a base across the lines of sight (more when the base
    runs along the frame's diagonal: the rectified rows follow the base; docs/benchmarks/dsm.md has the measured
    ranges), growing like 1/sin² of the epipole's distance outside the
    image as the rows far from the epipole are stretched along the base, and the matching's cost (rectified pixels
    times their disparities) grows with it. The pair choice ranks the pairs beyond
    :data:`fotogeo.stereo.pairs.NEAR_STRETCH` after the others (module docstring). The epipole's margin in degrees
    (:func:`epipole_margin`) says less: the same margin stretches a wide frame more than a narrow one, since the
    scale across the rectified image goes with the ratio of the epipole's distances to the far and near borders.
    ``extent``: the pair's :func:`.rectified_extent` at scale 1 when already computed."""
    vi, vj = views[p.i], views[p.j]
    w, h = (extent or rectified_extent(vi, vj, 1.0))[-1]
    return w * h / max(vi.size[0] * vi.size[1], vj.size[0] * vj.size[1])


def rectify_reason(p, views, resolution=None, extent=None) -> str:
    """:func:`size_reason` of pair ``p`` in the pair choice: at the scale the run will rectify it with
    (``2 GSD / resolution`` capped at 1, the pair's GSD its distance over the focal length; 1 without
    ``--resolution``, whose default is twice the GSD). ``extent``: the pair's :func:`.rectified_extent` at scale 1,
    used when that is the run's scale (the rounded sizes at another scale are measured there)."""
    fine = 2.0 * p.extra["distance"] / views[p.i].focal
    scale = min(1.0, fine / resolution) if resolution else 1.0
    return size_reason(views[p.i], views[p.j], scale, fine, extent if scale == 1.0 else None)


def choice_measures(p, views, resolution=None) -> tuple:
    """``(reason, stretch)`` of pair ``p`` in the pair choice: :func:`forward_reason` or :func:`rectify_reason` ("" to
    leave it in), and the :func:`rectified_stretch` of a pair left in (None for one left out), both from one
    :func:`.rectified_extent` at scale 1 (a second at the run's scale only when ``resolution`` makes it coarser)."""
    why = forward_reason(p, views)
    if why:
        return why, None
    try:
        extent = rectified_extent(views[p.i], views[p.j], 1.0)
    except ModelError as e:  # the frames share no epipolar line: at every scale
        return str(e), None
    why = rectify_reason(p, views, resolution, extent)
    return why, None if why else rectified_stretch(p, views, extent)


def disparity_bounds(rp, zlo: float, zhi: float, box=None, n: int = 17) -> tuple:
    """``(low, high)`` disparities of the heights ``[zlo, zhi]`` over the rectified left image, or over its pixels
    ``box`` ``(u0, v0, u1, v1)`` (module docstring; an ``n`` x ``n`` grid of rays)."""
    u0, v0, u1, v1 = box or (0, 0, *rp.size)
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    d = rp.rays(u, v, 0)
    ds = []
    for z in (zlo, zhi):
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = (z - rp.centres[0][2]) / d[:, 2]
        P = rp.centres[0] + lam[:, None] * d
        P = P[lam > 0]
        ds.append(rp.disparity(P))
    d = np.concatenate(ds)
    d = d[np.isfinite(d)]
    if not d.size:
        raise InputError("no disparity range: the heights lie behind the cameras; check the orientation")
    return float(d.min()) - PAD_PX, float(d.max()) + PAD_PX


def grid_for(polygons, resolution: float, bounds=None, min_cells: int = 1) -> GridSpec:
    """The output grid (module docstring); ``polygons`` the kept pairs' overlaps ``(K, 2)``. Refused: ``bounds``
    that miss the overlaps' extent, and a grid of fewer than ``min_cells`` cells (the speckle filter removes every
    island of heights smaller than that, so such a grid could only come out empty)."""
    xy = np.vstack([p for p in polygons if len(p)])
    (ox0, oy0), (ox1, oy1) = xy.min(axis=0), xy.max(axis=0)
    if bounds is not None:
        x0, y0, x1, y1 = bounds
        if x1 <= ox0 or x0 >= ox1 or y1 <= oy0 or y0 >= oy1:
            raise InputError(f"--bounds {x0:.10g},{y0:.10g},{x1:.10g},{y1:.10g} lies outside the images' stereo "
                             f"overlap ({ox0:.2f},{oy0:.2f},{ox1:.2f},{oy1:.2f} in the output CRS): give bounds "
                             f"that overlap it, or none", option="bounds")
    else:
        x0, y0, x1, y1 = ox0, oy0, ox1, oy1
    r = float(resolution)
    gx0, gy0 = math.floor(x0 / r) * r, math.floor(y0 / r) * r
    gx1, gy1 = math.ceil(x1 / r) * r, math.ceil(y1 / r) * r
    grid = GridSpec(gx0, gy1, r, max(1, int(round((gx1 - gx0) / r))), max(1, int(round((gy1 - gy0) / r))))
    if grid.width * grid.height < min_cells:
        coarsest = math.sqrt((x1 - x0) * (y1 - y0) / min_cells)
        raise InputError(f"--resolution {r:g} makes a DSM of {grid.width} x {grid.height} cells over "
                         f"{x1 - x0:.4g} x {y1 - y0:.4g} map units, fewer than {min_cells} cells (smaller islands of "
                         f"heights are removed as mismatches): give a resolution of {coarsest:.3g} or finer"
                         + (" or wider --bounds" if bounds is not None else ""), option="resolution")
    return grid


def stereo_mask(grid: GridSpec, height, pairs, ims, rows_per_block: int = 256) -> np.ndarray:
    """Cells of ``grid`` that both images of some pair see (bool ``(rows, cols)``): the cell centre at its height
    (``height``; a hole takes the height of the nearest cell with one) projects inside both images."""
    from scipy.ndimage import distance_transform_edt
    valid = np.isfinite(height)
    if not valid.any():
        return np.zeros(height.shape, bool)
    idx = distance_transform_edt(~valid, return_distances=False, return_indices=True)
    filled = height[idx[0], idx[1]]
    X, Y = grid.centres()
    seen = np.zeros(filled.shape, bool)
    for r0 in range(0, grid.height, rows_per_block):
        z = filled[r0:r0 + rows_per_block]
        xx, yy = np.meshgrid(X, Y[r0:r0 + rows_per_block])
        P = np.column_stack([xx.ravel(), yy.ravel(), z.ravel()])
        ok = np.isfinite(P).all(axis=1)
        hit = np.zeros(len(P), bool)
        for p in pairs:
            both = ok.copy()
            for im in (ims[p.i], ims[p.j]):
                px = np.full((len(P), 2), np.nan)
                px[both] = im.model.forward(P[both])
                with np.errstate(invalid="ignore"):
                    both &= (px[:, 0] >= 0) & (px[:, 0] <= im.width) & (px[:, 1] >= 0) & (px[:, 1] <= im.height)
            hit |= both
        seen[r0:r0 + rows_per_block] = hit.reshape(z.shape)
    return seen


def overlap_mask(grid: GridSpec, polygons) -> np.ndarray:
    """Cells of ``grid`` inside any of the overlap polygons (bool ``(rows, cols)``)."""
    import cv2
    mask = np.zeros((grid.height, grid.width), np.uint8)
    for p in polygons:
        if len(p) < 3:
            continue
        px = np.column_stack([(p[:, 0] - grid.x0) / grid.resolution, (grid.y0 - p[:, 1]) / grid.resolution])
        cv2.fillConvexPoly(mask, np.round(px * 16).astype(np.int32), 1, shift=4)
    return mask.astype(bool)
