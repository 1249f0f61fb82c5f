"""Measurement of X-shaped fiducial / calibration targets (Büyüksalih).

Two steps, as in the paper:

1. **Approximate centre by an edge method.** In a window around the approximation, a first
   threshold ``T0 = (MAX + MIN) / 2`` separates target from background (the target is the
   minority class unless ``polarity`` says otherwise); their mean grey levels ``MGL``
   (target) and ``MBGL`` (background) give the final threshold ``T = (MGL + MBGL) / 2``.
   (The paper's eq. 11, damaged in the OCR, combines them as a quadratic mean; the
   arithmetic mean is the level at which a symmetric blur leaves edge positions, hence arm
   widths, unbiased. Arm mid-points are unbiased either way.) Along every row the profile
   crosses ``T`` at the arm edges (rising and falling gradient); edges are located to
   sub-pixel by linear interpolation, and the arm mid-points ``x_m = (x_rise + x_fall) / 2``
   (eq. 12) of rows that cut both arms are sorted into the two diagonals (left arm above
   the crossing and right arm below it form one diagonal; the crossing lies in the widest
   run of rows where the arms have merged). A straight line
   ``x = a + b·y`` is fitted to each diagonal's mid-points; their intersection is the
   approximate centre, their slopes the arm directions and the run lengths the arm width.
   The same is done along columns (for arms nearer the horizontal); the scan that cut both
   arms in more lines is kept.
2. **Sub-pixel centre by least-squares matching** of a synthetic X-target template (the
   measured arm directions, width and grey levels, area-sampled) against the image with the
   affine + radiometric model of :mod:`fotogeo.matching.lsm`. The template centre maps to
   the target centre; its precision is the LSM σ.

Coordinates are GDAL corner convention (:mod:`fotogeo.pixels`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..pixels import from_centre, pixel_centres
from .lsm import lsm_many
from .ncc import as_image, as_xy, check_int, square_window
from .status import CONVERGED, STAGE_EDGE_METHOD, at_stage


def synthetic_x_target(shape, centre_xy, arm_width: float, angles_deg=(45.0, 135.0), target: float = 255.0,
                       background: float = 0.0, radius: float | None = None, supersample: int = 8) -> np.ndarray:
    """Area-sampled image of an X target: two straight arms of width ``arm_width`` crossing at
    ``centre_xy`` (corner convention) at ``angles_deg`` (direction of each arm, degrees from
    the +x axis towards +y, i.e. clockwise on screen); arms end at ``radius`` px from the
    centre if given. Each pixel is the mean over ``supersample²`` sub-pixel samples.
    """
    rows, cols = int(shape[0]), int(shape[1])
    s = check_int(supersample, "supersample", 1)
    sub = (np.arange(s) + 0.5) / s - 0.5
    X, Y = pixel_centres(cols, rows)
    xs = (X[..., None, None] + sub[None, None, None, :]) - float(centre_xy[0]) + np.zeros((s, 1))
    ys = (Y[..., None, None] + sub[None, None, :, None]) - float(centre_xy[1]) + np.zeros((1, s))
    hit = np.zeros(xs.shape, dtype=bool)
    for a in np.deg2rad(np.asarray(angles_deg, dtype=np.float64)):
        hit |= np.abs(-np.sin(a) * xs + np.cos(a) * ys) <= arm_width / 2.0
    if radius is not None:
        hit &= xs * xs + ys * ys <= radius * radius
    cover = hit.mean(axis=(-2, -1))
    return background + (target - background) * cover


@dataclass(frozen=True)
class TargetResult:
    """A measured X target.

    ``xy``: sub-pixel centre (corner convention; NaN if failed); ``sigma``: (σx, σy) px from
    LSM; ``approx_xy``: centre from the edge method; ``status``: ``"converged"`` or why it
    failed; ``target_grey``, ``background_grey`` (MGL, MBGL); ``arm_width`` px;
    ``arm_angles`` degrees; ``ncc``: correlation of template and image after LSM.
    """

    xy: np.ndarray
    sigma: np.ndarray
    approx_xy: np.ndarray
    status: str
    target_grey: float
    background_grey: float
    arm_width: float
    arm_angles: tuple
    ncc: float

    @property
    def ok(self) -> bool:
        return self.status == CONVERGED


def _row_runs(row: np.ndarray, T: float, sign: float):
    """Sub-pixel (rise, fall) crossings of ``sign·(row − T) > 0`` runs not touching the ends."""
    above = sign * (row - T) > 0
    idx = np.nonzero(above[1:] != above[:-1])[0]
    runs, start = [], None
    for j in idx:
        x = j + (T - row[j]) / (row[j + 1] - row[j])  # centre convention within the row
        if not above[j]:
            start = x
        elif start is not None:
            runs.append((start, x))
            start = None
    return runs


def _grey_levels(win: np.ndarray, polarity: str):
    """(sign, MGL, MBGL): +1 for a bright target; class means split at (MAX + MIN) / 2."""
    mx, mn = float(win.max()), float(win.min())
    if not mx > mn:
        raise ValueError("flat window")
    bright = win > 0.5 * (mx + mn)
    if polarity == "auto":
        sign = 1.0 if bright.mean() < 0.5 else -1.0
    else:
        sign = 1.0 if polarity == "bright" else -1.0
    tgt = bright if sign > 0 else ~bright
    return sign, float(win[tgt].mean()), float(win[~tgt].mean())


def _edge_centre(win: np.ndarray, polarity: str):
    """Approximate centre etc. from the edge method; raises ``ValueError`` with a reason."""
    sign, mgl, mbgl = _grey_levels(win, polarity)
    T = 0.5 * (mgl + mbgl)
    two = []
    for r in range(win.shape[0]):
        runs = _row_runs(win[r], T, sign)
        y = r  # centre convention
        if len(runs) == 2 and runs[1][0] - runs[0][1] > 1.0:
            (a0, a1), (b0, b1) = runs
            two.append((y, 0.5 * (a0 + a1), 0.5 * (b0 + b1), a1 - a0, b1 - b0))
    if len(two) < 4:
        raise ValueError("too few rows cut both arms")
    two = np.array(two)
    # rows near the crossing hold one merged run: the crossing lies in the widest gap between
    # rows that cut both arms (one-run rows also occur where an arm leaves the window)
    ys = two[:, 0]
    gaps = np.diff(ys)
    j = int(np.argmax(gaps))
    if gaps[j] <= 1:
        raise ValueError("arms do not merge at a crossing")
    y_mid = 0.5 * (ys[j] + ys[j + 1])
    up = two[:, 0] < y_mid
    # "\" diagonal: left run above the crossing, right run below; "/" the other way round
    back = np.concatenate([two[up][:, [0, 1, 3]], two[~up][:, [0, 2, 4]]])
    fwd = np.concatenate([two[up][:, [0, 2, 4]], two[~up][:, [0, 1, 3]]])
    if len(back) < 2 or len(fwd) < 2:
        raise ValueError("arms not found on both diagonals")
    A1 = np.polyfit(back[:, 0], back[:, 1], 1)  # x = b*y + a
    A2 = np.polyfit(fwd[:, 0], fwd[:, 1], 1)
    if abs(A1[0] - A2[0]) < 1e-6:
        raise ValueError("arms are parallel")
    yc = (A2[1] - A1[1]) / (A1[0] - A2[0])
    xc = A1[0] * yc + A1[1]
    width = float(np.median(np.concatenate([back[:, 2] / np.hypot(1, A1[0]), fwd[:, 2] / np.hypot(1, A2[0])])))
    angles = (float(np.degrees(np.arctan2(1.0, A1[0]))), float(np.degrees(np.arctan2(1.0, A2[0]))))
    return np.array([xc, yc]), mgl, mbgl, width, angles, len(two)


def _edge_centre_rows_or_cols(win: np.ndarray, polarity: str):
    """:func:`_edge_centre` along rows and along columns (for arms nearer the horizontal);
    keeps the scan that cut both arms more often."""
    best, reason = None, ""
    for transposed in (False, True):
        try:
            c, mgl, mbgl, w, ang, n = _edge_centre(win.T if transposed else win, polarity)
        except ValueError as exc:
            reason = reason or str(exc)
            continue
        if transposed:
            c, ang = c[::-1], (90.0 - ang[0], 90.0 - ang[1])
        if best is None or n > best[-1]:
            best = (c, mgl, mbgl, w, ang, n)
    if best is None:
        raise ValueError(reason)
    return best[:5]


def measure_target(image, approx_xy, *, half_window: int = 12, search_half_window: int | None = None,
                   polarity: str = "auto", arm_width: float | None = None, arm_angles=None,
                   interpolation: str = "bicubic", max_iterations: int = 15, mask=None) -> TargetResult:
    """Measure the centre of an X-shaped target near ``approx_xy`` to sub-pixel precision.

    Parameters
    ----------
    image : 2-D array (any real dtype, NaN = nodata)
    approx_xy : (x, y) approximate centre, corner convention; within a few pixels
    half_window : LSM window ``(2h+1)²``; the arms should reach at least ``h`` px from the centre
    search_half_window : edge-method window half-size (default ``half_window + 3``)
    polarity : ``"auto"`` (target = minority class), ``"bright"`` or ``"dark"``
    arm_width, arm_angles : override the measured arm width (px) / directions (degrees, from
        +x towards +y). The edge method needs arms within about 20° of the diagonals; for
        other targets (e.g. '+'), give both and LSM starts from ``approx_xy`` itself
    interpolation, max_iterations : passed to :func:`fotogeo.matching.lsm_many`

    Returns :class:`TargetResult`; failures are in ``status`` (``"window outside image"``,
    ``"nodata in window"``, ``"edge method: ..."``, or an LSM status).
    """
    img = as_image(image, "image", mask)
    q = as_xy(approx_xy, "approx_xy")
    h = check_int(half_window, "half_window", 3)
    hs = h + 3 if search_half_window is None else check_int(search_half_window, "search_half_window", 3)
    if polarity not in ("auto", "bright", "dark"):
        raise InputError(f"polarity must be 'auto', 'bright' or 'dark'; got {polarity!r}")
    nan2 = np.array([np.nan, np.nan])

    def fail(status, approx=nan2, mgl=np.nan, mbgl=np.nan, w=np.nan, ang=(np.nan, np.nan)):
        return TargetResult(nan2, nan2, approx, status, mgl, mbgl, w, ang, np.nan)

    c, r = int(np.floor(q[0])), int(np.floor(q[1]))
    win, status = square_window(img, c, r, hs)
    if win is None:
        return fail(status)
    try:
        centre, mgl, mbgl, width, angles = _edge_centre_rows_or_cols(win, polarity)
        approx = from_centre(centre + [c - hs, r - hs])
    except ValueError as exc:
        if arm_width is None or arm_angles is None or str(exc) == "flat window":
            return fail(at_stage(STAGE_EDGE_METHOD, str(exc)))
        # arms near the image axes ('+'): with the target's shape given, LSM starts at approx_xy
        _, mgl, mbgl = _grey_levels(win, polarity)
        approx = q
    if arm_width is not None:
        width = float(arm_width)
    if arm_angles is not None:
        angles = tuple(float(a) for a in arm_angles)
    if not (np.isfinite(approx).all() and np.hypot(*(approx - q)) <= hs):
        return fail(at_stage(STAGE_EDGE_METHOD, "centre outside the window"), approx, mgl, mbgl, width, angles)
    if not (0.5 <= width <= h):
        return fail(at_stage(STAGE_EDGE_METHOD, "implausible arm width"), approx, mgl, mbgl, width, angles)
    s = h + 3
    tpl = synthetic_x_target((2 * s + 1, 2 * s + 1), (s + 0.5, s + 0.5), width, angles, mgl, mbgl)
    b = lsm_many(tpl, img, [[s + 0.5, s + 0.5]], approx[None], half_window=h, interpolation=interpolation,
                 max_iterations=max_iterations, max_shift=3.0)
    res = b[0]
    return TargetResult(res.xy, res.sigma, approx, res.status, mgl, mbgl, width, angles, res.ncc)
