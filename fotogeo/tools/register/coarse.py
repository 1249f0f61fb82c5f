"""Coarse pre-alignment of an unreferenced target, for the area-based windows of :mod:`.local`.

The windows of ``fotogeo coreg`` measure shifts of a few pixels on the target's own grid, so they
need a georeference to start from. An unreferenced target (a scanned or raw archive image) gets one
here: the similarity target pixel -> reference pixel found by Fourier–Mellin
(:func:`fotogeo.coreg.similarity.estimate_similarity`: rotation, scale, offset, any rotation, scales
0.4–2.5) on the matching bands read at most ``FINE_SIDE`` px across, composed with the reference's
geotransform. The target is not resampled: a VRT beside nothing of the user's (a temporary folder)
gives the target file that georeference, and the windows then run as for a georeferenced target.
After a weak feature fit the windows start from that fit instead (:func:`seed_from_fit`, its affine part).
A similarity whose confidence (the translation's peak ratio) is below
:data:`fotogeo.coreg.similarity.MIN_CONFIDENCE` is refused: the images may not show the same area.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from affine import Affine

from ...coreg.similarity import FINE_SIDE, MIN_CONFIDENCE, estimate_similarity
from ...io.raster import gdal_env, ropen
from ...io.warp_tiles import write_vrt


def read_grey(path, band: int, nodata, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Band ``band`` of ``path`` averaged down by ``factor`` (float32, NaN at ``nodata``) and the
    scale matrix from its pixels to the file's (corner convention)."""
    from rasterio.enums import Resampling
    with gdal_env(), ropen(path) as ds:
        w, h = max(16, int(round(ds.width / factor))), max(16, int(round(ds.height / factor)))
        nd = ds.nodata if nodata is None else nodata
        a = ds.read(band, out_shape=(h, w), resampling=Resampling.average).astype(np.float32)
        if nd is not None:
            valid = ds.read_masks(band, out_shape=(h, w), resampling=Resampling.nearest) > 0 if nodata is None \
                else a != nd
            a[~valid] = np.nan
        return a, np.diag([ds.width / w, ds.height / h, 1.0])


def pre_align(reference, target, ref, tgt, opts, folder, bands: tuple[int, int]):
    """``(vrt path, target info with the pre-alignment's georeference, report entry)``; the VRT is
    written into ``folder``. Raises :class:`~fotogeo.errors.MatchingError` when refused."""
    factor = max(1.0, max(tgt.width, tgt.height) / FINE_SIDE)
    R, S_r = read_grey(reference, bands[0], opts.reference_nodata, factor)
    T, S_t = read_grey(target, bands[1], opts.target_nodata, factor)
    sim = estimate_similarity(R, T, min_confidence=MIN_CONFIDENCE, name=f"the target {str(target)!r}")
    M = S_r @ sim.matrix @ np.linalg.inv(S_t)  # target px -> reference px, full resolution
    vrt, aligned = georeferenced_vrt(target, ref, tgt, opts, folder, M)
    scale = float(np.sqrt(abs(np.linalg.det(M[:2, :2]))))
    report = {"method": "Fourier-Mellin (log-polar magnitude spectra + phase correlation)",
              "rotation_deg": round(float(np.degrees(np.arctan2(M[1, 0], M[0, 0]))), 3),
              "scale_target_px_in_reference_px": round(scale, 5),
              "offset_reference_px": [round(float(v), 2) for v in M[:2, 2]],
              "confidence_peak_ratio": round(sim.confidence, 2), "min_confidence": MIN_CONFIDENCE,
              "rotation_scale_peak_ratio": round(sim.rotation_ratio, 2), "read_at_factor": round(factor, 3),
              "note": "the target had no georeference: the windows ran on the target pre-aligned by this "
                      "similarity (target pixel -> reference pixel)"}
    return vrt, aligned, report


def georeferenced_vrt(target, ref, tgt, opts, folder, M):
    """``(vrt path, target info)``: the target given the georeference ``ref.transform · M`` (``M``: 3x3 affine,
    target pixel -> reference pixel) by a VRT written into ``folder``; the target's pixels are not resampled."""
    transform = ref.transform * Affine(M[0, 0], M[0, 1], M[0, 2], M[1, 0], M[1, 1], M[1, 2])
    nodata = tgt.nodata if opts.target_nodata is None else opts.target_nodata
    vrt = write_vrt(Path(folder) / "target_pre_aligned.vrt", [(Path(target).resolve(), (0, 0, tgt.height,
                                                                                         tgt.width))],
                    crs=ref.crs, transform=transform, width=tgt.width, height=tgt.height, count=tgt.count,
                    dtype=tgt.dtype, nodata=nodata)
    return vrt, replace(tgt, path=Path(vrt), raster_crs=ref.raster_crs, transform=transform)


def seed_from_fit(target, ref, tgt, opts, folder, to_reference_px):
    """``(vrt path, target info, report entry)``: the windows' starting georeference from a feature fit —
    the affine map target pixel -> reference pixel closest (least squares on a 9 x 9 grid over the target)
    to ``to_reference_px`` (the fit's target pixel -> reference pixel, possibly projective)."""
    g = np.linspace(0.0, 1.0, 9)
    src = np.stack(np.meshgrid(g * tgt.width, g * tgt.height), -1).reshape(-1, 2)
    dst = to_reference_px(src)
    A = np.column_stack([src, np.ones(len(src))])
    coef = np.linalg.lstsq(A, dst, rcond=None)[0]  # (3, 2)
    M = np.vstack([coef.T, [0.0, 0.0, 1.0]])
    vrt, aligned = georeferenced_vrt(target, ref, tgt, opts, folder, M)
    left = float(np.hypot(*(A @ coef - dst).T).max())
    return vrt, aligned, {"method": "the feature fit's affine part (least squares over the target)",
                          "max_departure_reference_px": round(left, 3),
                          "note": "the windows ran on the target given the feature fit's georeference"}
