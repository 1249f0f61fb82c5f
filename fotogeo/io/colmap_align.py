"""A COLMAP model left in COLMAP's own frame, aligned to the images' own GPS as ``colmap model_aligner`` does.

COLMAP's mapper leaves the model in an arbitrary frame (scale, rotation and origin of its first pair);
``colmap model_aligner --ref_images_path`` estimates the similarity ``X_map = s·Q·X + t`` from the camera centres
``X`` and their GPS positions. Here the same similarity is fitted when at least :data:`MIN_IMAGES` of the images
given carry an EXIF/XMP GPS position: to their map coordinates ``(E, N)`` in the map CRS and their GPS altitude
(the map axes are taken as Cartesian, as for a model aligned into a projected CRS), weighted by their horizontal
and vertical σ (the accuracy tags; without them a consumer receiver, :data:`~fotogeo.io.sfm_frame.DEFAULT_SIGMA_H`
horizontally and twice that vertically). An image with latitude and longitude but no GPS altitude is left out
and named: its altitude is never taken as 0. The fit (:mod:`fotogeo.geometry.similarity3d`, Umeyama 1991) leaves
out one bad fix when five or more images carry GPS; it is refused, naming ``--crs`` and ``model_aligner``, when

* fewer than :data:`MIN_IMAGES` of them carry a GPS altitude (latitude and longitude alone leave the heights and
  the tilt free: they are not invented; the images without one are named),
* the centres with GPS lie on a line (the normal matrix of the fit is singular,
  :data:`~fotogeo.geometry.similarity3d.MAX_CONDITION`: the rotation about the line is free),
* the residuals exceed 3σ RMS (χ² per degree of freedom >
  :data:`~fotogeo.geometry.similarity3d.CHI2_DOF_MAX`): the GPS σ is understated or the model is not rigid, or
* the fit's covariance leaves the tilt more uncertain than :data:`MAX_TILT_DEG` (few images, a small block, a
  narrow strip, a poor GPS). A shape ratio alone decides nothing: two RTK strips 40 m apart and 1.5 km long are a
  thin block whose tilt their GPS (σ 2 cm) fixes to ±0.005°.

Then each centre becomes ``s·Q·C + t`` and each world → camera rotation ``R·Qᵀ``. The alignment is only as good as
the GPS: its precision (the σ of the aligned centres and of the tilt, from the fit's covariance) is stated, and a
warning is given when it exceeds :data:`SURVEY_M`. The heights are the GPS altitudes': their vertical reference is
the images' common one when their vendor documents it (senseFly, DJI with RTK: the ellipsoid), else unknown.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import FotogeoWarning, InputError

#: images with GPS needed to align a model
MIN_IMAGES = 3
#: σ (m) of the aligned centres above which the alignment is announced as a warning, not a note
SURVEY_M = 0.05
#: σ (°) of the tilt beyond which the alignment is refused (±9 m per 100 m of height: no georeference at all)
MAX_TILT_DEG = 5.0
#: how the reading of an aligned model begins (:func:`aligned_to_gps`)
ALIGNED = "COLMAP model in its own frame aligned to the images' own GPS"


def aligned_to_gps(block) -> bool:
    """Whether ``block`` was aligned to the images' GPS here: its fit to them is tested already (the χ² of the
    similarity, one fix left out), so it is not tested again against every fix."""
    return block.frame_reading.startswith(ALIGNED)


def _refuse(where: str, why: str) -> InputError:
    return InputError(f"{where}: it is in COLMAP's own frame and {why}; geo-register it (colmap model_aligner, with "
                      f"GCPs or better GPS) and give the CRS of its positions (--crs)")


def _with_altitude(images: list, gps: dict, where: str) -> list:
    """Indices of ``images`` whose GPS carries an altitude; an :class:`InputError` naming the images without one
    when fewer than :data:`MIN_IMAGES` do (heights and tilt would be invented); None below MIN_IMAGES with GPS."""
    from .sfm_frame import project_key
    keys = [project_key(n) for n, *_ in images]
    used = [k for k, key in enumerate(keys) if key in gps]
    if len(used) < MIN_IMAGES:
        return None
    high = [k for k in used if gps[keys[k]].alt is not None]
    if len(high) < MIN_IMAGES:
        low = [keys[k] for k in used if gps[keys[k]].alt is None]
        raise _refuse(where, f"{len(low)} of its {len(used)} images with GPS carry latitude and longitude but no GPS "
                             f"altitude ({', '.join(low[:3])}{', ...' if len(low) > 3 else ''}): without heights "
                             f"their GPS fixes neither the model's heights nor its tilt")
    return high


def _common_reference(fixes) -> str | None:
    refs = {g.height_reference for g in fixes}
    return refs.pop() if len(refs) == 1 else None


def align_to_gps(images: list, gps: dict, map_crs, where: str) -> tuple:
    """``(images in map_crs, sentence, height reference)``: ``images`` ``[(name, camera id, C, R_wc)]`` of a model
    in COLMAP's own frame aligned to ``gps`` ``{frame key: GpsFix}`` (module docstring); the heights' reference is
    the fixes' common one (None: unknown); None when fewer than :data:`MIN_IMAGES` images carry GPS; an
    :class:`InputError` naming ``--crs`` when the alignment is ill-determined or contradicted."""
    from ..geometry.similarity3d import CHI2_DOF_MAX, robust_similarity, similarity_precision
    from .sfm_frame import TAG_SIGMA, gps_for, map_xy, project_key
    keys = [project_key(n) for n, *_ in images]
    gps = gps_for(gps, keys)
    used = _with_altitude(images, gps, where)
    if used is None:
        return None
    no_alt = [key for key in keys if key in gps and gps[key].alt is None]
    fixes = [gps[keys[k]] for k in used]
    x = np.array([images[k][2] for k in used], float)
    xy = map_xy(map_crs, [g.lon for g in fixes], [g.lat for g in fixes])
    y = np.column_stack([xy, [g.alt for g in fixes]])
    sh = np.array([max(g.sigma_h, TAG_SIGMA) for g in fixes])
    sv = np.array([max(g.sigma_v, TAG_SIGMA) if g.sigma_v else 2.0 * h for g, h in zip(fixes, sh)])
    sigma = np.column_stack([sh, sh, sv])
    fit = robust_similarity(x, y, sigma)
    names = [keys[k] for k in used]
    keep = np.ones(len(used), bool)
    if fit.left_out is not None:
        keep[fit.left_out] = False
    res = fit.residuals
    rms_h = float(np.sqrt(np.mean(np.sum(res[keep, :2] ** 2, axis=1))))
    rms_v = float(np.sqrt(np.mean(res[keep, 2] ** 2)))
    if fit.chi2_dof > CHI2_DOF_MAX or not fit.similarity.scale > 0:
        off = np.linalg.norm(res / sigma, axis=1)
        worst = ", ".join(f"{names[i]} {np.linalg.norm(res[i]):.2f} m" for i in np.argsort(-off)[:3])
        raise _refuse(where, f"a similarity to the GPS of its {len(used)} images leaves residuals of {rms_h:.2f} m "
                             f"RMS horizontally, {rms_v:.2f} m vertically, more than 3 x their σ "
                             f"({np.median(sh):.3g} m, {np.median(sv):.3g} m; {worst})")
    sim = fit.similarity
    all_c = np.array([c for _, _, c, _ in images], float)
    prec = similarity_precision(sim, x[keep], sigma[keep], at=all_c, chi2_dof=fit.chi2_dof)
    if not np.isfinite(prec.tilt_deg):
        raise _refuse(where, f"the centres of its {int(keep.sum())} images with GPS lie on a line (condition number "
                             f"{prec.condition:.2g}): their GPS leaves the rotation about that line free")
    if prec.tilt_deg > MAX_TILT_DEG:
        raise _refuse(where, f"the GPS of its {len(used)} images (σ {np.median(sh):.3g} m, {np.median(sv):.3g} m) "
                             f"determines its tilt only to ±{prec.tilt_deg:.1f}°")
    out = [(n, cid, sim.apply(c[None])[0], R @ sim.rotation.T) for n, cid, c, R in images]
    tagged = all(g.tagged for g in fixes)
    dropped = f"; {names[fit.left_out]}'s GPS left out ({np.linalg.norm(res[fit.left_out]):.2f} m off)" \
        if fit.left_out is not None else ""
    if no_alt:
        dropped += (f"; {len(no_alt)} image(s) without GPS altitude left out ({', '.join(no_alt[:3])}"
                    f"{', ...' if len(no_alt) > 3 else ''})")
    ref = _common_reference(fixes)
    per100 = 100.0 * math.tan(math.radians(prec.tilt_deg))
    said = (f"{ALIGNED} as colmap model_aligner does "
            f"(similarity, Umeyama 1991): {int(keep.sum())} images, GPS σ {np.median(sh):.3g} m horizontally, "
            f"{np.median(sv):.3g} m vertically" + ("" if tagged else " (no accuracy tags: a consumer receiver "
                                                                     "assumed)")
            + f", scale {sim.scale:.6g}, residuals {rms_h:.3f} m RMS horizontally, {rms_v:.3f} m vertically{dropped}; "
              f"expected error of the cameras ±{prec.horizontal:.3f} m horizontally, ±{prec.vertical:.3f} m "
              f"vertically, tilt ±{prec.tilt_deg:.3f}° (±{per100:.3f} m per 100 m of height above the ground); "
              f"heights are the GPS altitudes' (" + (f"above the {ref}, as the images' vendor documents)" if ref
                                                      else "reference not stated)"))
    if prec.horizontal > SURVEY_M or per100 > SURVEY_M:
        warnings.warn(f"{where}: aligned to the images' GPS only: expected error ≈ {prec.horizontal:.2f} m "
                      f"horizontally at the cameras plus {per100:.2f} m per 100 m of height (tilt ±"
                      f"{prec.tilt_deg:.2f}°), not an accurate georeference; align it with GCPs or RTK GPS "
                      f"(colmap model_aligner) for better", FotogeoWarning, stacklevel=4)
    return out, said, ref
