"""The matching tool: keypoints in both images, descriptor matching, optional LSM refinement.

:func:`find_tie_points` is the first half of the registration (Dihkan 2019: PCA fusion, SURF,
SSD ratio test); :func:`match_images` writes its tie points as a layer without fitting a model.
A :class:`FeatureCache` lets an image matched in many pairs (a frame of a block) be read, fused
and detected once.
"""
from __future__ import annotations

import numpy as np

from ..errors import FotogeoError, MatchingError
from ..features.detect import detect
from ..features.match import match_descriptors
from ..image.contrast import apply_contrast
from ..image.fusion import pca_fuse
from ..io.raster import AtomicOutputs, check_output, open_raster, read_decimated
from ..io.vector import write_layers
from ..models import Projective, ransac
from ..options import RegisterOptions
from ..pixels import pixel_to_map
from ..progress import as_progress
from .boundary import tool


def fused_for_matching(info, role, opts):
    """``(fused, factor)``: the image matched (decimated to ``opts.max_match_pixels``, PCA-fused) and its
    decimation factors (full-resolution pixels = matched pixels x factor)."""
    bands, mask, factor = read_decimated(info, opts.max_match_pixels, role)
    override = getattr(opts, f"{role}_nodata")
    fused = pca_fuse(bands, mask, nodata=info.nodata if override is None else override, rng=opts.seed,
                     contrast="linear", name=f"{role} {info.path}")
    return fused, np.asarray(factor, float)


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


def find_tie_points(ref, tgt, opts, prog=None, *, cache: FeatureCache | None = None):
    """Keypoints in both images, matched: ``(target_xy, reference_xy, counts)`` in full-resolution
    pixels (corner convention). ``ref``/``tgt`` are :class:`~fotogeo.io.raster.RasterInfo`.
    Wall times of the steps go to ``prog.timings`` (:meth:`fotogeo.progress.Progress.timed`).
    With a ``cache``, keypoints already detected are reused (the same results: detection is
    deterministic); it is not used with ``opts.refine == "lsm"``, which needs the fused images."""
    prog = as_progress(prog)
    stages = (prog.stage(0.0, 0.45, "reference: reading"), prog.stage(0.45, 0.9, "target: reading"))
    if cache is not None and opts.refine != "lsm":
        kp_ref, f_ref, ex_ref = cache.features(ref, "reference", opts, stages[0])
        kp_tgt, f_tgt, ex_tgt = cache.features(tgt, "target", opts, stages[1])
        fu_ref = fu_tgt = None
    else:
        kp_ref, f_ref, fu_ref = _features(ref, "reference", opts, stages[0])
        kp_tgt, f_tgt, fu_tgt = _features(tgt, "target", opts, stages[1])
        ex_ref, ex_tgt = fu_ref.explained, fu_tgt.explained
    with prog.stage(0.9, 1.0, "matching descriptors").timed("match"):
        m = match_descriptors(kp_tgt.descriptors, kp_ref.descriptors, ratio=opts.ratio, mutual=opts.mutual,
                              laplacian1=kp_tgt.laplacian, laplacian2=kp_ref.laplacian)
    min_pts = 6
    if len(m) < min_pts:
        raise MatchingError(f"only {len(m)} descriptor matches between {str(tgt.path)!r} and "
                            f"{str(ref.path)!r} (found {len(kp_tgt)} and {len(kp_ref)} keypoints); {HINT}")
    counts = {"keypoints": {"reference": len(kp_ref), "target": len(kp_tgt)}, "matches": len(m),
              "pca_explained_variance": {"reference": ex_ref, "target": ex_tgt}}
    t_xy, r_xy = kp_tgt.xy[m.pairs[:, 0]], kp_ref.xy[m.pairs[:, 1]]
    if opts.refine == "lsm":
        with prog.timed("refine_lsm"):
            t_xy, counts["lsm"] = refine_lsm(fu_ref, fu_tgt, r_xy, t_xy)
    return t_xy * f_tgt, r_xy * f_ref, counts


def refine_lsm(fu_ref, fu_tgt, ref_xy, tgt_xy, half_window: int = 10):
    """Refine target tie-point positions by least-squares matching (:func:`fotogeo.matching.lsm_many`).

    The template is the reference's linearly stretched first component around each reference
    keypoint; the approximate local affinity comes from a RANSAC homography between the two
    keypoint sets (its Jacobian at each point), so rotated and scaled pairs converge. Points
    whose LSM does not converge keep their keypoint position. Returns (xy, summary).
    """
    from ..matching import CONVERGED, lsm_many
    try:
        H = ransac(Projective, ref_xy, tgt_xy, 3.0, rng=0, max_trials=2000).model
    except FotogeoError:
        return tgt_xy, {"refined": 0, "note": "no homography to start LSM from"}
    e = 0.5
    jx = (H.forward(ref_xy + [e, 0]) - H.forward(ref_xy - [e, 0])) / (2 * e)
    jy = (H.forward(ref_xy + [0, e]) - H.forward(ref_xy - [0, e])) / (2 * e)
    J = np.stack([jx, jy], axis=2)  # J[:, :, k] = d(target)/d(reference axis k)
    ref_img = np.where(fu_ref.mask, fu_ref.image, np.nan).astype(np.float32)
    tgt_img = np.where(fu_tgt.mask, fu_tgt.image, np.nan).astype(np.float32)
    res = lsm_many(ref_img, tgt_img, ref_xy, tgt_xy, half_window=half_window, approx_jacobian=J,
                   max_shift=3.0)
    ok = np.asarray(res.status) == CONVERGED
    out = tgt_xy.copy()
    out[ok] = res.xy[ok]
    moved = np.hypot(*(out[ok] - tgt_xy[ok]).T) if ok.any() else np.zeros(0)
    return out, {"refined": int(ok.sum()), "of": int(len(ok)),
                 "median_shift_px": float(np.median(moved)) if len(moved) else None,
                 "median_sigma_px": float(np.median(np.hypot(*res.sigma[ok].T))) if ok.any() else None}


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
    check_output(output, [reference, target], overwrite, "tie-point layer")
    ref, tgt = open_raster(reference, "reference"), open_raster(target, "target")
    src, ref_xy, counts = find_tie_points(ref, tgt, opts, prog.stage(0.0, 0.9, "matching"))
    try:
        inl = ransac(Projective, src, ref_xy, opts.ransac_threshold, rng=opts.seed).inliers
    except FotogeoError:
        inl = np.zeros(len(src), bool)
    pts = pixel_to_map(ref.transform, ref_xy) if ref.georeferenced else ref_xy
    layer = {"id": np.arange(len(src), dtype=np.int64), "target_col": src[:, 0], "target_row": src[:, 1],
             "ref_col": ref_xy[:, 0], "ref_row": ref_xy[:, 1], "inlier": inl.astype(np.int64),
             "geometry": shapely.points(pts)}
    with AtomicOutputs(overwrite) as out:
        write_layers(out.temp(output), {"tie_points": layer}, ref.crs.to_wkt() if ref.georeferenced else None)
        prog(1.0, "done")
        out.commit()
    return {"output": str(output), **counts, "inliers": int(inl.sum())}
