"""What a pair's sparse matches say about the heights around each strip of ``fotogeo dsm`` (:mod:`.frames`).

**Local disparity ranges** (:func:`local_range`; the approach of s2p, de Franchis et al. 2014, and CARS,
Youssefi et al. 2020): the cost of semi-global matching is pixels x disparities, and a pair's range covers every
height of the whole overlap. Each strip searches only the disparities of the heights around it: the heights of
the pair's sparse matches (without the mismatches the pair's range drops, :func:`guides`) within ``LOCAL_NEAR``
rectified pixels of the strip, their span widened by half itself
and ``LOCAL_PAD_M`` metres on each side (the pair range's rule, :mod:`.plan`, on the strip's neighbourhood: relief
between the matches — a roof, a tree, a steeper slope — rises above or dips below the matched heights by about
the relief seen around, and the fixed metres cover a flat neighbourhood with an object the matches missed),
turned into disparities over the strip's own pixels (:func:`~fotogeo.tools.dsm.plan.disparity_bounds`: over an
oblique pair one height's disparity varies across the image) plus ``PAD_PX``, and kept inside the pair's range.
Fewer than ``LOCAL_MIN`` matches near a strip and it searches the pair's range. With a DEM (``--dem``) that fits
the pair's matches (:mod:`.dem_guide`) a strip searches the heights where its rays meet the DEM, from the DEM's
margin below them to its margin above them (the matches' rise over the DEM: roofs and trees on a DEM of the ground;
:func:`dem_heights`, the rule of RPC tiles too; the matches' rule where the DEM has a void), and each pixel expects
the DEM's height.

**Local height ranges** (:func:`strip_heights`): a strip with a local range keeps only the points within its
local heights, not the pair's. Its disparity range is the union of its pixels' (over an oblique pair one height's
disparity varies across the strip by hundreds of pixels), so a pixel may find a disparity that is inside the
strip's range yet whose height lies outside the heights the range was made of: outside that pixel's own range.
Where it comes from: at the rectified images' top and bottom rows the two images' valid columns may not overlap
at the surface's disparity (rows both images reach, ground only one of them sees); the left pixels without a
partner there meet right pixels without a partner that meet them back, real texture on both sides, and pass the
left–right check at a wrong disparity (on the oblique set "1280x960 full" of ``tests/dsm_oblique_sets.py``: a
band of −22 m, 280–287 m where the matches near the strip span 296–301 m, padded to 288–308 m). Those pixels are
now refused where they are matched (:func:`expected_disparity`, the ``partner`` of
:func:`fotogeo.stereo.dense.disparity`); the heights stay a guard."""
from __future__ import annotations

import cv2
import numpy as np

from ...pixels import HALF
from ...stereo.rectify import RectifiedPair
from .plan import disparity_bounds, plausible_heights

#: a strip's local disparity range (module docstring): the sparse matches within this many rectified pixels of
#: it, at least ``LOCAL_MIN`` of them, their heights' span padded by half itself and ``LOCAL_PAD_M`` metres
LOCAL_NEAR = 192
LOCAL_MIN = 8
LOCAL_PAD_M = 5.0


def guides(sp, ceiling: float) -> np.ndarray:
    """``(N, 3)`` rectified left pixel ``(u, v)`` and height of each sparse match of :func:`.frames.sparse_check`
    that is not a mismatch (:func:`~fotogeo.tools.dsm.plan.plausible_heights`, the pair range's filter;
    ``ceiling`` the lower camera's height): what :func:`local_range` reads (small and picklable, kept with the pair)."""
    z = sp["points"][:, 2]
    keep = plausible_heights(z, ceiling) if len(z) else np.zeros(0, bool)
    return np.column_stack([sp["uv"], z])[keep].astype(float)


def local_heights(near, box, rp: RectifiedPair | None = None, dem=None) -> tuple | None:
    """``(low, high)``: the heights the sparse matches ``near`` (:func:`guides`) within ``LOCAL_NEAR`` rectified
    pixels of the box ``(u0, v0, u1, v1)`` span, padded by half their span and ``LOCAL_PAD_M`` metres (module
    docstring); None when fewer than ``LOCAL_MIN`` lie that near. With a ``dem`` (:class:`.dem_guide.DemGuide`)
    and the pair ``rp``: the heights where the box's rays meet the DEM (:func:`dem_heights`) within its margins, the
    matches' where it has none."""
    if dem is not None:
        return dem_heights(rp, near, dem, box)
    if near is None or len(near) < LOCAL_MIN:
        return None
    u0, v0, u1, v1 = box
    u, v, z = near[:, 0], near[:, 1], near[:, 2]
    z = z[(u >= u0 - LOCAL_NEAR) & (u <= u1 + LOCAL_NEAR) & (v >= v0 - LOCAL_NEAR) & (v <= v1 + LOCAL_NEAR)]
    if len(z) < LOCAL_MIN:
        return None
    pad = 0.5 * (z.max() - z.min()) + LOCAL_PAD_M
    return float(z.min() - pad), float(z.max() + pad)


def _nodes(box) -> tuple:
    """The nodes ``(u, v)`` (2-D) ``GUIDE_STEP`` rectified pixels apart over the box ``(u0, v0, u1, v1)``, its far
    edges included."""
    u0, v0, u1, v1 = box
    return np.meshgrid(np.arange(u0, u1 + GUIDE_STEP, GUIDE_STEP, dtype=float),
                       np.arange(v0, v1 + GUIDE_STEP, GUIDE_STEP, dtype=float))


def _nearest_median(near, u, v) -> np.ndarray:
    """The median height of the ``LOCAL_MIN`` sparse matches ``near`` nearest each node ``(u, v)`` (flat)."""
    from scipy.spatial import cKDTree  # nodes x matches distances would take ~100 MB on a wide strip
    _, nearest = cKDTree(near[:, :2]).query(np.column_stack([np.ravel(u), np.ravel(v)]), k=LOCAL_MIN)
    return np.median(near[nearest, 2], axis=1)


def _on_dem(rp, near, dem, u, v) -> tuple:
    """``(z, residual, matches' z)`` of the nodes ``(u, v)`` (flat): where their rays meet the DEM ``dem``
    (:meth:`.dem_guide.DemGuide.node_heights`, started at the nearest matches' median, or the DEM's median where
    the matches are too few) and the nearest matches' median height (NaN when they are too few)."""
    few = near is None or len(near) < LOCAL_MIN
    zm = np.full(np.size(u), np.nan) if few else _nearest_median(near, u, v)
    if dem is None:
        return np.full(np.size(u), np.nan), np.zeros(np.size(u)), zm
    data = dem.dem.data[np.isfinite(dem.dem.data)]  # all NaN (the pair over a void): no start, no DEM height
    start = np.where(np.isfinite(zm), zm, (float(np.median(data)) if data.size else np.nan) - dem.fitted.offset)
    return (*dem.node_heights(rp, u, v, start), zm)


def dem_heights(rp, near, dem, box) -> tuple | None:
    """``(low, high)``: the heights where the rays of the box's nodes meet the DEM ``dem``
    (:meth:`.dem_guide.DemGuide.node_heights`) widened by each node's residual, the DEM's margin below and its margin
    above (:meth:`.dem_guide.DemGuide.span`: what stands on a DEM of the ground rises over it), joined with the
    matches' :func:`local_heights` when the DEM has no height at some node (a void, its edge); None when neither
    says anything there."""
    u, v = _nodes(box)
    z, res, _ = _on_dem(rp, near, dem, u, v)
    ok = np.isfinite(z)
    spans = []
    if ok.any():
        spans.append(dem.span(z[ok], res[ok]))
    if not ok.all():
        z = local_heights(near, box)
        if z is None:
            return None
        spans.append(z)
    return min(a for a, _ in spans), max(b for _, b in spans)


def local_range(rp: RectifiedPair, near, box, lo: float, hi: float, dem=None) -> tuple:
    """``(low, high, local)``: the disparity range of the rectified left pixels ``box`` ``(u0, v0, u1, v1)`` from
    the sparse matches ``near`` (:func:`guides`) around it, or the DEM ``dem`` there (:func:`local_heights`, module
    docstring), inside the pair's ``[lo, hi]``; ``(lo, hi, False)`` when neither bounds the box."""
    z = local_heights(near, box, rp, dem)
    if z is None:
        return lo, hi, False
    a, b = disparity_bounds(rp, *z, box, n=5)
    a, b = max(lo, a), min(hi, b)
    return (a, b, True) if b > a else (lo, hi, False)


def strip_heights(near, box, zlim: tuple, local: bool, rp: RectifiedPair | None = None, dem=None) -> tuple:
    """The heights a strip's points are kept within: the pair's ``zlim``, narrowed to the strip's
    :func:`local_heights` (``rp``, ``dem`` as there) when its range is ``local`` (module docstring, *local height
    ranges*)."""
    z = local_heights(near, box, rp, dem) if local else None
    if z is None:
        return zlim
    a, b = max(zlim[0], z[0]), min(zlim[1], z[1])
    return (a, b) if b > a else zlim


#: the expected disparities of a strip's left pixels (:func:`expected_disparity`) are found on nodes this many
#: rectified pixels apart
GUIDE_STEP = 32


def expected_disparity(rp: RectifiedPair, near, rows: tuple, cols: tuple, dem=None) -> np.ndarray | None:
    """The disparity (float32 ``(rows, cols)`` of the rectified left pixels ``rows`` ``(r0, r1)`` x ``cols``
    ``(c0, c1)``) each pixel is expected at: its ray at the height where it meets the DEM ``dem``
    (:class:`.dem_guide.DemGuide`) or, where there is none, the median height of the ``LOCAL_MIN`` sparse matches
    ``near`` (:func:`guides`) nearest to it in the rectified left image (at the rows where the images barely
    overlap few matches lie near: the nearest still tell the heights around), found on nodes ``GUIDE_STEP`` pixels
    apart and linear between them (what :func:`fotogeo.stereo.dense.disparity` fills the pixels outside the images
    by, its ``partner``: a pixel without a partner is refused, not matched to another without one); None with
    fewer than ``LOCAL_MIN`` matches and no DEM."""
    if dem is None and (near is None or len(near) < LOCAL_MIN):
        return None
    (r0, r1), (c0, c1) = rows, cols
    u, v = _nodes((c0, r0, c1, r1))
    zd, _, zm = _on_dem(rp, near, dem, u, v)
    z = np.where(np.isfinite(zd), zd, zm)
    d = rp.rays(u, v, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (z - rp.centres[0][2]) / d[:, 2]
    P = rp.centres[0] + lam[:, None] * d
    dn = np.where(lam > 0, rp.disparity(P), np.nan).reshape(u.shape).astype(np.float32)
    # linear between the nodes: node k at pixel k * GUIDE_STEP of the piece
    x = (np.arange(c1 - c0, dtype=np.float32) + HALF) / GUIDE_STEP
    y = (np.arange(r1 - r0, dtype=np.float32) + HALF) / GUIDE_STEP
    X, Y = np.meshgrid(x, y)
    return cv2.remap(dn, X, Y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
