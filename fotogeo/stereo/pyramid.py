"""Coarse-to-fine disparity search: the disparities of a coarse copy of a rectified pair bound, pixel by pixel,
the narrow band the full-resolution matching searches.

Semi-global matching costs pixels x disparities, and over a slope or a relief the disparities of one piece of a
rectified pair span hundreds of pixels while each pixel's own lies within a few of its neighbours'. As the
hierarchical matchers do (MicMac's pyramid, Pierrot-Deseilligny & Paparoditis 2006; the coarse-to-fine SGM of
Rothermel et al. 2012, SURE), the pair is first matched on copies ``FACTOR`` times smaller (pixel areas averaged),
over the whole range divided by ``FACTOR`` (:func:`coarse_disparity`: ``FACTOR³`` times less work); then
:func:`guide` turns the coarse disparities into an offset ``D0(x, y)`` and one half-width ``R`` for the piece:

* the coarse holes are filled by push-pull interpolation (:func:`fill_holes`: averages over ever coarser
  levels, then pulled back down; Gortler et al. 1996), so that a pixel without a coarse match gets the surface of
  its surroundings;
* a pixel's coarse envelope is the lowest and the highest (filled) coarse disparity within ``RADIUS`` coarse
  pixels of it (a step of the surface — a roof edge, a tree — lies within the envelope of the pixels beside it);
  ``D0`` is the envelope's middle smoothed by a Gaussian of ``SMOOTH`` coarse pixels and, at full resolution,
  kept so that ``x − D0(x)`` never decreases along a row (a step of the coarse surface would otherwise fold the
  resampled image onto itself); ``R`` is the ``PERCENTILE`` th percentile over the piece of the envelope's reach
  from the smoothed middle, plus ``PAD`` coarse pixels (the coarse disparities' own error), times ``FACTOR``.

The full-resolution right image is resampled along its rows by the offset, ``R'(x', y) = R(x' − D0(x', y), y)``
(rows stay epipolar), and matched against the left image within ``[−R, R]``; a disparity ``d'`` found in that
frame is the disparity ``d = d' + D0(x − d', y)`` of the pair (:func:`resolve`: the left pixel ``x`` meets
``x' = x − d'`` of ``R'``, i.e. ``x' − D0(x')`` of ``R``). The left–right check, the sub-pixel error
cancellation and the filters of :func:`fotogeo.stereo.dense.disparity` work in that frame unchanged; the caller
drops disparities within ``EDGE`` px of the band's ends (the pixel's own may lie beyond the band).

Within the band both directions of that left–right check are held to the band, so a left pixel without a partner
(beyond the overlap's edge, where the coarse copy has no match and ``D0`` is extrapolated) can meet a wrong right
pixel that meets it back. The coarse matching over the whole range is the independent witness
(:func:`witnessed`): the right image's coarse disparities (the same matching, images mirrored) must put the right
pixel ``x − d`` within ``WITNESS`` coarse pixels of ``d``; where the right pixel has none (a hole of the coarse
right matching: low texture, an occlusion, a speckle removed), ``d`` must lie within ``WITNESS`` of the envelope of
those within ``WITNESS_NEAR`` coarse pixels of it (:func:`witness_envelope`), except near a border
(:func:`near_border`), where the wrong matches come from and the right pixel's own is required. The pixels the
coarse matching does not support near the images' borders (:func:`unsupported`) are matched over the range of the
coarse disparities around them (:func:`fill_unsupported`), in windows derived once (:func:`fill_windows`: what the
choice of the search reads is what is matched) and joined down a border where that costs less.
"""
from __future__ import annotations

import cv2
import numpy as np

from .dense import disparity, disparity_range, right_expected

#: the coarse copies are this many times smaller per side
FACTOR = 4
#: coarse pixels around a pixel whose disparities make its envelope
RADIUS = 2
#: coarse pixels added to the envelope's half-width (the coarse disparities' error)
PAD = 1.5
#: the standard deviation (coarse pixels) of the Gaussian that smooths the envelope's middle into the offset
SMOOTH = 2.0
#: the percentile of the envelope's half-width over the piece that sets the band
PERCENTILE = 99.0
#: full-resolution disparities this close to the band's ends are dropped (the pixel's may lie beyond the band)
EDGE = 1.0
#: ranges narrower than this (full-resolution pixels) are searched whole: the coarse step would not pay
MIN_RANGE = 96
#: a fine disparity is kept only if the coarse disparity of the right pixel it meets lies within this many
#: coarse pixels of it (:func:`witnessed`)
WITNESS = 1.0
#: a right pixel without a coarse disparity is witnessed by those within this many coarse pixels of it
#: (:func:`witness_envelope`)
WITNESS_NEAR = 2
#: the pixels the coarse matching does not support are matched over the whole range in blocks of this many
#: rows, with this many more rows and columns around (:func:`fill_unsupported`)
FILL_ROWS = 64
FILL_CONTEXT = 48
#: a run's fill searches the coarse disparities within FILL_NEAR coarse pixels of it, FILL_PAD px wider
FILL_NEAR = 8
FILL_PAD = 32
#: coarse pixels from an invalid coarse pixel within which an unsupported pixel is matched over the whole range
BORDER = 6
#: a piece is matched coarse to fine only if the disparities that would search (the band, the coarse copies and the
#: fill, :func:`fill_cost`) are at most this share of its whole range's; else it is searched whole
GAIN = 0.5
#: the coarse matching's filters (:func:`~fotogeo.stereo.dense.disparity`'s keywords)
COARSE_FILTERS: dict = {}
#: fewer coarse disparities than this share of the coarse left pixels, or than ``MIN_COARSE``, and the piece is
#: searched whole (a sliver of overlap: its coarse copy's matches agree both ways and yet may all be wrong)
MIN_MATCHED = 0.02
MIN_COARSE = 2000


def shrink(img, factor: int) -> np.ndarray:
    """``img`` averaged over ``factor x factor`` pixels (the rows and columns beyond a multiple dropped)."""
    h, w = (s // factor for s in img.shape[:2])
    a = np.asarray(img, np.float32)[:h * factor, :w * factor]
    return a.reshape(h, factor, w, factor).mean(axis=(1, 3))


def coarse_disparity(left, right, valid_left, valid_right, lo: float, hi: float, factor: int | None = None,
                     penalty: float | None = None, side: str = "left", partner=None):
    """Disparities (coarse pixels, NaN where none) of the pair shrunk ``factor`` (default ``FACTOR``) times
    within ``[lo, hi]`` full pixels: :func:`~fotogeo.stereo.dense.disparity` with its filters, without the
    sub-pixel cancellation; of the left image's pixels (``side="left"``), of the right image's (``"right"``: the
    same matching with the images' roles and rows mirrored, a right pixel ``x`` meets the left pixel ``x + d``),
    or ``(left's, right's)`` (``"both"``); ``partner``: the left pixels' expected disparities (full pixels, NaN
    where unknown, :func:`~fotogeo.stereo.dense.disparity`), the right side's matching given the right pixels'
    (:func:`~fotogeo.stereo.dense.right_expected`): each side's pixels without a partner are refused, not lined up
    with the other side's, as the left side's (the right side's disparities are the witness of the fine ones and
    decide which pixels are unsupported)."""
    factor = factor or FACTOR
    vl = shrink(valid_left, factor) >= 1.0
    vr = shrink(valid_right, factor) >= 1.0
    L, R = shrink(left, factor), shrink(right, factor)
    kw = dict(half_shift=False, penalty=penalty, **COARSE_FILTERS)
    lo, hi = lo / factor, hi / factor
    # SGBM leaves a matched image's first max(dmax, 0) columns and last max(-dmin, 0) without a disparity: padded
    # with invalid columns there, every column of the copy is searched (partners in the padding are refused)
    dmin, n = disparity_range(lo, hi)
    a, b = max(dmin + n, 0) + 1, max(-dmin, 0) + 1
    g = None if partner is None else shrink(partner, factor) / factor
    dl = dr = None
    if side in ("left", "both"):
        pad = lambda m, v=0: np.pad(m, ((0, 0), (a, b)), constant_values=v)
        dl = disparity(pad(L), pad(R), pad(vl), pad(vr), lo, hi, partner=None if g is None else pad(g, np.nan),
                       **kw)[:, a:a + L.shape[1]]
    if side in ("right", "both"):
        pad = lambda m, v=0: np.pad(m, ((0, 0), (b, a)), constant_values=v)[:, ::-1]
        gr = None if g is None else pad(right_expected(g), np.nan)  # a right pixel's, mirrored: the same values
        dr = disparity(pad(R), pad(L), pad(vr), pad(vl), lo, hi, partner=gr, **kw)[:, ::-1]
        dr = np.ascontiguousarray(dr[:, b:b + R.shape[1]])
    return {"left": dl, "right": dr, "both": (dl, dr)}[side]


def _at(dc, x, factor: int) -> np.ndarray:
    """The coarse disparities ``dc`` (full-resolution pixels) of the blocks holding the full-resolution columns
    ``x`` (rows ``0, 1, …`` of ``x``); NaN outside ``dc`` or where ``x`` is NaN."""
    hc, wc = dc.shape
    with np.errstate(invalid="ignore"):
        inside = np.isfinite(x) & (x >= 0) & (x < wc * factor)
        bx = (np.where(inside, x, 0) // factor).astype(np.intp)
    by = np.minimum(np.arange(x.shape[0]) // factor, hc - 1)[:, None]
    return np.where(inside, factor * dc[np.broadcast_to(by, x.shape), bx], np.nan)


def witness_envelope(dc_right) -> tuple:
    """``(low, high)`` (coarse pixels, ``dc_right``'s shape): the right image's coarse disparity where it has one;
    where it has none, the lowest and the highest of those within ``WITNESS_NEAR`` coarse pixels (the coverage gap
    bounded by its neighbours, :func:`witnessed`); NaN where none lies that near."""
    ok = np.isfinite(dc_right)
    k = np.ones((2 * WITNESS_NEAR + 1, 2 * WITNESS_NEAR + 1), np.uint8)
    lo = cv2.erode(np.where(ok, dc_right, np.inf).astype(np.float32), k, borderValue=np.inf)
    hi = cv2.dilate(np.where(ok, dc_right, -np.inf).astype(np.float32), k, borderValue=-np.inf)
    near = np.isfinite(lo) & np.isfinite(hi)
    lo, hi = np.where(ok, dc_right, np.where(near, lo, np.nan)), np.where(ok, dc_right, np.where(near, hi, np.nan))
    return lo.astype(np.float32), hi.astype(np.float32)


def witnessed(d, dc_right, factor: int | None = None, near_border=None) -> np.ndarray:
    """``d`` (full-resolution disparities of the left pixels) with NaN where the coarse matching over the whole
    range, an independent witness, does not confirm it: the right pixel ``x − d`` meets has a coarse disparity
    more than ``WITNESS`` coarse pixels from ``d``, or none and ``d`` lies more than ``WITNESS`` beyond the
    envelope of the coarse disparities within ``WITNESS_NEAR`` of it (:func:`witness_envelope`: a hole of the
    coarse right matching — low texture, an occlusion, a speckle removed — is bounded by the surface around it),
    or none and none near. Where ``near_border`` (bool, ``d``'s shape) is True the right pixel's own coarse
    disparity is required (the envelope is not read): at the overlap's edge a left pixel without a partner can
    meet a wrong right pixel that meets it back within the band (module docstring)."""
    factor = factor or FACTOR
    i = np.flatnonzero(np.isfinite(d))  # the matched pixels only (flat indices: one gather per array)
    dv = d.ravel()[i]
    r, c = np.divmod(i, d.shape[1])
    xr = np.rint(c.astype(np.float32) - dv)
    hc, wc = dc_right.shape
    inside = (xr >= 0) & (xr < wc * factor)
    cell = np.minimum(r // factor, hc - 1) * wc + np.where(inside, xr, 0).astype(np.intp) // factor  # integer //
    lo, hi = witness_envelope(dc_right)
    a, b = factor * lo.ravel()[cell], factor * hi.ravel()[cell]
    if near_border is not None:
        nb = near_border.ravel()[i]
        a[nb] = b[nb] = factor * dc_right.ravel()[cell[nb]]
    with np.errstate(invalid="ignore"):
        keep = inside & (dv >= a - factor * WITNESS) & (dv <= b + factor * WITNESS)
    out = np.full(d.shape, np.nan, np.float32)
    out.ravel()[i[keep]] = dv[keep]
    return out


def near_border(D0, valid_left, valid_right, factor: int | None = None) -> np.ndarray:
    """Pixels (bool, ``D0``'s shape) within ``BORDER`` coarse pixels of an invalid coarse pixel of the left image,
    or whose right pixel ``x − D0`` is of the right's (or outside it)."""
    factor = factor or FACTOR
    k = np.ones((2 * BORDER + 1, 2 * BORDER + 1), np.uint8)
    near_l, near_r = (cv2.dilate((shrink(v, factor) < 1.0).astype(np.uint8), k).astype(np.float32)
                      for v in (valid_left, valid_right))
    x = np.broadcast_to(np.arange(D0.shape[1], dtype=np.float32)[None, :], D0.shape)
    with np.errstate(invalid="ignore"):
        return ~(_at(near_l, x, factor) < 1.0) | ~(_at(near_r, np.rint(x - D0), factor) < 1.0)  # NaN: outside


def unsupported(dc_left, dc_right, D0, near, factor: int | None = None) -> np.ndarray:
    """Pixels (bool, ``D0``'s shape) ``near`` an image's border (:func:`near_border`) that the coarse matching does
    not support: without a coarse disparity of their own or of their right pixel ``x − D0``
    (:func:`fill_unsupported` matches them; elsewhere the coarse copy saw the pixel and found nothing, as the whole
    range would)."""
    factor = factor or FACTOR
    x = np.broadcast_to(np.arange(D0.shape[1], dtype=np.float32)[None, :], D0.shape)
    with np.errstate(invalid="ignore"):
        bare = ~np.isfinite(_at(dc_left, x, factor)) | ~np.isfinite(_at(dc_right, np.rint(x - D0), factor))
    return near & bare


def _columns(a, c0: int, c1: int) -> np.ndarray:
    """Columns ``c0:c1`` of ``a``, zeros (invalid) where they fall outside it."""
    out = np.zeros((a.shape[0], c1 - c0), a.dtype)
    i0, i1 = max(c0, 0), min(c1, a.shape[1])
    if i1 > i0:
        out[:, i0 - c0:i1 - c0] = a[:, i0:i1]
    return out


def _run_range(dc, rows: slice, run, lo: float, hi: float, factor: int) -> tuple:
    """The disparities (full px) the coarse matches within ``FILL_NEAR`` coarse pixels of a run span, widened by
    ``FILL_PAD`` px and kept inside ``[lo, hi]``; ``(lo, hi)`` without any."""
    r0, r1 = max(0, rows.start // factor - FILL_NEAR), rows.stop // factor + FILL_NEAR + 1
    c0, c1 = max(0, run[0] // factor - FILL_NEAR), run[-1] // factor + FILL_NEAR + 1
    near = dc[r0:r1, c0:c1]
    near = near[np.isfinite(near)]
    if not near.size:
        return lo, hi
    a, b = max(lo, factor * float(near.min()) - FILL_PAD), min(hi, factor * float(near.max()) + FILL_PAD)
    return (a, b) if b > a else (lo, hi)


class FillWindow:
    """A window :func:`fill_unsupported` matches: ``cores`` (pairs of slices) whose needing pixels it fills,
    within ``span`` ``(r0, r1, c0, c1)`` (the rows and columns the cores cover); the range ``[ra, rb]`` it
    searches. Its rows and columns (slices of the left image: ``FILL_CONTEXT`` more rows and columns around the
    cores, and the range's width more columns on either side, so that the right pixels the left–right check reads
    keep every left pixel they may meet), the right window's shift ``t`` (it starts ``t`` columns left of the left
    one's), the disparities ``n`` and ``cost`` (window pixels x ``n``) follow from those and the image's
    ``shape``."""

    def __init__(self, cores: list, span: tuple, ra: float, rb: float, shape: tuple):
        self.cores, self.span, self.ra, self.rb, self.shape = cores, span, ra, rb, shape
        (r0, r1, c0, c1), (rows, cols), ctx = span, shape, FILL_CONTEXT
        self.t = int(np.floor(ra))
        dmin, self.n = disparity_range(ra - self.t, rb - self.t)
        self.rows = slice(max(0, r0 - ctx), min(rows, r1 + ctx))
        self.cols = slice(max(0, c0 - (dmin + self.n) - ctx), min(cols, c1 + ctx + dmin + self.n))
        self.cost = (self.rows.stop - self.rows.start) * (self.cols.stop - self.cols.start) * self.n

    def merged(self, other) -> "FillWindow":
        """One window holding both windows' cores, over their spans' and ranges' union."""
        a, b = self.span, other.span
        span = (min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3]))
        return FillWindow(self.cores + other.cores, span, min(self.ra, other.ra), max(self.rb, other.rb), self.shape)


def _join(above: list, w: FillWindow) -> FillWindow:
    """``w`` joined with the window of ``above`` (the block above's) whose columns it meets within
    ``2 FILL_CONTEXT`` and whose joining saves the most disparities (that one taken out of ``above``: None in
    its place); ``w`` itself when none saves any."""
    best, gain = None, 0
    for k, u in enumerate(above):
        if u is None or u.span[2] - 2 * FILL_CONTEXT > w.span[3] or w.span[2] > u.span[3] + 2 * FILL_CONTEXT:
            continue
        m = u.merged(w)
        if u.cost + w.cost - m.cost > gain:
            best, gain = (k, m), u.cost + w.cost - m.cost
    if best is None:
        return w
    above[best[0]] = None
    return best[1]


def fill_windows(need, lo: float, hi: float, dc=None, factor: int | None = None) -> list:
    """The :class:`FillWindow` s :func:`fill_unsupported` matches the ``need`` pixels in: per block of
    ``FILL_ROWS`` rows, each run of needing columns (gaps under ``2 FILL_CONTEXT`` joined) over the range the
    coarse disparities ``dc`` near it span (:func:`_run_range`; ``[lo, hi]`` without ``dc`` or any near). A run
    joins the window of the blocks above whose columns it meets when the joined window costs less than the two
    (a band of needing pixels down an image's border is then one window, its rows' context paid once)."""
    factor = factor or FACTOR
    shape, ctx = need.shape, FILL_CONTEXT
    done, above = [], []
    for r0 in range(0, shape[0], FILL_ROWS):
        r1 = min(shape[0], r0 + FILL_ROWS)
        cs = np.flatnonzero(need[r0:r1].any(axis=0))
        here = []
        for run in np.split(cs, np.flatnonzero(np.diff(cs) > 2 * ctx) + 1) if len(cs) else []:
            ra, rb = (lo, hi) if dc is None else _run_range(dc, slice(r0, r1), run, lo, hi, factor)
            w = FillWindow([(slice(r0, r1), slice(run[0], run[-1] + 1))], (r0, r1, run[0], run[-1] + 1), ra, rb,
                           shape)
            here.append(_join(above, w))
        done += [u for u in above if u is not None]
        above = here
    return done + above


def fill_cost(windows) -> int:
    """The disparities :func:`fill_unsupported` would search in ``windows`` (:func:`fill_windows`) if each had a
    pixel to fill: window pixels x their ranges, summed (what the choice of the search reads: an upper bound)."""
    return sum(w.cost for w in windows)


def fill_unsupported(d, left, right, valid_left, valid_right, need, windows, penalty: float | None = None,
                     partner=None, noise: tuple | None = None) -> tuple:
    """``(d, disparities searched)``: ``d`` with its ``need`` pixels matched by
    :func:`~fotogeo.stereo.dense.disparity` in the ``windows`` (:func:`fill_windows` of these or more pixels,
    derived once: a window whose cores hold no needing pixel is skipped), the right window shifted by its range's
    low end; the others untouched; ``partner`` the left pixels' expected disparities (NaN where unknown),
    ``noise`` the images' noise σ (the texture test's, :func:`~fotogeo.stereo.dense.disparity`)."""
    searched, d = 0, d.copy()
    for w in windows:
        if not any(need[core].any() for core in w.cores):
            continue
        rs, cs, t = w.rows, w.cols, w.t
        L, R = left[rs, cs], _columns(right[rs], cs.start - t, cs.stop - t)
        dd = disparity(L, R, valid_left[rs, cs], _columns(valid_right[rs], cs.start - t, cs.stop - t), w.ra - t,
                       w.rb - t, penalty=penalty, partner=None if partner is None else partner[rs, cs] - t,
                       noise=noise) + t
        searched += dd.size * w.n
        for core in w.cores:
            got = dd[core[0].start - rs.start:core[0].stop - rs.start,
                     core[1].start - cs.start:core[1].stop - cs.start]
            take = need[core] & np.isfinite(got)
            d[core][take] = got[take]
    return d, searched


def fill_holes(d) -> np.ndarray:
    """``d`` (NaN where none) with its holes filled by push-pull interpolation: NaN-aware 2 x 2 averages down to
    a level without holes, each level's holes then filled from the next coarser one (bilinear); all NaN stays
    all NaN."""
    d = np.asarray(d, np.float32)
    ok = np.isfinite(d)
    if ok.all() or not ok.any():
        return d.copy()
    w = ok.astype(np.float32)
    v = np.where(ok, d, 0.0).astype(np.float32)
    h, wd = d.shape
    hp, wp = -(-h // 2) * 2, -(-wd // 2) * 2
    v2 = np.pad(v, ((0, hp - h), (0, wp - wd)))
    w2 = np.pad(w, ((0, hp - h), (0, wp - wd)))
    sv = v2.reshape(hp // 2, 2, wp // 2, 2).sum(axis=(1, 3))
    sw = w2.reshape(hp // 2, 2, wp // 2, 2).sum(axis=(1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        coarse = fill_holes(np.where(sw > 0, sv / sw, np.nan))
    up = cv2.resize(coarse, (wp, hp), interpolation=cv2.INTER_LINEAR)[:h, :wd]
    return np.where(ok, d, up).astype(np.float32)


def guide(dc, shape: tuple, valid_left, factor: int | None = None) -> tuple | None:
    """``(D0 (rows, cols) float32, R)``: the offset and the band's half-width (full-resolution pixels) of a piece
    of ``shape`` from its coarse disparities ``dc`` (shrunk ``factor`` times, default ``FACTOR``; module
    docstring); None when too few coarse pixels matched (the piece is then searched whole)."""
    factor = factor or FACTOR
    vl = shrink(valid_left, factor) >= 1.0
    ok = np.isfinite(dc)
    if ok.sum() < max(MIN_COARSE, MIN_MATCHED * vl.sum()):
        return None
    f = fill_holes(dc)
    k = np.ones((2 * RADIUS + 1, 2 * RADIUS + 1), np.uint8)
    lower, upper = cv2.erode(f, k), cv2.dilate(f, k)
    mid = cv2.GaussianBlur(0.5 * (upper + lower), (0, 0), SMOOTH)
    reach = np.maximum(upper - mid, mid - lower)
    inside = vl if vl.any() else np.ones_like(vl)
    R = factor * (float(np.percentile(reach[inside], PERCENTILE)) + PAD)
    h, w = shape
    D0 = cv2.resize(factor * mid, (mid.shape[1] * factor, mid.shape[0] * factor), interpolation=cv2.INTER_LINEAR)
    D0 = np.pad(D0, ((0, h - D0.shape[0]), (0, w - D0.shape[1])), mode="edge")
    x = np.arange(w, dtype=np.float32)[None, :]
    D0 = x - np.maximum.accumulate(x - D0, axis=1)  # x' − D0(x') never decreasing: the resampling never folds
    return D0.astype(np.float32), R


def resolve(dprime, D0) -> np.ndarray:
    """The pair's disparities ``d = d' + D0(x − d', y)`` (module docstring) of disparities ``dprime`` found
    against the right image resampled by ``D0`` (NaN stays NaN; ``D0`` linear between columns, held at the
    edges)."""
    rows, cols = dprime.shape
    x = np.arange(cols, dtype=np.float32)[None, :] - np.nan_to_num(dprime)
    y = np.repeat(np.arange(rows, dtype=np.float32)[:, None], cols, axis=1)
    at = cv2.remap(D0, np.clip(x, 0, cols - 1).astype(np.float32), y, cv2.INTER_LINEAR)
    return dprime + at
