"""``fotogeo dsm --rpc``: pairs of images with RPCs, locally epipolar tile by tile (s2p, de Franchis et al. 2014).

Per pair (left = the first image, right = the second):

1. **heights**: the RPCs' own range (``HEIGHT_OFF ± HEIGHT_SCALE``, with ``--dem`` the DEM's too) narrowed by
   the tie points of step 2; with ``--dem`` the DEM, fitted to the tie points, bounds each tile's (:mod:`.rpc_dem`);
2. **relative pointing correction** (:func:`fotogeo.stereo.affine_epipolar.pointing_correction`): SIFT tie points
   of the two images (whole up to ``TIE_SIDE`` pixels a side, else on copies averaged to that size), their
   offsets from the epipolar curves, one translation of the right image (the tie points agreeing on it within
   :func:`agreement_px`: 3 px, times the overviews' pixel size); its size is reported and, when large,
   named in a warning: the same error along the epipolar lines is invisible to the
   images and moves every height, so absolute heights then need a reference DEM or GCPs;
3. **tiles** of ``TILE`` left pixels: correspondences of a 3-D grid (the tile's pixels at three heights)
   through both models give the tile's rectifying similarities, the rectified tiles are matched
   (:func:`fotogeo.stereo.dense.disparity`) and every matched pixel is triangulated through the RPCs: its height
   is where the right pixel lies on the epipolar curve of the left pixel (the secant method along the curve:
   linear between the lowest and highest height, then between the last two estimates, ``SECANT_STEPS`` times;
   exact for an affine camera at once, and to well below a pixel's height for a perspective one, e.g. an RPC
   fitted to an aerial frame); the distance of the right pixel from the curve is its **miss distance** (pixels).
   With ``refine`` the disparities are first refined by least-squares matching (:func:`fotogeo.stereo.refine.refine`).
   Tiles follow the output grid (:class:`RpcPairMatch`, :func:`.matching.match_tiles`, as frame pairs do):
   each output tile's left pixels (its corners at the lowest and highest height through the left RPC) are cut
   into ``TILE`` pixel tiles, each rectified with its own local epipolar geometry from windows read from disk.
4. **planimetry halfway between the images**: the correction ``τ`` says how far the two RPCs disagree, not
   which one is wrong. The left pixel's line of sight at the height ``z`` gives ``X_L``; the right pixel's,
   uncorrected, ``X_R = X_L + Δ`` (``Δ`` the ground offset ``τ`` makes at ``z``); the point is put at
   ``X_L + Δ/2``. With independent pointing errors of equal size in the two images this halves the variance of
   the planimetric error against either image alone, and it is where a midpoint triangulation of the two
   measured rays puts the point (as CARS does); the height is unchanged (``τ`` has no component along the
   epipolar lines).

Heights are ellipsoidal (RPC00B).
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import cv2
import numpy as np

from ...errors import FotogeoWarning, InputError
from ...features.detect import detect
from ...pixels import HALF
from ...stereo import affine_epipolar as ae
from ...stereo.dense import disparity, to_uint8
from ...stereo.refine import refine as refine_disparities
from .frames import SPARSE_SIDE
from .rpc_dem import tile_range

TILE = 512
#: refinements of a matched pixel's height along the epipolar curve (module docstring, step 3)
SECANT_STEPS = 2
#: tie points are found on copies of the images at most this many pixels a side (larger images: averaged), as the
#: frames' sparse check does: SIFT's scale space on a larger copy would outgrow the matching tiles' memory
TIE_SIDE = SPARSE_SIDE
#: left pixels added around an output tile's box
BOX_PAD = 48
#: at most this many miss distances of each matched tile are kept for the report's median and 95th percentile
MISS_SAMPLE = 4096
#: the report lists at most this many tiles' disparity ranges
MAX_RANGES = 64
#: the relative pointing correction needs at least this many tie points, and as many agreeing on it (within
#: :func:`agreement_px`): fewer cannot tell a correction from a chance alignment of false matches
MIN_TIE_POINTS = 10
#: tie points agree on one relative pointing correction within this many pixels *of the overview they were found
#: on* (:func:`agreement_px`): SIFT's scatter there (NMAD 0.28 px on the ventoux pair) grows with the overview's
#: pixel size when it is multiplied back to source pixels
AGREEMENT_OVERVIEW_PX = 3.0
#: a relative pointing correction above this many pixels is reported as large (a few pixels are usual for
#: vendor RPCs without ground control)
LARGE_POINTING_PX = 10.0


def rpc_height_range(ims) -> tuple:
    """``(low, high)``: the union of the RPCs' ``HEIGHT_OFF ± HEIGHT_SCALE``, refused when unusable."""
    lo, hi = [], []
    for im in ims:
        norm = getattr(getattr(im.model, "model", None), "src_norm", None)
        off, scale = (float(norm.offset[2]), float(norm.scale[2])) if norm is not None else (np.nan, np.nan)
        if not (np.isfinite(off) and np.isfinite(scale) and 0 < scale < 10000 and -1000 < off < 9000):
            raise InputError(f"image {im.name!r}: its RPC states no usable height range (HEIGHT_OFF {off:g}, "
                             f"HEIGHT_SCALE {scale:g}); give a DEM of the area (--dem)")
        lo.append(off - scale)
        hi.append(off + scale)
    return max(-500.0, min(lo)), min(9000.0, max(hi))


def _models(m1, m2, tau):
    """``(q(p1, z))``: the right pixel of left pixels ``p1`` at heights ``z`` (corrected by ``tau``)."""
    def q(p1, z):
        P = m1.inverse(p1, z)
        return m2.forward(P) + tau, P
    return q


def tie_points(g1, g2, max_features: int = 5000) -> tuple:
    """``(p1, p2)`` ratio-tested SIFT matches (corner convention) of two grey images."""
    k1, k2 = (detect(to_uint8(g, g > 0).astype(np.float32), None, "sift", max_keypoints=max_features)
              for g in (g1, g2))
    if len(k1) < 8 or len(k2) < 8:
        return np.zeros((0, 2)), np.zeros((0, 2))
    good = [m[0] for m in cv2.BFMatcher(cv2.NORM_L2).knnMatch(k1.descriptors, k2.descriptors, k=2)
            if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
    return (k1.xy[[m.queryIdx for m in good]].reshape(-1, 2), k2.xy[[m.trainIdx for m in good]].reshape(-1, 2))


def overview(src) -> tuple:
    """``(grey, (sx, sy))``: image ``src`` (a :class:`~fotogeo.tools.dsm.inputs.SourceImage`) whole when its
    longer side is at most ``TIE_SIDE`` pixels, else averaged over blocks to about that size; ``(sx, sy)`` its
    pixels' size in source pixels."""
    k = max(1, -(-max(src.width, src.height) // TIE_SIDE))
    g = src.grey(0, 0, src.width, src.height, k)
    return g, (src.width / g.shape[1], src.height / g.shape[0])


def agreement_px(s1, s2) -> float:
    """The consensus threshold (source pixels) of tie points found on overviews of pixel sizes ``s1``, ``s2``
    (``(sx, sy)`` source pixels, :func:`overview`): ``AGREEMENT_OVERVIEW_PX`` times the larger size — 3 px for
    images whole, 3·k px on overviews averaged over k x k blocks."""
    return AGREEMENT_OVERVIEW_PX * max(1.0, *s1, *s2)


def pointing(m1, m2, sources, zlo, zhi) -> dict:
    """The relative pointing correction and the tie points' heights (module docstring, steps 1–2), the tie
    points found on :func:`overview` s of the two images."""
    (g1, s1), (g2, s2) = overview(sources[0]), overview(sources[1])
    p1, p2 = tie_points(g1, g2)
    p1, p2 = p1 * s1, p2 * s2
    names = " and ".join(repr(Path(s.path).stem) for s in sources)
    if len(p1) < MIN_TIE_POINTS:
        raise InputError(f"images {names}: only {len(p1)} tie points between them: they may not overlap, or be "
                         f"textureless or cloud-covered; give images that show the same ground")
    q = _models(m1, m2, np.zeros(2))
    q_lo, P_lo = q(p1, zlo)
    q_hi, _ = q(p1, zhi)
    ok = np.isfinite(q_lo).all(axis=1) & np.isfinite(q_hi).all(axis=1)
    p1, p2, q_lo, q_hi = p1[ok], p2[ok], q_lo[ok], q_hi[ok]
    within = agreement_px(s1, s2)
    tau, inl, res = ae.pointing_correction(p2, q_lo, q_hi, threshold=within)
    if inl.sum() < MIN_TIE_POINTS:
        raise InputError(f"images {names}: only {int(inl.sum())} of their {len(p1)} tie points agree on one relative "
                         f"pointing correction (within {within:.3g} px; {MIN_TIE_POINTS} needed), too few to tell "
                         f"it: the images may overlap too thinly (the others then match ground only one image "
                         f"shows), or show repetitive, textureless or cloud-covered ground; give images that overlap "
                         f"more")
    before = ae.curve_offsets(p2, q_lo, q_hi)[0]
    along = ae.curve_offsets(p2 - tau, q_lo, q_hi)[2]
    z = zlo + along * (zhi - zlo)
    m_per_px = (zhi - zlo) / np.hypot(*(q_hi - q_lo)[inl].T)  # the height of one pixel along the epipolar curve
    return {"tau": tau, "n": int(inl.sum()), "before_px": float(np.median(np.abs(before[inl]))),
            "after_px": float(np.median(np.abs(res[inl]))), "z": z[inl], "p1": p1[inl],
            "m_per_px": float(np.median(m_per_px))}


def triangulate(m1, m2, tau, p1, p2, zlo, zhi) -> tuple:
    """``(ground points (N, 3), miss distances (N,) px)`` of matched pixels (module docstring, step 3)."""
    q = _models(m1, m2, tau)
    za, qa = np.full(len(p1), float(zlo)), q(p1, zlo)[0]
    zb, qb = np.full(len(p1), float(zhi)), q(p1, zhi)[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        for _ in range(SECANT_STEPS):  # the secant along the curve: linear between the last two heights
            _, _, t = ae.curve_offsets(p2, qa, qb)
            z = za + t * (zb - za)
            move = np.abs(z - zb) > 1e-4  # a converged pixel keeps its (non-degenerate) last segment
            za[move], qa[move] = zb[move], qb[move]
            zb[move] = z[move]
            qb[move] = q(p1[move], zb[move])[0]
        off, _, t = ae.curve_offsets(p2, qa, qb)
        z2 = za + t * (zb - za)
    P = m1.inverse(p1, z2)
    P = np.column_stack([P[:, :2], z2])
    ok = np.isfinite(P).all(axis=1)
    if ok.any() and np.any(tau):  # halfway between the two images' geolocations (module docstring, step 4)
        half = m2.inverse(p2[ok], z2[ok])[:, :2] - m2.inverse(p2[ok] - tau, z2[ok])[:, :2]
        P[ok, :2] += 0.5 * half
    return P, np.abs(off)


def tile_correspondences(m1, q, tile, zs) -> tuple:
    """Left pixels of a 5 x 5 grid over ``tile`` (c0, r0, c1, r1) at heights ``zs``, their right pixels and the
    mask of the middle height."""
    c0, r0, c1, r1 = tile
    u, v = np.meshgrid(np.linspace(c0, c1, 5), np.linspace(r0, r1, 5))
    g = np.column_stack([u.ravel(), v.ravel()])
    p1 = np.vstack([g] * len(zs))
    p2 = np.vstack([q(g, z)[0] for z in zs])
    mid = np.repeat(np.arange(len(zs)) == len(zs) // 2, len(g))
    ok = np.isfinite(p2).all(axis=1)
    return p1[ok], p2[ok], mid[ok]


def _rectified(src, A, u0, v0, w, h):
    """Rectified image ``(h, w)`` of window ``(u0, v0)`` through the affine map ``A`` (raw → rectified) and its
    validity mask, resampled from the window of the :class:`~fotogeo.tools.dsm.inputs.SourceImage` ``src`` its
    pixels need (never the whole image)."""
    Ai = ae.invert(A)
    u, v = np.meshgrid(u0 + np.arange(w) + HALF, v0 + np.arange(h) + HALF)
    raw = ae.apply(Ai, np.column_stack([u.ravel(), v.ravel()])) - HALF
    mx, my = raw[:, 0].reshape(h, w), raw[:, 1].reshape(h, w)
    W, H = src.width, src.height
    valid = (mx >= 0) & (my >= 0) & (mx <= W - 1) & (my <= H - 1)
    if not valid.any():
        return np.zeros((h, w), np.float32), valid
    x0, y0 = max(0, int(np.floor(mx[valid].min())) - 3), max(0, int(np.floor(my[valid].min())) - 3)
    x1, y1 = min(W, int(np.ceil(mx[valid].max())) + 4), min(H, int(np.ceil(my[valid].max())) + 4)
    g = src.grey(x0, y0, x1, y1)
    out = cv2.remap(g, (mx - x0).astype(np.float32), (my - y0).astype(np.float32), cv2.INTER_CUBIC,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return out, valid


def window_margins(lo: float, hi: float) -> tuple:
    """``(before, after)``: the columns the rectified window of a tile takes before and after the tile's own for
    disparities ``[lo, hi]`` (``d = u_left − u_right``), so that every pixel of the tile keeps both directions of the
    left–right check (:func:`fotogeo.stereo.dense.disparity`). SGBM leaves a left column ``x`` without a disparity
    when ``x − d_min`` falls beyond the image's last column (``d_min = ⌊lo⌋ < 0``), and so the right-to-left pass
    (matched on the flipped images) leaves the right columns ``x_r < −d_min``; the partner ``x_r = x − d`` of a
    tile's pixel at disparity up to ``hi`` is among them unless the tile starts ``hi − d_min`` columns in — the
    range's width, not its larger end ``max(|lo|, |hi|)``, which cut the last ~35 columns of every tile whose
    heights lay near the range's low end (a DEM's range, issue 30). 16 columns more each side: the block and the
    rounding of SGBM's range."""
    from ...stereo.dense import disparity_range
    dmin = disparity_range(lo, hi)[0]
    return int(np.ceil(max(hi, 0.0))) + max(0, -dmin) + 16, int(np.ceil(max(abs(lo), abs(hi)))) + 16


def match_tile(m1, m2, tau, sources, tile, zlo, zhi, stats, refine: bool = False, noise=None) -> tuple:
    """``(left pixels (N, 2), right pixels (N, 2))`` of one tile's dense matches (module docstring, step 3), the
    rectified tiles read from the windows of the two :class:`~fotogeo.tools.dsm.inputs.SourceImage` s
    ``sources`` they need; ``noise`` the two images' noise σ (the texture test's, :mod:`fotogeo.stereo.texture`)."""
    q = _models(m1, m2, tau)
    p1g, p2g, mid = tile_correspondences(m1, q, tile, (zlo, 0.5 * (zlo + zhi), zhi))
    A1, A2 = ae.rectifying_maps(p1g, p2g, mid)
    d = ae.apply(A1, p1g)[:, 0] - ae.apply(A2, p2g)[:, 0]
    lo, hi = float(d.min()) - 4.0, float(d.max()) + 4.0
    c0, r0, c1, r1 = tile
    corners = ae.apply(A1, np.array([[c0, r0], [c1, r0], [c1, r1], [c0, r1]], float))
    before, after = window_margins(lo, hi)
    u0, v0 = int(np.floor(corners[:, 0].min())) - before, int(np.floor(corners[:, 1].min())) - 16
    w, h = int(np.ceil(corners[:, 0].max())) + after - u0, int(np.ceil(corners[:, 1].max())) + 16 - v0
    L, vl = _rectified(sources[0], A1, u0, v0, w, h)
    R, vr = _rectified(sources[1], A2, u0, v0, w, h)
    disp = disparity(L, R, vl, vr, lo, hi, noise=noise)
    if refine:
        disp = refine_disparities(L, R, disp)
    rows, cols = np.nonzero(np.isfinite(disp))
    u, v = u0 + cols + HALF, v0 + rows + HALF
    p1 = ae.apply(ae.invert(A1), np.column_stack([u, v]))
    p2 = ae.apply(ae.invert(A2), np.column_stack([u - disp[rows, cols], v]))
    inside = (p1[:, 0] >= c0) & (p1[:, 0] < c1) & (p1[:, 1] >= r0) & (p1[:, 1] < r1)
    shift = int(round(0.5 * (lo + hi)))  # matchable: valid left pixels whose partner at the middle disparity is
    partner = np.zeros_like(vr)           # valid in the right image, inside the tile
    if abs(shift) < w:
        partner[:, max(0, shift):w + min(0, shift)] = vr[:, max(0, -shift):w - max(0, shift)]
    rr, cc = np.nonzero(vl & partner)
    m = ae.apply(ae.invert(A1), np.column_stack([u0 + cc + HALF, v0 + rr + HALF]))
    stats["matchable"] = stats.get("matchable", 0) + int(((m[:, 0] >= c0) & (m[:, 0] < c1) & (m[:, 1] >= r0) &
                                                          (m[:, 1] < r1)).sum())
    stats["matched"] = stats.get("matched", 0) + int(inside.sum())
    stats.setdefault("disparity_ranges_px", []).append([round(lo, 2), round(hi, 2)])
    return p1[inside], p2[inside]


def _at_least(a: int, b: int, n: int) -> tuple:
    """``[a, b)`` widened about its middle to at least ``TILE`` (or ``n``) pixels, inside ``[0, n)``."""
    grow = max(0, min(TILE, n) - (b - a))
    a = max(0, a - grow // 2)
    b = min(n, max(b, a + min(TILE, n)))
    return max(0, min(a, b - min(TILE, n))), b


def box_points(m1, m2, sources, zlo, zhi, tau, stats, box, colours: bool = False, refine: bool = False, dem=None,
               noise=None):
    """Yield ``(points (N, 3), colours (N, 3) uint8 or None, miss px (N,))`` of the left pixels ``box``
    ``(c0, r0, c1, r1)`` (widened to at least ``TILE`` pixels a side: the context of a small box), in equal locally
    epipolar tiles of at most ``TILE`` pixels a side (module docstring, step 3; ``refine`` too); ``colours``: the
    left image's, read by the window of the tile's matched pixels; ``dem`` a :class:`.dem_guide.DemGuide`: each
    tile's heights (:func:`.rpc_dem.tile_range`)."""
    W, H = sources[0].width, sources[0].height
    (c0, c1), (r0, r1) = _at_least(box[0], box[2], W), _at_least(box[1], box[3], H)
    nc, nr = -(-(c1 - c0) // TILE), -(-(r1 - r0) // TILE)
    cs, rs = np.linspace(c0, c1, nc + 1).round().astype(int), np.linspace(r0, r1, nr + 1).round().astype(int)
    for rt, rt1 in zip(rs[:-1], rs[1:]):
        for ct, ct1 in zip(cs[:-1], cs[1:]):
            tile = (int(ct), int(rt), int(ct1), int(rt1))
            zl, zh = (zlo, zhi) if dem is None else tile_range(m1, dem, tile, zlo, zhi)
            p1, p2 = match_tile(m1, m2, tau, sources, tile, zl, zh, stats, refine, noise)
            if not len(p1):
                continue
            P, miss = triangulate(m1, m2, tau, p1, p2, zl, zh)
            ok = np.isfinite(P).all(axis=1) & (P[:, 2] >= zl) & (P[:, 2] <= zh)
            rgb = None
            if colours:
                src = sources[0]
                c = np.clip(p1[:, 0].astype(int), 0, src.width - 1)
                r = np.clip(p1[:, 1].astype(int), 0, src.height - 1)
                x0, y0 = int(c.min()), int(r.min())
                rgb = np.stack([ch[r - y0, c - x0] for ch in src.colours(x0, y0, int(c.max()) + 1,
                                                                         int(r.max()) + 1)], axis=1)[ok]
            yield P[ok], rgb, miss[ok]


class RpcPairMatch:
    """One RPC pair ready to match tile by tile (the interface of :class:`.matching.PairMatch`): the left and right
    models ``m1``, ``m2`` (map coordinates ↔ pixels), :class:`~fotogeo.tools.dsm.inputs.SourceImage` s, the
    height range, the relative pointing correction ``tau``, and what its tiles gave (pixel counts, points, a
    sample of the miss distances, seconds)."""

    def __init__(self, pair, name: str, models, sources, zlim, tau, refine: bool = False, dem=None):
        self.pair, self.name, self.models, self.sources, self.dem = pair, name, models, sources, dem
        self.zlim, self.tau, self.refine = (float(zlim[0]), float(zlim[1])), np.asarray(tau, float), refine
        self.stats, self.points, self.seconds, self.miss = {}, 0, 0.0, []
        self.noise = tuple(s.noise() for s in sources)  # once per image, here: a Dask task gets the values

    def box(self, sub) -> tuple | None:
        """``(c0, r0, c1, r1)``: the left pixels whose points may fall in the grid ``sub``: a 3 x 3 grid over it
        at the lowest and highest height through the left RPC, padded by ``BOX_PAD`` pixels; None outside."""
        xs = sub.x0 + sub.resolution * sub.width * np.array([0.0, 0.5, 1.0])
        ys = sub.y0 - sub.resolution * sub.height * np.array([0.0, 0.5, 1.0])
        P = np.array([(x, y, z) for x in xs for y in ys for z in self.zlim], float)
        px = self.models[0].forward(P)
        px = px[np.isfinite(px).all(axis=1)]
        src = self.sources[0]
        if not len(px):
            return None
        c0, r0 = (max(0, int(np.floor(v)) - BOX_PAD) for v in px.min(axis=0))
        c1, r1 = min(src.width, int(np.ceil(px[:, 0].max())) + BOX_PAD), min(src.height,
                                                                            int(np.ceil(px[:, 1].max())) + BOX_PAD)
        return (c0, r0, c1, r1) if c1 > c0 and r1 > r0 else None

    def dense(self, box, colours: bool = False):
        """Yield ``(points (N, 3), colours or None)`` of the left pixels ``box`` (:func:`box_points`)."""
        for P, rgb, miss in box_points(*self.models, self.sources, *self.zlim, self.tau, self.stats, box, colours,
                                       self.refine, self.dem, self.noise):
            self.miss.append(miss[::max(1, len(miss) // MISS_SAMPLE)])
            yield P, rgb

    def report(self) -> None:
        """The pair's entry in the report (match density, points, disparity ranges, miss distances)."""
        m = np.concatenate(self.miss) if self.miss else np.zeros(0)
        self.pair.extra.update(
            match_density=round(self.stats.get("matched", 0) / max(1, self.stats.get("matchable", 0)), 4),
            points=self.points, disparity_ranges_px=self.stats.get("disparity_ranges_px", [])[:MAX_RANGES],
            ray_miss_px=({"median": round(float(np.median(m)), 4), "p95": round(float(np.percentile(m, 95)), 4)}
                         if len(m) else None))


def pointing_warning(name, pt: dict, have_dem: bool) -> str:
    """The warning about a large relative pointing error ("" when small)."""
    size = float(np.hypot(*pt["tau"]))
    if size <= LARGE_POINTING_PX:
        return ""
    dem = ("the DEM (--dem) measures how far the heights lie from it (the report's pairs[].dem.offset_m) but does "
           "not move them" if have_dem else "a reference DEM (--dem) would measure how far the heights lie from it "
           "(the report's pairs[].dem.offset_m) but not move them")
    return (f"pair {name}: the relative pointing error of the RPCs was large ({size:.1f} px across the epipolar "
            f"lines, corrected from {pt['n']} tie points); the same error along the lines cannot be seen in the "
            f"images and shifts every height by {pt['m_per_px']:.2g} m per pixel, so absolute heights need GCPs: "
            f"correct the RPCs with them (fotogeo rpc-bias, one image at a time) and make the DSM from the "
            f"corrected images; {dem}")


def warn(text: str) -> None:
    if text:
        warnings.warn(text, FotogeoWarning, stacklevel=5)


def now() -> float:
    return time.perf_counter()
