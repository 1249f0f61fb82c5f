"""One pair of oriented frames → 3-D points (the per-pair steps of ``fotogeo dsm``).

:func:`frame_view` gives a frame's :class:`~fotogeo.stereo.rectify.FrameView` from its ground → image model
(triangulate's :class:`~fotogeo.tools.triangulate.ortho.AdjustedFrame`: collinearity with Brown's distortion).
:func:`sparse_check` matches SIFT features of the two source images (Lowe 2004, ratio 0.8; detected once per image,
images longer than ``SPARSE_SIDE`` pixels on a copy of averaged source pixels) and follows them into the rectified
pair through the camera models: their row differences are the pair's epipolar residuals (the orientation's
relative error, in rectified pixels), their rays' miss distances its error in metres, their disparities the search
range when no DEM bounds it. :func:`dense_points` then
matches a box of the rectified pair (an output tile's, :mod:`.matching`) strip by strip
(:func:`fotogeo.stereo.dense.disparity`, strips of ``STRIP`` rows and the box's columns, with ``MARGIN`` more on
every side) and triangulates every matched pixel (:func:`fotogeo.stereo.rays.closest_points`), yielding
``(points, colours)`` per strip. Every rectified strip is resampled (:func:`rectified`) from the window of the
source image its pixels need (:class:`~fotogeo.tools.dsm.inputs.SourceImage`): memory follows the strip, not
the images.

**Local disparity and height ranges** (:mod:`.local`): each strip searches the disparities of the heights
the pair's sparse matches give around it (with ``--dem``: the DEM's heights there ± a margin, :mod:`.dem_guide`),
keeps the points within those heights, and its pixels outside the images are filled as their partner is expected
(:func:`.local.expected_disparity`).

**Coarse to fine** (``COARSE_TO_FINE``; :func:`_match`, :mod:`fotogeo.stereo.pyramid`): one band
per strip cannot follow a slope across it, so a strip whose range is ``pyramid.MIN_RANGE`` px or wider is matched
on copies ``pyramid.FACTOR`` times smaller over that range, and at full resolution within a narrow band around the
coarse disparities: the right image read again through its rectification maps resampled along the rows by the
coarse offset — where the band, the coarse copies and the fill of the pixels the coarse copies do not support
(``pyramid.fill_windows``, each window over its own run's range) search at most ``pyramid.GAIN`` of the whole
range's disparities; else the strip searches its whole range. A fine disparity is kept where the right image's
coarse disparities witness it (``pyramid.witnessed``: the right pixel's own, or where it has none away from the
borders, the envelope of its neighbours')."""
from __future__ import annotations

import cv2
import numpy as np

from ...features.detect import detect
from ...orientation import bundle_jacobian as bj
from ...pixels import HALF
from ...stereo import pyramid as pyr
from ...stereo.dense import disparity, disparity_range, penalty_scale, to_uint8
from ...stereo.rays import closest_points
from ...stereo.refine import refine as refine_disparities
from ...stereo.rectify import FrameView, RectifiedPair
from .local import expected_disparity, local_range, strip_heights

STRIP = 384
MARGIN = 48
#: True: strips whose range is wide enough search coarse to fine where that pays (:func:`_match`,
#: :mod:`fotogeo.stereo.pyramid`); False: every strip searches its whole range
COARSE_TO_FINE = True


class FrameRays:
    """The map-frame ray directions of source pixels (corner convention) of a frame: the pixels undistorted
    (:func:`fotogeo.orientation.bundle_jacobian.undistort_rays`) and turned by the rotation ``M`` (camera → map).
    A class, not a closure, so that a pair's views pickle into a Dask task."""

    def __init__(self, interior, scale, M):
        self.interior, self.scale, self.M = interior, scale, M

    def __call__(self, px) -> np.ndarray:
        return bj.undistort_rays(np.asarray(px, float), self.interior, self.scale) @ self.M.T


def frame_view(im) -> FrameView:
    """The :class:`FrameView` of an :class:`~fotogeo.tools.ortho.inputs.OrthoImage` of a frame (picklable: its
    model's ``forward`` and a :class:`FrameRays`)."""
    m = im.model
    M = m.frame.eo.rotation_cv
    cam = m.frame.camera
    return FrameView(im.name, m.frame.eo.centre, M, 0.5 * (cam.fx + cam.fy), (im.width, im.height), m.forward,
                     FrameRays(m.interior, m.scale, M))


def _remap(img, mx, my, interpolation=cv2.INTER_LINEAR):
    return cv2.remap(img, mx, my, interpolation, borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def _source_window(mx, my, valid, size, pad: int = 3) -> tuple | None:
    """``(x0, y0, x1, y1)``: the source pixels the maps' valid pixels need (with ``pad`` for the cubic kernel)."""
    if not valid.any():
        return None
    w, h = size
    x, y = mx[valid], my[valid]
    return (max(0, int(np.floor(x.min())) - pad), max(0, int(np.floor(y.min())) - pad),
            min(w, int(np.ceil(x.max())) + pad + 1), min(h, int(np.ceil(y.max())) + pad + 1))


def rectified(rp: RectifiedPair, view, i: int, src, r0: int, r1: int, c0: int = 0, c1: int | None = None,
              k: int = 1, colours: bool = False, maps: tuple | None = None) -> tuple:
    """``(grey float32, valid bool, colours or None)`` of rows ``r0:r1``, columns ``c0:c1`` of rectified image
    ``i``, read from the :class:`~fotogeo.tools.dsm.inputs.SourceImage` ``src`` by the window those pixels need
    (averaged over ``k x k`` source pixels when ``k > 1``); ``colours`` (three uint8 bands, bilinear) when asked;
    ``maps`` the source pixels to read (``rp.maps``'s, or resampled from them) instead of the window's."""
    mx, my = rp.maps(view, i, r0, r1, c0, c1) if maps is None else maps
    w, h = src.width, src.height
    valid = (mx >= 0) & (my >= 0) & (mx <= w - 1) & (my <= h - 1)
    win = _source_window(mx, my, valid, (w, h))
    if win is None:
        return np.zeros(mx.shape, np.float32), valid, None
    x0, y0, x1, y1 = win
    g = src.grey(x0, y0, x1, y1, k)
    sx, sy = (x1 - x0) / g.shape[1], (y1 - y0) / g.shape[0]
    gx, gy = (mx + HALF - x0) / sx - HALF, (my + HALF - y0) / sy - HALF  # centre convention, window pixels
    grey = _remap(g, gx.astype(np.float32), gy.astype(np.float32), cv2.INTER_CUBIC)
    rgb = None
    if colours:
        rgb = [_remap(c, mx - x0, my - y0) for c in src.colours(x0, y0, x1, y1)]
    return grey, valid, rgb


#: the longest side of the copy of a source image the sparse check detects features on (larger images: a copy of
#: source pixels averaged to that size)
SPARSE_SIDE = 1500


def _features(i: int, view, src, cache: dict, max_features: int) -> tuple:
    """``(pixels (N, 2) corner convention, descriptors)`` of SIFT features (Lowe 2004) of source image ``src``,
    once per image (``cache`` keyed by ``i``), on a copy at most ``SPARSE_SIDE`` pixels a side."""
    if i not in cache:
        w, h = src.width, src.height
        g = src.grey(0, 0, w, h, max(1, -(-max(w, h) // SPARSE_SIDE)))
        img8 = to_uint8(g, g > 0)  # 0: nodata
        kp = detect(img8.astype(np.float32), img8 > 0, "sift", max_keypoints=max_features)
        cache[i] = (kp.xy * [w / g.shape[1], h / g.shape[0]], kp.descriptors)
    return cache[i]


def sparse_check(rp: RectifiedPair, views, sources, max_features: int = 4000, cache: dict | None = None,
                 ids: tuple = (0, 1)) -> dict:
    """Sparse matches of the pair (module docstring): SIFT features of each source image (once per image and
    ``cache``, keyed by ``ids``), matched with Lowe's ratio test, their pixels followed into ``rp``'s rectified
    images: ``{"n", "dy" (px), "d" (px), "uv" (rectified left pixels), "points", "miss" (m)}``; ``n`` 0 when
    nothing matched; ``"followed"`` the matches followed into the rectified pair, those whose rays do not meet
    (an orientation that does not fit the images) too, which ``"dy_median"`` and ``"dy_spread"`` describe."""
    cache = {} if cache is None else cache
    (x1, d1), (x2, d2) = (_features(ids[i], views[i], sources[i], cache, max_features) for i in (0, 1))
    empty = {"n": 0, "dy": np.zeros(0), "d": np.zeros(0), "uv": np.zeros((0, 2)), "points": np.zeros((0, 3)),
             "miss": np.zeros(0), "dy_median": 0.0, "dy_spread": 0.0, "followed": 0}
    if d1 is None or d2 is None or len(x1) < 8 or len(x2) < 8:
        return empty
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(d1, d2, k=2)
    good = [m[0] for m in pairs if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
    if len(good) < 8:
        return empty
    p1 = rp.project(views[0].centre + views[0].rays(x1[[m.queryIdx for m in good]]), 0)
    p2 = rp.project(views[1].centre + views[1].rays(x2[[m.trainIdx for m in good]]), 1)
    seen = np.isfinite(p1).all(axis=1) & np.isfinite(p2).all(axis=1)
    if seen.sum() < 8:
        return empty
    p1, p2 = p1[seen], p2[seen]
    dy = p1[:, 1] - p2[:, 1]
    med = float(np.median(dy))
    spread = float(1.4826 * np.median(np.abs(dy - med)))
    keep = np.abs(dy - med) <= max(2.0, 3.0 * spread)
    p1, p2, dy = p1[keep], p2[keep], dy[keep]
    P, miss = closest_points(rp.centres[0], rp.rays(p1[:, 0], p1[:, 1], 0), rp.centres[1],
                             rp.rays(p2[:, 0], p2[:, 1], 1))
    ok = np.isfinite(miss)
    return {"n": int(ok.sum()), "dy": dy[ok], "d": (p1[:, 0] - p2[:, 0])[ok], "uv": p1[ok], "points": P[ok],
            "miss": miss[ok], "dy_median": med, "dy_spread": spread, "followed": int(keep.sum())}


def sparse_problem(sp, max_px: float) -> str:
    """Why the sparse matches of a pair cannot be trusted ("" when they can): they disagree among themselves (the
    images do not show the same ground, or the orientation is wrong), or agree on rows ``max_px`` apart (the
    orientation does not fit the images). Judged on the matches followed into the rectified pair, not on those
    whose rays meet: a wrong orientation (two images' names swapped) may leave no ray pair meeting, and a pair
    with no match is not a textureless one when its images match."""
    if sp["followed"] < 8:
        return ""
    if sp["dy_spread"] > 3.0:
        return (f"its sparse matches disagree (their row differences spread {sp['dy_spread']:.0f} px): the images "
                f"may not show the same ground, or their orientation is wrong")
    if abs(sp["dy_median"]) > max_px:
        miss = f"rays miss by {np.median(sp['miss']):.2f} m" if sp["n"] else "their rays do not meet"
        return (f"the orientation does not fit the images: {sp['followed']} sparse matches lie "
                f"{abs(sp['dy_median']):.1f} px off their epipolar lines ({miss}); check that each image has its own "
                f"orientation (file names swapped?) or refine the orientation (fotogeo triangulate)")
    return ""


#: the pair's penalty factor (:func:`pair_penalty`) is measured on this many bands of this many rectified rows
PENALTY_BANDS = 8
PENALTY_ROWS = 32


def pair_penalty(rp: RectifiedPair, views, sources) -> float:
    """SGBM's penalty factor of the pair (:func:`fotogeo.stereo.dense.penalty_scale`), measured on
    ``PENALTY_BANDS`` bands of ``PENALTY_ROWS`` rows of the rectified left image spread evenly over its height
    (their whole width): every strip of the pair matches with the same P1 and P2."""
    w, h = rp.size
    starts = np.unique(np.linspace(0, max(0, h - PENALTY_ROWS), PENALTY_BANDS).round().astype(int))
    pieces = [rectified(rp, views[0], 0, sources[0], int(r), min(h, int(r) + PENALTY_ROWS))[:2] for r in starts]
    return penalty_scale([g for g, _ in pieces], [v for _, v in pieces])


def pair_noise(sources) -> tuple:
    """``(left, right)``: the noise σ of the pair's two source images (:meth:`.inputs.SourceImage.noise`, once per
    image), the texture test's thresholds in every strip. Measured on the source pixels, not the rectified ones:
    resampling only lowers the noise, and a rectified image smaller than its source folds the scene's finest
    texture into the high frequencies the estimate reads as noise (the eBee frames at 0.2 m: 1.46 grey levels
    rectified, 0.43 in the source)."""
    return tuple(s.noise() for s in sources)


def _warped_maps(maps, D0) -> tuple:
    """The source maps of the right window resampled along its rows at ``x' − D0(x', y)`` (:mod:`~fotogeo.stereo.
    pyramid`; linear between the maps' columns, −1 outside the window)."""
    mx, my = maps
    rows, cols = mx.shape
    x = np.arange(cols, dtype=np.float32)[None, :] - D0
    y = np.repeat(np.arange(rows, dtype=np.float32)[:, None], cols, axis=1)
    out = (x < 0) | (x > cols - 1)
    return tuple(np.where(out, -1.0, cv2.remap(m, x.astype(np.float32), y, cv2.INTER_LINEAR)).astype(np.float32)
                 for m in maps)


def _coarse_to_fine(rp, views, sources, g1, v1m, g2, v2m, maps2, sa: float, sb: float, penalty, guide=None,
                    noise: tuple | None = None) -> tuple:
    """``(result or None, coarse disparities searched per pixel)``: the strip's windows matched coarse to fine
    (:func:`_match`'s result) if that pays, None if not. The left image's coarse copy is matched first: when its
    band alone (with both coarse copies' search) would already exceed ``pyramid.GAIN`` of the whole range's
    disparities, the right image's copy is not matched; else the pixels the copies do not support and their fill
    windows (:func:`fotogeo.stereo.pyramid.fill_windows`, derived once and matched as derived) complete the cost."""
    whole, per = disparity_range(sa, sb)[1], disparity_range(sa / pyr.FACTOR, sb / pyr.FACTOR)[1] / pyr.FACTOR ** 2
    dc = pyr.coarse_disparity(g1, g2, v1m, v2m, sa, sb, penalty=penalty, partner=guide)
    gd = pyr.guide(dc, g1.shape, v1m)
    # a band wider than the margin: its last columns go unmatched
    if gd is None or gd[1] >= MARGIN or disparity_range(-gd[1], gd[1])[1] + 2 * per > pyr.GAIN * whole:
        return None, per
    (D0, R), band = gd, disparity_range(-gd[1], gd[1])[1]
    dcr = pyr.coarse_disparity(g1, g2, v1m, v2m, sa, sb, penalty=penalty, side="right", partner=guide)
    wm = _warped_maps(maps2, D0)
    near = pyr.near_border(D0, v1m, v2m)
    unsup = v1m & pyr.unsupported(dc, dcr, D0, near) & (wm[0] >= 0) & (wm[1] >= 0) & \
        (wm[0] <= sources[1].width - 1) & (wm[1] <= sources[1].height - 1)  # its partner in the image
    windows = pyr.fill_windows(unsup, sa, sb, dc)
    if band + 2 * per + pyr.fill_cost(windows) / g1.size > pyr.GAIN * whole:
        return None, 2 * per
    g2w, v2w, _ = rectified(rp, views[1], 1, sources[1], 0, 0, maps=wm)
    dp = disparity(g1, g2w, v1m, v2w, -R, R, penalty=penalty, partner=None if guide is None else guide - D0,
                   noise=noise)
    with np.errstate(invalid="ignore"):
        dp[np.abs(dp) > R - pyr.EDGE] = np.nan  # at the band's ends: the true disparity may lie beyond
    d = pyr.witnessed(pyr.resolve(dp, D0), dcr, near_border=near)
    with np.errstate(invalid="ignore"):
        d[(d < sa) | (d > sb)] = np.nan  # outside the strip's range: never the whole search's answer
    need = v1m & v2w & np.isnan(d) & unsup
    d, extra = pyr.fill_unsupported(d, g1, g2, v1m, v2m, need, windows, penalty, guide, noise)
    return (d, v2w, band + 2 * per + extra / g1.size, True), 2 * per


def _match(rp, views, sources, g1, v1m, g2, v2m, maps2, sa: float, sb: float, penalty, pyramid: bool,
           guide=None, noise=None) -> tuple:
    """``(d, partner valid, disparities searched per pixel, coarse)`` of a strip's windows (window columns, the
    right window's as read): with ``pyramid`` and a range of ``pyramid.MIN_RANGE`` px or more, coarse to fine
    (:func:`_coarse_to_fine`, :mod:`fotogeo.stereo.pyramid`: the right image read again through its maps resampled
    by the coarse offset, one interpolation of the source as before) where that searches at most ``pyramid.GAIN``
    of the whole range's disparities (the band, the coarse copies and the fill of the pixels they do not support),
    else the whole range (plus the coarse search already made); ``noise`` the images' σ (:func:`pair_noise`: the
    full-resolution matchings' texture test; the coarse copies, a guide only, keep the stretch's)."""
    coarse = 0.0  # disparities per pixel the coarse copies searched
    if pyramid and sb - sa >= pyr.MIN_RANGE:
        got, coarse = _coarse_to_fine(rp, views, sources, g1, v1m, g2, v2m, maps2, sa, sb, penalty, guide, noise)
        if got is not None:
            return got
    wc = g1.shape[1]
    d = disparity(g1, g2, v1m, v2m, sa, sb, penalty=penalty, partner=guide, noise=noise)
    shift = int(round(0.5 * (sa + sb)))  # matchable: the partner at the middle disparity lies in the image
    partner = np.zeros_like(v2m)
    if abs(shift) < wc:
        partner[:, max(0, shift):wc + min(0, shift)] = v2m[:, max(0, -shift):wc - max(0, shift)]
    return d, partner, disparity_range(sa, sb)[1] + coarse, False


def _strip(rp: RectifiedPair, views, sources, rng: tuple, zlim: tuple, stats: dict, core_box, colours: bool,
           refine: bool, penalty: float | None = None, near=None, dem=None, noise=None):
    """``(points, colours or None)`` of the rectified left pixels ``core_box`` ``(u0, r0, u1, r1)`` matched within
    the disparities ``rng`` ``(low, high, local)`` with ``MARGIN`` more rows and columns on either side and the
    columns the range's width needs (the right image's window shifted by the range's whole low end: the columns
    follow the width of the range, not its offset), coarse to fine with ``COARSE_TO_FINE`` (:func:`_match`); None when
    nothing matched. ``stats`` as :func:`dense_points`."""
    w, h = rp.size
    u0, r0, u1, r1 = core_box
    s = int(np.floor(rng[0]))  # the right image's window starts s columns left of the left's: search [sa, sb]
    sa, sb, local = rng[0] - s, rng[1] - s, rng[2]
    ca = max(0, min(u0, u0 - int(np.ceil(sb))) - MARGIN)
    cb = min(w, max(u1, u1 - int(np.floor(sa))) + MARGIN)
    a, b = max(0, r0 - MARGIN), min(h, r1 + MARGIN)
    g1, v1m, rgb1 = rectified(rp, views[0], 0, sources[0], a, b, ca, cb, colours=colours)
    maps2 = rp.maps(views[1], 1, a, b, ca - s, cb - s)
    g2, v2m, _ = rectified(rp, views[1], 1, sources[1], a, b, ca - s, cb - s, maps=maps2)
    if not v1m.any() or not v2m.any():
        return None
    guide = expected_disparity(rp, near, (a, b), (ca, cb), dem)
    d, partner, searched, coarse = _match(rp, views, sources, g1, v1m, g2, v2m, maps2, sa, sb, penalty,
                                          COARSE_TO_FINE, None if guide is None else guide - s, noise)
    stats["strips"] += 1
    stats["local_strips"] += int(local)
    stats["coarse_strips"] += int(coarse)
    stats["searched"] += g1.size * searched
    stats["searched_pixels"] += g1.size
    if refine:
        d = refine_disparities(g1, g2, d)
    core = (slice(r0 - a, r1 - a), slice(u0 - ca, u1 - ca))
    d, vm = d[core] + s, (v1m & partner)[core]
    rows, cols = np.nonzero(np.isfinite(d))
    stats["matchable"] += int(vm.sum())
    stats["matched"] += int((vm & np.isfinite(d)).sum())  # of the matchable pixels: a share of them
    if not len(rows):
        return None
    u, v = cols + u0 + HALF, rows + r0 + HALF
    P, _ = closest_points(rp.centres[0], rp.rays(u, v, 0), rp.centres[1], rp.rays(u - d[rows, cols], v, 1))
    ok = np.isfinite(P).all(axis=1) & (P[:, 2] >= zlim[0]) & (P[:, 2] <= zlim[1])
    rgb = None
    if rgb1 is not None:
        rgb = np.stack([c[core][rows, cols] for c in rgb1], axis=1)[ok]
    return P[ok], rgb


def dense_points(rp: RectifiedPair, views, sources, lo: float, hi: float, zlim: tuple, stats: dict, box=None,
                 colours: bool = False, refine: bool = False, near=None, penalty: float | None = None,
                 local: bool = True, dem=None, noise: tuple | None = None):
    """Yield ``(points (N, 3), colours (N, 3) uint8 or None)`` strip by strip (module docstring) of the rectified
    left pixels ``box`` ``(u0, v0, u1, v1)`` (default: all); ``[lo, hi]`` the pair's disparity range, ``near`` its
    sparse matches (:func:`guides`: each pixel's expected disparity, and when ``local`` each strip's range; None
    or not ``local``: every strip searches ``[lo, hi]``), ``dem`` the pair's :class:`.dem_guide.DemGuide` (the
    expected disparities and local ranges from the DEM's heights where it has them), ``zlim`` the heights kept;
    ``stats`` gets the matched and matchable pixel counts, the strips, those with a local range and the
    disparities searched (summed over the strips' pixels); ``refine``: the disparities refined by least-squares
    matching (:func:`fotogeo.stereo.refine.refine`); ``penalty`` the pair's penalty factor (:func:`pair_penalty`;
    None: each strip's own), ``noise`` the images' noise σ (:func:`pair_noise`; None: the texture test in
    levels of each strip's stretch only). The box is cut into strips of ``STRIP`` rows and its
    columns, each matched by :func:`_strip` with its source pixels read by windows: memory follows the strip, not
    the images."""
    w, h = rp.size
    u0, v0, u1, v1 = box or (0, 0, w, h)
    for k in ("matched", "matchable", "strips", "local_strips", "coarse_strips", "searched", "searched_pixels"):
        stats.setdefault(k, 0)
    for r0 in range(v0, v1, STRIP):
        core_box = (u0, r0, u1, min(v1, r0 + STRIP))
        rng = local_range(rp, near if local else None, core_box, lo, hi, dem if local else None)
        out = _strip(rp, views, sources, rng, strip_heights(near, core_box, zlim, rng[2], rp, dem), stats, core_box,
                     colours, refine, penalty, near, dem, noise)
        if out is not None:
            yield out
