"""Image pyramids and coarse-to-fine matching (Büyüksalih: sub-pixel matching on pyramids; Yastıklı: digital aerial triangulation).

Levels are built with ``cv2.pyrDown`` (5x5 Gaussian, keep every second pixel). pyrDown
keeps input pixel ``2j`` (centre convention) as output pixel ``j``, so between level 0 and
level k the *centre*-convention coordinates scale by ``2**k``:

    x_k = from_centre(to_centre(x_0) / 2**k),   i.e. in GDAL corner convention
    x_k = (x_0 − 0.5) / 2**k + 0.5            (not x_0 / 2**k: that would be 0.25 px off at level 1).

Matching follows the points down the pyramid: NCC with the full search radius (scaled) at
the top level, NCC with a small radius at each finer level around the doubled position,
then least-squares matching (:func:`fotogeo.matching.lsm_many`) at full resolution.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..pixels import as_points, from_centre, to_centre
from ..progress import as_progress
from .lsm import lsm_many
from .ncc import as_image, as_point_pairs, check_int, check_range, match_prepared
from .status import CONVERGED, OK, STAGE_LSM, WINDOW_OUTSIDE, at_stage, ncc_level


def to_level(xy, level: int) -> np.ndarray:
    """Corner-convention coordinates at level 0 -> the same point at pyramid ``level``.

    >>> to_level([[0.5, 0.5], [2.5, 4.5]], 1).tolist()
    [[0.5, 0.5], [1.5, 2.5]]
    """
    return from_centre(to_centre(xy) / 2.0 ** level)


def from_level(xy, level: int) -> np.ndarray:
    """Inverse of :func:`to_level`."""
    return from_centre(to_centre(xy) * 2.0 ** level)


def build_pyramid(image, levels: int, mask=None, name: str = "image") -> list[np.ndarray]:
    """``[level 0, level 1, ...]`` float64 arrays (NaN = nodata) halved with ``cv2.pyrDown``.

    A coarse pixel is nodata when any fine pixel under its 5x5 kernel is nodata. Stops early
    when a level would be smaller than 8 pixels on a side.
    """
    img = as_image(image, name, mask)
    check_int(levels, "levels", 0)
    out = [img]
    for _ in range(int(levels)):
        cur = out[-1]
        if min(cur.shape) < 16:
            break
        bad = np.isnan(cur)
        fill = float(np.nanmean(cur)) if (~bad).any() else 0.0
        nxt = cv2.pyrDown(np.where(bad, fill, cur)).astype(np.float64)
        if bad.any():
            nb = cv2.pyrDown(bad.astype(np.float64))
            nxt[nb > 1e-9] = np.nan
        out.append(nxt)
    return out


def levels_for(search_radius: float, top_radius: int = 4) -> int:
    """Number of halvings so that ``search_radius`` shrinks to about ``top_radius`` pixels."""
    if search_radius <= top_radius:
        return 0
    return math.ceil(math.log2(search_radius / top_radius))


@dataclass(frozen=True)
class TransferResult:
    """Points transferred from ``reference`` to ``search`` (row i = point i).

    ``xy`` (N, 2) corner convention, NaN where failed; ``sigma`` (N, 2) LSM (σx, σy) px;
    ``ncc`` (N,) final LSM correlation; ``status`` (N,) ``"converged"`` or why it failed,
    prefixed by the stage (e.g. ``"ncc level 3: ambiguous"``, ``"lsm: diverged"``);
    ``ncc_xy`` (N, 2) the level-0 NCC position; ``levels``: number of pyramid levels used.
    """

    xy: np.ndarray
    sigma: np.ndarray
    ncc: np.ndarray
    status: np.ndarray
    ncc_xy: np.ndarray
    levels: int

    @property
    def ok(self) -> np.ndarray:
        return self.status == CONVERGED

    def __len__(self) -> int:
        return len(self.status)


def transfer_points(reference, search, ref_xy, approx_xy, *, search_radius: int = 32, half_window: int = 10,
                    ncc_half_window: int | None = None, levels: int | None = None, min_correlation: float = 0.5,
                    max_ambiguity: float = 0.9, interpolation: str = "bicubic", max_iterations: int = 15,
                    max_sigma: float = 0.5, reference_mask=None, search_mask=None, progress=None) -> TransferResult:
    """Transfer points (e.g. GCPs) from ``reference`` into ``search``: pyramid NCC, then LSM.

    Parameters
    ----------
    reference, search : 2-D arrays (any real dtype, NaN = nodata), same orientation and
        roughly the same scale (resample one onto the other's grid first otherwise)
    ref_xy : (N, 2) points in ``reference`` (GDAL corner convention)
    approx_xy : (N, 2) approximate positions in ``search``; the true position must lie within
        ``search_radius`` pixels
    search_radius : px at level 0; sets the number of levels (``levels_for``) unless given
    half_window : LSM window ``(2h+1)²`` at level 0; ``ncc_half_window`` (default the same)
        is the NCC template half-size at every level
    min_correlation, max_ambiguity : NCC acceptance at every level (and LSM correlation)
    interpolation, max_iterations, max_sigma : passed to :func:`fotogeo.matching.lsm_many`
    progress : optional callback ``progress(fraction, message) -> bool`` (False cancels)

    Returns :class:`TransferResult`.
    """
    P, Q = as_point_pairs(ref_xy, approx_xy)
    R = check_int(search_radius, "search_radius", 1)
    h = check_int(half_window, "half_window", 2)
    hn = h if ncc_half_window is None else check_int(ncc_half_window, "ncc_half_window", 2)
    check_range(min_correlation, "min_correlation", -1.0, 1.0)
    check_range(max_ambiguity, "max_ambiguity", 0.0, 1.0)
    L = levels_for(R) if levels is None else check_int(levels, "levels", 0)
    prog = as_progress(progress)
    prog(0.0, "building image pyramids")

    # no level smaller than two template widths
    f_img = as_image(reference, "reference", reference_mask, "reference_mask")
    g_img = as_image(search, "search", search_mask, "search_mask")
    smallest = min(f_img.shape + g_img.shape)
    while L > 0 and smallest / 2.0 ** L < 2 * (2 * hn + 1):
        L -= 1
    ref_pyr = build_pyramid(f_img, L, None, "reference")
    sea_pyr = build_pyramid(g_img, L, None, "search")
    L = min(len(ref_pyr), len(sea_pyr)) - 1
    n = P.shape[0]
    status = np.full(n, "", dtype=object)
    cur = to_level(Q, L)
    # search radius per point at the current level; a point whose window does not fit at a
    # coarse level skips it and is searched with a correspondingly larger radius below
    rad = np.full(n, math.ceil(R / 2.0 ** L) + 1)
    total = max(n * (L + 1), 1)
    done = 0
    for k in range(L, -1, -1):
        pk = to_level(P, k)
        for i in range(n):
            if status[i]:
                continue
            res = match_prepared(ref_pyr[k], sea_pyr[k], pk[i], cur[i], hn, int(rad[i]),
                                 min_correlation, max_ambiguity)
            if res.status == OK:
                cur[i], rad[i] = res.xy, 2
            elif res.status == WINDOW_OUTSIDE and k > 0:
                rad[i] = 2 * rad[i] + 1
            else:
                status[i] = at_stage(ncc_level(k), res.status)
            done += 1
            if done % 64 == 0:
                prog(0.8 * done / total, f"NCC at pyramid level {k}")
        prog(0.8 * done / total, f"NCC at pyramid level {k} done")
        if k > 0:
            cur = to_level(from_level(cur, k), k - 1)
    ncc_xy = np.where((status == "")[:, None], cur, np.nan)
    prog(0.8, "least-squares matching")
    xy = np.full((n, 2), np.nan)
    sigma = np.full((n, 2), np.nan)
    rho = np.full(n, np.nan)
    live = np.nonzero(status == "")[0]
    if live.size:
        b = lsm_many(ref_pyr[0], sea_pyr[0], P[live], cur[live], half_window=h, interpolation=interpolation,
                     max_iterations=max_iterations, min_correlation=min_correlation, max_sigma=max_sigma,
                     max_shift=2.0)
        xy[live], sigma[live], rho[live] = b.xy, b.sigma, b.ncc
        status[live] = [s if s == CONVERGED else at_stage(STAGE_LSM, s) for s in b.status]
    prog(1.0, "points transferred")
    return TransferResult(xy, sigma, rho, status.astype(str), ncc_xy, L)


@dataclass(frozen=True)
class PyramidMatch:
    """One point matched coarse-to-fine: ``xy``, ``sigma`` (σx, σy), ``ncc``, ``status``."""

    xy: np.ndarray
    sigma: np.ndarray
    ncc: float
    status: str

    @property
    def ok(self) -> bool:
        return self.status == CONVERGED


def pyramid_match(reference, search, ref_xy, approx_xy, **options) -> PyramidMatch:
    """One point through :func:`transfer_points` (same options)."""
    p = as_points(ref_xy, name="ref_xy")
    q = as_points(approx_xy, name="approx_xy")
    if p.shape[0] != 1 or q.shape[0] != 1:
        raise InputError("pyramid_match takes one point; use transfer_points for many")
    r = transfer_points(reference, search, p, q, **options)
    return PyramidMatch(r.xy[0], r.sigma[0], float(r.ncc[0]), str(r.status[0]))
