"""The matching tool: keypoints in both images, descriptor matching, optional LSM refinement.

:func:`find_tie_points` is the first half of the registration (Dihkan 2019: PCA fusion, SURF,
SSD ratio test); :func:`match_images` writes its tie points as a layer without fitting a model.
A :class:`FeatureCache` lets an image matched in many pairs (a frame of a block) be read, fused
and detected once. :func:`lsm_tie_points` refines matched positions by least-squares matching
(each with its σ and status); the registration does it by default (``refine="auto"``: lsm in 2-D,
:mod:`fotogeo.tools.register.points`).

Bands: ``reference_bands`` / ``target_bands`` (1-based, as ``gdal_translate -b``) choose the
bands fused for matching (:func:`.selection.select_bands`); of those, empty or constant bands are left out
of the PCA with a warning (:func:`fotogeo.image.fusion.pca_fuse`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ...errors import FotogeoError, FotogeoWarning, MatchingError
from ...features.detect import detect
from ...image.contrast import apply_contrast
from ...image.fusion import pca_fuse
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster, read_decimated
from ...io.vector import write_layers
from ...models import Projective, ransac
from ...options import RegisterOptions
from ...pixels import pixel_to_map
from ...progress import as_progress
from ..common.boundary import tool
from .bands import rematch
from .selection import band_numbers, match_keypoints, select_bands  # noqa: F401 (register's other modules)


#: fewer homography inliers than this are what chance gives among unrelated matches (the disjoint Landsat / NGI
#: pair: 5 of 32; triangulate's pairs: 9–10 inliers 28 % right matches, 30 or more 98 %,
#: :data:`fotogeo.tools.triangulate.pairs.MIN_PAIR_INLIERS`): the registration checks such a fit by windows
#: (``local.WEAK_INLIERS``), ``match`` flags no inlier and says so
WEAK_INLIERS = 12


def _per_band_mask(bands, info, mask):
    """The validity mask for :func:`~fotogeo.image.fusion.pca_fuse`: per band from the file's nodata
    (GDAL's mask of a file with nodata is per band, and read_decimated ANDs them: one empty band would
    void every pixel; pca_fuse leaves empty bands out instead), else ``mask`` (alpha, internal mask)."""
    if info.nodata is None:
        return mask
    return np.isfinite(bands) if np.isnan(info.nodata) else (bands != info.nodata)


def fused_for_matching(info, role, opts):
    """``(fused, factor)``: the image matched (decimated to ``opts.max_match_pixels``, the bands of
    ``opts.<role>_bands`` PCA-fused) and its decimation factors (full-resolution pixels = matched
    pixels x factor)."""
    numbers = select_bands(getattr(opts, f"{role}_bands", None), info.count, role)
    bands, mask, factor = read_decimated(info, opts.max_match_pixels, role)
    if numbers != tuple(range(1, info.count + 1)):
        bands = bands[np.asarray(numbers) - 1]
    mask = _per_band_mask(bands, info, mask)
    override = getattr(opts, f"{role}_nodata")
    fused = pca_fuse(bands, mask, nodata=info.nodata if override is None else override, rng=opts.seed,
                     contrast="linear", name=f"{role} {info.path}", numbers=numbers)
    return fused, np.asarray(factor, float)


def fused_windows(info, role, opts, fusion, origins, size: int) -> np.ndarray:
    """``(N, size, size)`` float32: full-resolution windows of ``info`` whose top-left pixels are
    ``origins`` (N, 2) (col, row), fused as ``fusion`` (:func:`fused_for_matching`'s result: its
    bands, component, mean and linear stretch); NaN where invalid or outside the image."""
    from rasterio.windows import Window
    from ...image.fusion import valid_mask
    from ...io.raster import gdal_env, ropen
    numbers = select_bands(getattr(opts, f"{role}_bands", None), info.count, role)
    kept = [numbers.index(b) for b in fusion.bands]
    v, mean = fusion.component[kept], fusion.mean[kept]
    lo, hi = fusion.stretch
    override = getattr(opts, f"{role}_nodata")
    nodata = info.nodata if override is None else override
    out = np.full((len(origins), size, size), np.nan, np.float32)
    with gdal_env(), ropen(info.path) as ds:
        for k, (c0, r0) in enumerate(np.asarray(origins, int)):
            c1, r1 = min(c0 + size, info.width), min(r0 + size, info.height)
            ca, ra = max(c0, 0), max(r0, 0)
            if c1 <= ca or r1 <= ra:
                continue
            win = Window(ca, ra, c1 - ca, r1 - ra)
            bands = ds.read(list(fusion.bands), window=win)
            mask = None if info.nodata is not None else ds.read_masks(list(fusion.bands), window=win).all(axis=0)
            per_band = _per_band_mask(bands, info, mask)
            ok = valid_mask(bands, None if per_band is None else np.reshape(per_band, (-1, *bands.shape[1:])).all(0),
                            nodata)
            pc = np.tensordot(v, bands.astype(np.float64) - mean[:, None, None], axes=1)
            chip = np.clip((pc - lo) * (255.0 / (hi - lo)), 0, 255).astype(np.float32)
            chip[_without_specks(~ok)] = np.nan
            out[k, ra - r0:r1 - r0, ca - c0:c1 - c0] = chip
    return out


def _features(info, role, opts, prog):
    """Keypoints of one image; wall times in ``prog.timings`` (``read_fuse_<role>``, ``detect_<role>``)."""
    with prog.timed(f"read_fuse_{role}"):
        fused, factor = fused_for_matching(info, role, opts)
    prog(0.3, f"{role}: keypoints")
    with prog.timed(f"detect_{role}"):
        kp = detect(apply_contrast(fused.image, fused.mask, opts.contrast), fused.mask, opts.detector,
                    max_keypoints=opts.max_keypoints, hessian_threshold=opts.hessian_threshold)
    return kp, factor, fused


HINT = ("check that the images overlap, then try a looser --ratio (0.9), more --max-keypoints, "
        "a lower --hessian-threshold or --detector sift")


class FeatureCache:
    """Keypoints, decimation factor and PCA explained variance of images already detected, keyed by
    (path, the role's nodata override, options), so that :func:`find_tie_points` detects an image
    matched in several pairs once. The fused images are not kept (memory: keypoints only);
    :meth:`forget` drops an image whose pairs are done."""

    def __init__(self):
        self._entries: dict = {}

    def features(self, info, role, opts, prog):
        """``(keypoints, factor, explained)`` of ``info`` as :func:`_features` detects it in ``role``."""
        key = (str(info.path), getattr(opts, f"{role}_nodata"), opts)
        if key not in self._entries:
            kp, factor, fused = _features(info, role, opts, prog)
            self._entries[key] = (kp, factor, fused.explained)
        return self._entries[key]

    def forget(self, info):
        """Drop every entry of the image ``info``."""
        self._entries = {k: v for k, v in self._entries.items() if k[0] != str(info.path)}

    def __len__(self) -> int:
        return len(self._entries)


def find_tie_points(ref, tgt, opts, prog=None, *, cache: FeatureCache | None = None, images: bool = False):
    """Keypoints in both images, matched: ``(target_xy, reference_xy, counts)`` in full-resolution
    pixels (corner convention). ``ref``/``tgt`` are :class:`~fotogeo.io.raster.RasterInfo`.
    Wall times of the steps go to ``prog.timings`` (:meth:`fotogeo.progress.Progress.timed`).
    With a ``cache``, keypoints already detected are reused (the same results: detection is
    deterministic); a match weak enough for the band re-match (:func:`.bands.rematch`) reads the two fused
    images again for it. The positions are the keypoints' (``opts.refine`` is the caller's:
    :func:`lsm_tie_points`); with ``images`` a 4th value ``(fused reference, fused target,
    reference factor, target factor)`` gives the images matched for it (no cache then)."""
    prog = as_progress(prog)
    stages = (prog.stage(0.0, 0.45, "reference: reading"), prog.stage(0.45, 0.9, "target: reading"))
    if cache is not None and not images:
        kp_ref, f_ref, ex_ref = cache.features(ref, "reference", opts, stages[0])
        kp_tgt, f_tgt, ex_tgt = cache.features(tgt, "target", opts, stages[1])
        fu_ref = fu_tgt = None
    else:
        kp_ref, f_ref, fu_ref = _features(ref, "reference", opts, stages[0])
        kp_tgt, f_tgt, fu_tgt = _features(tgt, "target", opts, stages[1])
        ex_ref, ex_tgt = fu_ref.explained, fu_tgt.explained
    with prog.stage(0.9, 1.0, "matching descriptors").timed("match"):
        m = match_keypoints(kp_tgt, kp_ref, opts)
    again = None
    if len(m) >= 6:  # bands that do not correspond: matched again on combined bands (cached: the images re-read)
        fused = (fu_ref, fu_tgt) if fu_ref is not None else lambda: (fused_for_matching(ref, "reference", opts)[0],
                                                                      fused_for_matching(tgt, "target", opts)[0])
        with prog.timed("rematch_bands"):
            fu_ref, fu_tgt, kp_ref, kp_tgt, m, again = rematch((ref, tgt), opts, fused, (kp_ref, kp_tgt), m)
    min_pts = 6
    if len(m) < min_pts:
        raise MatchingError(f"only {len(m)} descriptor matches between {str(tgt.path)!r} and "
                            f"{str(ref.path)!r} (found {len(kp_tgt)} and {len(kp_ref)} keypoints); {HINT}")
    counts = {"keypoints": {"reference": len(kp_ref), "target": len(kp_tgt)}, "matches": len(m),
              "pca_explained_variance": {"reference": ex_ref, "target": ex_tgt}}
    if fu_ref is not None:
        counts["bands_fused"] = {"reference": list(fu_ref.bands), "target": list(fu_tgt.bands)}
        counts.update({"bands_rematched": again} if again else {})
        dropped = {r: {str(k): v for k, v in f.dropped.items()} for r, f in (("reference", fu_ref), ("target", fu_tgt))
                   if f.dropped}
        if dropped:
            counts["bands_left_out"] = dropped
    t_xy, r_xy = kp_tgt.xy[m.pairs[:, 0]], kp_ref.xy[m.pairs[:, 1]]
    if images:
        return t_xy * f_tgt, r_xy * f_ref, counts, (fu_ref, fu_tgt, f_ref, f_tgt)
    return t_xy * f_tgt, r_xy * f_ref, counts


#: status of a tie point LSM was not tried on: too far from the approximate homography (a likely mismatch)
NOT_TRIED = "not refined (far from the approximate homography)"
#: status of every tie point when no approximate homography could be found to start LSM from
NO_START = "not refined (no approximate homography)"


@dataclass(frozen=True)
class LsmPoints:
    """Tie points refined by :func:`lsm_tie_points` (row i = tie point i).

    ``xy`` (N, 2): the refined target position where LSM converged, the keypoint's elsewhere;
    ``sigma`` (N,): radial σ = sqrt(σx² + σy²) of the refined position in target pixels (NaN
    unless converged); ``scale`` (N,): target pixels per reference pixel at the point (from the
    LSM affinity; converts σ to reference pixels); ``status`` (N,): the LSM status words of
    :mod:`fotogeo.matching.status`, or :data:`NOT_TRIED` / :data:`NO_START`.
    """

    xy: np.ndarray
    sigma: np.ndarray
    scale: np.ndarray
    status: np.ndarray
    jacobian: np.ndarray | None = None  # (N, 2, 2) LSM affinity d(target)/d(reference) (NaN: not tried)

    @property
    def converged(self) -> np.ndarray:
        from ...matching import CONVERGED
        return self.status == CONVERGED

    def summary(self, original: np.ndarray) -> dict:
        """Counts per status, and the median shift from ``original`` and median σ of the converged."""
        ok = self.converged
        moved = np.hypot(*(self.xy[ok] - original[ok]).T)
        words, n = np.unique(self.status, return_counts=True)
        return {"refined": int(ok.sum()), "of": int(len(ok)), "status": dict(zip(words.tolist(), n.tolist())),
                "median_shift_px": float(np.median(moved)) if ok.any() else None,
                "median_sigma_px": float(np.median(self.sigma[ok])) if ok.any() else None}


def lsm_tie_points(fu_ref, fu_tgt, ref_xy, tgt_xy, *, half_window: int = 10, max_shift: float = 3.0,
                   prefilter: float = 15.0, homography=None, tolerance: float = 1e-3) -> LsmPoints:
    """Target tie-point positions refined by least-squares matching (:func:`fotogeo.matching.lsm_many`).

    The template is the reference's linearly stretched first component around each reference
    keypoint (``(2h+1)²`` pixels, ``h = half_window``), searched in the target's; the approximate
    local affinity comes from a RANSAC homography between the two keypoint sets (its Jacobian at
    each point; or the ``homography`` given, reference -> target pixels), so rotated and scaled
    pairs converge. Pairs farther than ``prefilter`` pixels from that homography (mismatches, or
    relief the homography does not follow) are not tried. LSM stops when a step is below
    ``tolerance`` px. Points are in the pixels of the fused images (corner convention).
    """
    from ...matching import lsm_many
    n = len(ref_xy)
    sigma, scale = np.full(n, np.nan), np.full(n, np.nan)
    H = homography
    if H is None:
        try:
            H = ransac(Projective, ref_xy, tgt_xy, 3.0, rng=0, max_trials=2000).model
        except FotogeoError:
            return LsmPoints(tgt_xy.copy(), sigma, scale, np.full(n, NO_START, dtype=object))
    e = 0.5
    jx = (H.forward(ref_xy + [e, 0]) - H.forward(ref_xy - [e, 0])) / (2 * e)
    jy = (H.forward(ref_xy + [0, e]) - H.forward(ref_xy - [0, e])) / (2 * e)
    J = np.stack([jx, jy], axis=2)  # J[:, :, k] = d(target)/d(reference axis k)
    tried = np.hypot(*(H.forward(ref_xy) - tgt_xy).T) <= prefilter
    status = np.full(n, NOT_TRIED, dtype=object)
    out = tgt_xy.copy()
    jac = np.full((n, 2, 2), np.nan)
    if tried.any():
        ref_img, tgt_img = lsm_image(fu_ref), lsm_image(fu_tgt)
        res = lsm_many(ref_img, tgt_img, ref_xy[tried], tgt_xy[tried], half_window=half_window,
                       approx_jacobian=J[tried], max_shift=max_shift, tolerance=tolerance)
        ok = res.ok
        idx = np.flatnonzero(tried)
        status[idx] = res.status
        out[idx[ok]] = res.xy[ok]
        sigma[idx[ok]] = np.hypot(*res.sigma[ok].T)
        A = res.affine[:, :, :2]
        scale[idx] = np.sqrt(np.abs(A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]))
        jac[idx] = A
    return LsmPoints(out, sigma, scale, status.astype(str), jac)


#: invalid specks of at most this many pixels inside valid data are matched as the values they have
MAX_SPECK = 16


def lsm_image(fused) -> np.ndarray:
    """The fused image for LSM: NaN where invalid, except specks of at most :data:`MAX_SPECK` pixels.

    A nodata value that valid pixels also take (0 in the dark water of a uint8 scene with nodata 0)
    marks scattered pixels invalid inside the scene; LSM refuses any window touching one, which lost
    two thirds of the tie points of the Landsat test pair. Their fused value (the darkest) is kept.
    """
    img = fused.image.astype(np.float32)
    img[_without_specks(~np.asarray(fused.mask, bool))] = np.nan
    return img


def _without_specks(invalid: np.ndarray) -> np.ndarray:
    """``invalid`` without its specks: connected invalid areas of at most :data:`MAX_SPECK` pixels
    that do not touch the image border.

    >>> m = np.zeros((6, 6), bool); m[2, 3] = m[0, 0] = True
    >>> _without_specks(m).nonzero()
    (array([0]), array([0]))
    """
    import cv2
    if not invalid.any():
        return invalid
    n, label, stats, _ = cv2.connectedComponentsWithStats(invalid.astype(np.uint8), connectivity=8)
    x, y, w, h, area = (stats[:, k] for k in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                               cv2.CC_STAT_HEIGHT, cv2.CC_STAT_AREA))
    inner = (x > 0) & (y > 0) & (x + w < invalid.shape[1]) & (y + h < invalid.shape[0])
    speck = (area <= MAX_SPECK) & inner
    speck[0] = False  # label 0: the valid pixels
    return invalid & ~speck[label]


def refine_lsm(fu_ref, fu_tgt, ref_xy, tgt_xy, half_window: int = 10):
    """Refine target tie-point positions by least-squares matching (:func:`lsm_tie_points`); points
    whose LSM does not converge keep their keypoint position. Returns (xy, summary)."""
    pts = lsm_tie_points(fu_ref, fu_tgt, ref_xy, tgt_xy, half_window=half_window, prefilter=np.inf)
    return pts.xy, pts.summary(tgt_xy)


@tool("MATCH", rasters={"reference": None, "target": None})
def match_images(reference, target, output, *, overwrite: bool = False, progress=None, **options) -> dict:
    """Detect and match features only: write the tie points of ``target`` ↔ ``reference`` to the
    GeoPackage ``output`` (layer ``tie_points``), without fitting a georeference or resampling.

    Points lie at their reference map positions (reference CRS) when the reference is
    georeferenced, else at their reference pixel positions (no CRS). Fields: ``id``,
    ``target_col``, ``target_row``, ``ref_col``, ``ref_row`` (full resolution, corner
    convention), ``inlier`` (1 when consistent with a RANSAC homography between the pixel sets
    at ``ransac_threshold`` reference pixels). Options as :class:`RegisterOptions`.
    """
    import shapely
    opts = RegisterOptions(**options)
    opts.validate()
    prog = as_progress(progress)
    check_output(output, [reference, target], overwrite, "tie-point layer", (".gpkg",))
    ref, tgt = open_raster(reference, "reference"), open_raster(target, "target")
    src, ref_xy, counts = find_tie_points(ref, tgt, opts, prog.stage(0.0, 0.9, "matching"))
    try:
        inl = ransac(Projective, src, ref_xy, opts.ransac_threshold, rng=opts.seed,
                     min_inliers=WEAK_INLIERS).inliers
    except FotogeoError:
        inl = np.zeros(len(src), bool)
        warnings.warn(f"fewer than {WEAK_INLIERS} of the {len(src)} matches agree on one homography, so none is "
                      f"flagged an inlier: check that {str(reference)!r} and {str(target)!r} overlap",
                      FotogeoWarning, stacklevel=2)
    pts = pixel_to_map(ref.transform, ref_xy) if ref.georeferenced else ref_xy
    layer = {"id": np.arange(len(src), dtype=np.int64), "target_col": src[:, 0], "target_row": src[:, 1],
             "ref_col": ref_xy[:, 0], "ref_row": ref_xy[:, 1], "inlier": inl.astype(np.int64),
             "geometry": shapely.points(pts)}
    with AtomicOutputs(overwrite) as out:
        write_layers(out.temp(output), {"tie_points": layer}, ref.crs.to_wkt() if ref.georeferenced else None)
        prog(1.0, "done")
        out.commit()
    return {"output": str(output), **counts, "inliers": int(inl.sum())}
