"""SURF keypoints and descriptors (Bay, Ess, Tuytelaars, Van Gool 2008), in numpy + OpenCV.

OpenCV's binary wheels exclude SURF, so fotogeo implements it: the detector lives in
:mod:`fotogeo.features.hessian`, orientation and descriptor in
:mod:`fotogeo.features.describe`; this module validates inputs, handles nodata, selects
a spatially balanced subset and returns a :class:`SurfResult`.

>>> import numpy as np
>>> yy, xx = np.mgrid[0:64, 0:64] + 0.5              # pixel centres, GDAL corner convention
>>> img = 255 * np.exp(-((xx - 32.0) ** 2 + (yy - 30.0) ** 2) / (2 * 3.0 ** 2))
>>> res = surf(img, upright=True)
>>> len(res), res.xy.round(1).tolist()
(1, [[32.0, 30.0]])
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..pixels import from_centre
from . import describe, fine, hessian, octaves, refine

#: Default Hessian threshold, on det(H) of an image in grey levels 0..255 (OpenCV semantics,
#: but measured after the light pre-smoothing below, which lowers fine-detail responses). Chosen
#: on the box filters' counts; the Gaussian layers' gain (``hessian.GAUSSIAN_GAIN``) keeps their
#: counts close to the box filters' (a few fewer on the aerial images, more on the coarse Landsat
#: clip): both, with and without the fine octave, in docs/benchmarks/matching.md
#: (``benchmarks/surf_counts.py``).
DEFAULT_THRESHOLD = 50.0

#: Gaussian pre-smoothing (pixels) applied before the integral image. The 9x9 box filters
#: are crude on unsmoothed, aliased pixels; a light blur makes the responses closer to the
#: Gaussian derivatives they approximate. Measured on the benchmark's rotation/scale cases
#: (2 real images, 6 transforms, top-1000 keypoints): sigma 0 / 0.7 / 1.0 / 1.3 / 1.6 give
#: repeatability 0.685 / 0.714 / 0.736 / 0.743 / 0.742 and matching score 0.609 / 0.656 /
#: 0.679 / 0.684 / 0.684.
PRESMOOTH_SIGMA = 1.2

#: Default of ``surf(refine_positions=...)``: positions from the Gaussian scale-space fit of
#: :mod:`fotogeo.features.refine` instead of the box-filter maxima. Measured (issue 19,
#: benchmarks/surf_bench.py --protocol): under the Landsat warp 200 deg x 0.9 + perspective
#: the correct matches' median error falls 0.62 -> 0.37 px (SIFT 0.10) and the dense error
#: of the fitted homography 0.27 -> 0.15 px (SIFT 0.016); on 3 tiles x 14 cases the
#: repeatability rises 0.773 -> 0.790 but the matching score falls 0.702 -> 0.697 (pure
#: scale changes lose up to 0.04), and the dense error of a fitted homography improves on some
#: tiles and worsens on others (README, SURF section), at about 1.2x the CPU time (4 Mpx):
#: so it is off by default.
REFINE_POSITIONS = False

#: ``surf(upscale=True)``: keypoints of scale s < UPSCALE_CUT come from an extra, finer octave
#: on the image upsampled 2x (as SIFT doubles its input, Lowe 2004 sec. 3.3), added to the
#: usual octaves. The box filters' finest layers (L = 9, 15) and the pre-smoothing leave blobs
#: finer than about s = 1.6 undetected, which a 2x enlarged copy shows: at scale 2.0 only 56 %
#: of the 1500 strongest keypoints had a partner among the other image's 1500 (issue 19,
#: Sentinel-2 scene).
UPSCALE_CUT = 1.6

#: Pre-smoothing (pixels of the image) of the doubled image: PRESMOOTH_SIGMA there is half of it here.
FINE_PRESMOOTH = PRESMOOTH_SIGMA / 2

#: Default of ``surf(gaussian=...)``: the Hessian's second derivatives from Gaussian kernels of
#: sigma s (:func:`fotogeo.features.hessian._gauss_layer`) instead of box filters. The box filters
#: are not rotation covariant: on fine texture (a drone frame of asphalt and lane marks) their
#: maxima move under rotations off multiples of 90 degrees; the Gaussian layers meet the held-out
#: protocol where they do not (docs/benchmarks/matching.md, SURF). A blob seen by two adjacent
#: octaves keeps one keypoint (:mod:`fotogeo.features.octaves`). ``gaussian=False``: box filters.
GAUSSIAN_HESSIAN = True

#: Radius, in units of the scale s, that the descriptor window (20s square rotated
#: arbitrarily, plus the 2s Haar wavelets: 9.5 sqrt(2) s + s) can reach from the centre.
WINDOW_RADIUS = 14.5


@dataclass(frozen=True)
class SurfResult:
    """SURF keypoints and descriptors of one image.

    Attributes
    ----------
    xy : (N, 2) float64
        ``(col, row)`` positions in the GDAL corner convention (the centre of the top-left
        pixel is ``(0.5, 0.5)``).
    scale : (N,) float64
        SURF scale s (1.2 for the 9x9 filter; s = 1.2 L / 9 for filter size L).
    angle : (N,) float64
        Orientation in **degrees**, in [0, 360), measured from +x (columns) towards +y
        (rows, downwards), i.e. clockwise on screen like OpenCV's ``KeyPoint.angle``; 0 for
        upright SURF.
    response : (N,) float64
        det(H) at the maximum (grey level^2, see :func:`surf`); times :func:`fine_weight`
        for the keypoints of the fine octave (``upscale``, scale below :data:`UPSCALE_CUT`).
    laplacian : (N,) int8
        Sign of the trace of H: -1 for bright blobs on a dark background, +1 for dark blobs.
        Matching only across equal signs is a free speed-up and filter.
    descriptors : (N, 64) or (N, 128) float32
        Unit-length SURF descriptors (128 when ``extended``).
    """

    xy: np.ndarray
    scale: np.ndarray
    angle: np.ndarray
    response: np.ndarray
    laplacian: np.ndarray
    descriptors: np.ndarray

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    @classmethod
    def empty(cls, extended: bool = False) -> SurfResult:
        """A result without keypoints (arrays of the right shapes and dtypes)."""
        z = np.zeros(0)
        return cls(np.zeros((0, 2)), z, z.copy(), z.copy(), np.zeros(0, np.int8),
                   np.zeros((0, 128 if extended else 64), np.float32))


def surf(image, mask=None, *, hessian_threshold: float = DEFAULT_THRESHOLD, n_octaves: int = 4,
         upright: bool = False, extended: bool = False, max_keypoints: int | None = None,
         refine_positions: bool = REFINE_POSITIONS, upscale: bool = True,
         gaussian: bool = GAUSSIAN_HESSIAN) -> SurfResult:
    """Detect and describe SURF keypoints in a 2-D image.

    Parameters
    ----------
    image : 2-D array, any real numeric dtype
        Grey levels, ideally 0..255 (the pipeline passes float32 after a robust contrast
        stretch). NaN/inf pixels are treated as nodata.
    mask : 2-D bool array, optional
        True where the image is valid. A keypoint is dropped when any invalid pixel lies
        within ``WINDOW_RADIUS * s`` (14.5 s, the reach of its rotated descriptor window) of
        it, so no descriptor sees nodata. The image border is not nodata: beyond it the image
        is mirrored (reflect-101) for the descriptor windows.
    hessian_threshold : float
        Minimum det(H) = Dxx Dyy - (w Dxy)^2 (w = 1.0, ``hessian.DXY_WEIGHT``) with every box
        response divided by the filter area, for grey levels 0..255 -- the same meaning as
        OpenCV's ``hessianThreshold`` (usual values 100..400 there; lower gives more keypoints), except that the image is
        first smoothed with a Gaussian of sigma :data:`PRESMOOTH_SIGMA`, which lowers the
        responses of the finest details: hence the default of 50 (see
        :data:`DEFAULT_THRESHOLD`). det(H) scales with the square of the contrast: for an image in 0..1 divide
        the threshold by 255^2.
    n_octaves : int
        Octaves of the scale space (filter sizes 9-27, 15-51, 27-99, 51-195, ...).
    upright : bool
        U-SURF: skip the orientation (angle 0); faster, not rotation invariant.
    extended : bool
        128-D descriptors (sums split by the sign of the other derivative).
    max_keypoints : int, optional
        Keep at most this many keypoints, spatially balanced: the image is divided into
        about ``max_keypoints / 8`` square cells and the cells take turns giving their next
        strongest keypoint (round robin), so keypoints spread over the image.
    refine_positions : bool
        Report positions re-fitted in the Gaussian scale space
        (:mod:`fotogeo.features.refine`); descriptors, scales and angles are those of the
        box-filter detector either way. See :data:`REFINE_POSITIONS`.
    upscale : bool, optional
        Add a finer octave detected on the image upsampled 2x (as SIFT doubles its input,
        Lowe 2004 sec. 3.3): blobs finer than s = :data:`UPSCALE_CUT` come from it, the rest
        from the usual octaves; its responses are weighted by :func:`fine_weight`. Finds the
        fine blobs a 2x enlarged copy of the image shows. On at every image size (default):
        the doubled image is processed in strips (:mod:`fotogeo.features.fine`), so memory
        stays bounded and a tile gives the same keypoints alone or inside a larger image;
        detection costs about twice the time without it.
    gaussian : bool, optional
        det(H) from Gaussian derivatives of sigma s (Lindeberg 1998) at every layer instead of
        Bay et al.'s box filters: the same scales, sampling, maxima, orientation and descriptors,
        but a response that turns with the image, and one keypoint per blob across octaves
        (:func:`fotogeo.features.octaves.drop_duplicates`; see :data:`GAUSSIAN_HESSIAN`).

    Returns
    -------
    SurfResult
        Keypoints sorted by (row, col) of their position; empty (with the right array
        shapes) for constant, tiny or fully masked images.
    """
    img = _check_image(image)
    valid = np.isfinite(img)
    if mask is not None:
        valid &= _check_mask(mask, img.shape)
    hessian_threshold = _check_number(hessian_threshold, "hessian_threshold", 0.0)
    n_octaves = _check_int(n_octaves, "n_octaves", 1, 8)
    if max_keypoints is not None:
        max_keypoints = _check_int(max_keypoints, "max_keypoints", 0, None)
    upright, extended = bool(upright), bool(extended)

    rows, cols = img.shape
    if rows < 24 or cols < 24 or not valid.any() or max_keypoints == 0:
        return SurfResult.empty(extended)
    n_octaves = min(n_octaves, _usable_octaves(rows, cols))
    prep = _prepared(img, valid)
    # one integral image at a time: detection and description each walk the octaves
    # (hessian.octave_integrals), the second time with room for the descriptor windows
    kp = hessian.detect(prep, hessian_threshold, n_octaves, blur=PRESMOOTH_SIGMA, gaussian=gaussian)
    filled = _filled(img, valid) if upscale else None
    if upscale:     # the doubled image strip by strip (fine.py): same keypoints at any image size
        kp = _with_fine(kp, fine.detect(filled, hessian_threshold, PRESMOOTH_SIGMA, gaussian), hessian_threshold)
    if gaussian:    # one keypoint per blob across octaves (octaves.py)
        blur = octaves.octave_blur(kp["octave"], PRESMOOTH_SIGMA, hessian.OCTAVE_BLUR, FINE_PRESMOOTH)
        one = octaves.drop_duplicates(kp, hessian.scale_of_size(kp["size"]), blur)
        kp = {k: v[one] for k, v in kp.items()}
    idx = _selected(kp, valid, max_keypoints)
    if not len(idx):
        return SurfResult.empty(extended)
    x, y, s = kp["x"][idx], kp["y"][idx], hessian.scale_of_size(kp["size"][idx])
    theta, desc = np.zeros(len(idx)), np.zeros((len(idx), 128 if extended else 64), np.float32)
    octave = kp["octave"][idx]
    if (octave >= 0).any():
        sel = octave >= 0
        theta[sel], desc[sel], x[sel], y[sel] = _described(prep, x[sel], y[sel], s[sel], octave[sel], upright,
                                                           extended, refine_positions)
    if (octave < 0).any():   # described on the doubled image (octave 0 there), strip by strip
        sel = octave < 0

        def fn(up, xs, ys, ss):
            return _described(up, xs, ys, ss, np.zeros(len(xs), np.int64), upright, extended, refine_positions)
        theta[sel], desc[sel], x[sel], y[sel] = fine.describe(filled, x[sel], y[sel], s[sel], PRESMOOTH_SIGMA,
                                                              fn, desc.shape[1])
    return SurfResult(xy=from_centre(np.column_stack([x, y])), scale=s,
                      angle=np.degrees(theta) % 360.0, response=kp["response"][idx],
                      laplacian=kp["laplacian"][idx].astype(np.int8), descriptors=desc)


def fine_weight(s):
    """Weight of the fine octave's det(H) at its detected scale ``s`` (pixels of the image): the
    pre-smoothing the usual octaves apply, which the doubled image lacks.

    A Gaussian blob of variance b^2 smoothed to b^2 + p^2 gives a scale-normalised det(H) at its
    maximum proportional to (b^2 / (b^2 + p^2))^2 (Lindeberg 1998): with the fine octave's
    p = :data:`FINE_PRESMOOTH` and the usual p = :data:`PRESMOOTH_SIGMA`, the attenuation ratio
    evaluated at s^2 = b^2 + FINE_PRESMOOTH^2 is ``(s^2 / (s^2 + PRESMOOTH_SIGMA^2 -
    FINE_PRESMOOTH^2))^2`` (0.23 at s = 1, 0.49 at s = 1.6). The box filters report a blob at a
    smaller scale than its smoothed σ (b = 2: s = 1.51 in the fine octave, 1.82 in the usual ones,
    for σ 2.09 / 2.33), so on such a blob the weighted fine response is 0.74x the usual octaves'
    (unweighted 1.60x): the fine octave ranks a little behind. Unweighted, the finest blobs -- the
    ones a reduced copy of the image loses -- crowd a strongest-N cut and a small image's
    keypoints: issue 19's protocol (benchmarks/surf_bench.py --protocol) on 7 tiles x 5 scale
    cases (0.5, 0.7, 2, 30 deg x 0.7, 135 deg x 0.6) had 4 pairs below 0.8x SIFT's matching score
    or mahotas' repeatability with weight 1 (Landsat at scale 0.5: 0.54x), 3 with a flat 0.5, 1
    with a flat 0.25 (Sentinel-2 scene at scale 2: 0.74x), none with this weight, which also meets
    both targets on all 98 tile x case pairs of the full protocol (worst 0.82x; README, SURF).

    >>> fine_weight(np.array([1.0, 1.6])).round(2).tolist()
    [0.23, 0.49]
    """
    s2 = np.asarray(s, float) ** 2
    return (s2 / (s2 + PRESMOOTH_SIGMA ** 2 - FINE_PRESMOOTH ** 2)) ** 2


def _filled(img: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """float32 image minus its valid mean (computed in float64), nodata 0 -- i.e. filled by the mean.

    SURF sees differences only: exact in real arithmetic, and in float32 a large offset (uint16 DN 10000 +- 50) no
    longer eats the box sums' and Haar responses' precision (Pleiades DN + 10000: 5554 box keypoints instead of 5549,
    Gaussian descriptors changed by up to 0.12 before; ``tests/test_surf_heldout.py``)."""
    centred = (img.astype(np.float64) - img[valid].mean(dtype=np.float64)).astype(np.float32)
    centred[~valid] = 0.0
    return centred


def _with_fine(kp: dict, kf: dict, threshold: float) -> dict:
    """Detections ``kp`` of scale s >= :data:`UPSCALE_CUT` and those ``kf`` of the doubled image
    (:func:`fine.detect`, in the image's pixels) finer than it, with octave -1 and response x
    :func:`fine_weight` (kept when that still exceeds ``threshold``)."""
    coarse = hessian.scale_of_size(kp["size"]) >= UPSCALE_CUT
    kf = dict(kf)
    kf["response"] = kf["response"] * fine_weight(hessian.scale_of_size(kf["size"]))
    fine = (hessian.scale_of_size(kf["size"]) < UPSCALE_CUT) & (kf["response"] > threshold)
    kf["octave"] = np.full(len(kf["x"]), -1, np.int8)
    return {k: np.concatenate([kp[k][coarse], kf[k][fine]]) for k in kp}


def _prepared(img: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """:func:`_filled` image (valid mean removed), pre-smoothed (σ :data:`PRESMOOTH_SIGMA`)."""
    img = _filled(img, valid)
    if PRESMOOTH_SIGMA > 0:
        img = cv2.GaussianBlur(img, (0, 0), PRESMOOTH_SIGMA, borderType=cv2.BORDER_REFLECT_101)
    return img


def _selected(kp: dict, valid: np.ndarray, max_keypoints: int | None) -> np.ndarray:
    """Indices of the detections to keep: clear of nodata, at most ``max_keypoints`` spatially
    balanced, in a deterministic order (by row, then column, then scale)."""
    x, y = kp["x"], kp["y"]
    s = hessian.scale_of_size(kp["size"])
    keep = np.ones(len(x), bool)
    if not valid.all() and len(x):
        keep = _clear_of_nodata(~valid, x, y, WINDOW_RADIUS * s)
    idx = np.nonzero(keep)[0]
    if max_keypoints is not None and len(idx) > max_keypoints:
        idx = idx[_balanced(x[idx], y[idx], kp["response"][idx], *valid.shape, max_keypoints)]
    return idx[np.lexsort((s[idx], x[idx], y[idx]))]


def _described(img, x, y, s, octave, upright: bool, extended: bool, refine_positions: bool = False):
    """Orientation (radians), descriptors and (refined) positions of the keypoints, each
    octave's keypoints described on the smoothed image (orientation) and its integral
    (descriptor) they were detected on, and refined on that image
    (:func:`fotogeo.features.refine.refine`) when ``refine_positions``."""
    rx, ry = x.copy(), y.copy()
    theta = np.zeros(len(x))
    desc = np.zeros((len(x), 128 if extended else 64), np.float32)
    for o, ii_o, pad, img_o in hessian.octave_integrals(img, int(octave.max()) + 1, PRESMOOTH_SIGMA,
                                                        WINDOW_RADIUS):
        sel = np.nonzero(octave == o)[0]
        if len(sel):
            if not upright:
                theta[sel] = describe.orientation(img_o, x[sel], y[sel], s[sel])
            desc[sel] = describe.descriptors(ii_o, pad, x[sel], y[sel], s[sel], theta[sel], extended)
            if refine_positions:     # after describing: descriptors stay those of the detector
                blur_o = max(PRESMOOTH_SIGMA, hessian.OCTAVE_BLUR * (1 << o))
                rx[sel], ry[sel], _ = refine.refine(img_o, x[sel], y[sel], s[sel], blur_o)
        del ii_o                                # before the next octave's integral is built
    return theta, desc, rx, ry


def _usable_octaves(rows: int, cols: int) -> int:
    """Octaves whose largest filter (plus one sample) still fits in the image."""
    n = 1
    while n < 8:
        o = n
        big = hessian.octave_sizes(o)[2]      # largest filter needed for layer-1 maxima
        if big + 2 * (1 << o) + 2 > min(rows, cols):
            break
        n += 1
    return n


def _clear_of_nodata(invalid: np.ndarray, x, y, radius) -> np.ndarray:
    """True for keypoints with no invalid pixel in the square of half-side ``radius``."""
    rows, cols = invalid.shape
    cnt = cv2.integral(invalid.astype(np.uint8), sdepth=cv2.CV_32S)
    r = np.ceil(radius).astype(np.int64)
    cx, cy = np.rint(x).astype(np.int64), np.rint(y).astype(np.int64)
    x0, x1 = np.clip(cx - r, 0, cols), np.clip(cx + r + 1, 0, cols)
    y0, y1 = np.clip(cy - r, 0, rows), np.clip(cy + r + 1, 0, rows)
    n = cnt[y1, x1] - cnt[y0, x1] - cnt[y1, x0] + cnt[y0, x0]
    return n == 0


def _balanced(x, y, response, rows: int, cols: int, budget: int) -> np.ndarray:
    """Indices of ``budget`` keypoints chosen round robin over a grid of ~budget/8 cells.

    Within a cell keypoints are ranked by decreasing response; the selection takes every
    cell's rank-0 keypoint, then every rank-1, ... (ties in rank by decreasing response).
    """
    ncells = max(1, budget // 8)
    side = np.sqrt(rows * cols / ncells)
    gx, gy = max(1, round(cols / side)), max(1, round(rows / side))
    cell = (np.minimum((y * gy / rows).astype(np.int64), gy - 1) * gx
            + np.minimum((x * gx / cols).astype(np.int64), gx - 1))
    order = np.lexsort((-response, cell))            # by cell, strongest first
    c_sorted = cell[order]
    start = np.r_[0, np.nonzero(np.diff(c_sorted))[0] + 1]
    first = np.repeat(start, np.diff(np.r_[start, len(order)]))
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order)) - first
    pick = np.lexsort((-response, rank))[:budget]
    return np.sort(pick)


def _check_image(image) -> np.ndarray:
    a = np.asarray(image)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.number) or a.dtype == bool) \
            or np.issubdtype(a.dtype, np.complexfloating):
        raise InputError(f"image must be a real numeric array; got dtype {a.dtype}")
    if a.ndim != 2:
        raise InputError(f"image must be 2-D (rows, cols); got shape {a.shape} — pass one band, "
                         "e.g. the first principal component")
    if np.issubdtype(a.dtype, np.floating):
        return a.astype(np.float32, copy=False) if a.dtype.itemsize <= 4 else a.astype(np.float64)
    return a.astype(np.float32)


def _check_mask(mask, shape) -> np.ndarray:
    m = np.asarray(mask)
    if m.dtype != bool and not np.issubdtype(m.dtype, np.integer):
        raise InputError(f"mask must be a bool array (True = valid); got dtype {m.dtype}")
    if m.shape != shape:
        raise InputError(f"mask must have the image's shape {shape}; got {m.shape}")
    return m.astype(bool)


def _check_number(v, name: str, lo: float) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number; got {v!r}") from None
    if not np.isfinite(f) or f < lo:
        raise InputError(f"{name} must be a finite number >= {lo}; got {v!r}")
    return f


def _check_int(v, name: str, lo: int, hi: int | None) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise InputError(f"{name} must be an integer; got {v!r}")
    if v < lo or (hi is not None and v > hi):
        raise InputError(f"{name} must be between {lo} and {hi if hi is not None else 'inf'}; got {v}")
    return int(v)
