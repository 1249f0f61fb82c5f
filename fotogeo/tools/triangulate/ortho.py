"""Frames on the ground after a bundle adjustment: footprints and orthorectified frames.

Each adjusted frame becomes a ground → image model
(:class:`fotogeo.orientation.adjusted_frame.AdjustedFrame`: the bundle
adjustment's collinearity with Brown's distortion, :mod:`fotogeo.orientation.bundle_jacobian`)
placed on the terrain by :class:`fotogeo.geometry.georeference.Georeference`:

* **footprints** — the image outline (33 points per edge) intersected with the DEM, or with the
  plane at the mean height of the adjusted points when there is no DEM;
* **orthorectified frames** — ``fotogeo ortho``'s orthophotos, through its own code
  (:func:`fotogeo.tools.ortho.tool.plan_grid`, :func:`fotogeo.tools.ortho.tool.write_orthophoto`): the DEM under the frames,
  the north-up grid aligned to the resolution (the frame's ground sample distance unless given) and clipped to the
  DEM where the frame leaves it, cells without a height nodata, internal overviews, ``FOTOGEO_NADIR`` for
  ``fotogeo mosaic``; a frame's heights are first checked against those of the adjusted points
  (:func:`fotogeo.tools.orient.rectify.check_terrain_heights`);
* **uncertainty rasters** (``uncertainty``) — beside each orthophoto ``<frame>_ortho_sigma.tif``, the predicted
  planimetric σ of every cell from this adjustment's covariance (the report's ``frames[].covariance``) and the
  DEM's σ: the raster ``fotogeo ortho --uncertainty`` writes from the same report
  (:mod:`fotogeo.tools.ortho.products`, :mod:`fotogeo.orientation.ground_sigma`).
"""
from __future__ import annotations

import warnings

import numpy as np

from ...errors import FotogeoWarning, InputError, ModelError
from ...geometry.georeference import Georeference
from ...orientation.adjusted_frame import AdjustedFrame


def frame_models(result, block) -> list:
    """One :class:`AdjustedFrame` per frame of the adjusted block."""
    return [AdjustedFrame(result.camera, e, result.distortion, n) for n, e in zip(block.frames, result.eo)]


#: the largest angle from the nadir a ray may leave a frame at and still find its ground in the DEM window read
#: before the adjustment (:func:`dem_near_frames`); flatter rays, if any, find no height there (NaN: left out)
MAX_OFF_NADIR_DEG = 80.0


def frame_reach(camera, eos, lowest: float) -> list:
    """The ground the frames ``eos`` can see down to the height ``lowest``, as the corners of one square per frame
    (``[(4, 2)]`` in the frames' CRS): centred below the frame, half side ``(Z − lowest)·tan θ``, ``θ`` the angle of
    its optical axis from the nadir plus half the field of view's diagonal (at most :data:`MAX_OFF_NADIR_DEG`)."""
    w, h = camera.image_size
    half = np.arctan(np.hypot(0.5 * w / camera.fx, 0.5 * h / camera.fy))
    out = []
    for e in eos:
        axis = e.rotation_cv @ np.array([0.0, 0.0, 1.0])
        theta = min(float(np.arccos(np.clip(-axis[2], -1.0, 1.0))) + half, np.radians(MAX_OFF_NADIR_DEG))
        r = max(e.Z - lowest, 0.0) * np.tan(theta)
        out.append(np.array([[e.X - r, e.Y - r], [e.X + r, e.Y - r], [e.X + r, e.Y + r], [e.X - r, e.Y + r]]))
    return out


def dem_near_frames(dem, crs, camera, eos):
    """The DEM ``dem`` around the frames ``eos`` before any adjustment (their ground, :func:`frame_reach`, read by
    :func:`fotogeo.tools.ortho.inputs.read_dem_around`: memory bounded by the block's area, not a regional DEM's),
    as a height source in the map CRS ``crs``; None when no height of it lies there (the start then measures on a
    plane, as without a DEM; the stages after the adjustment say what they lack)."""
    from ..orient.rectify import dem_heights
    from ..ortho.inputs import read_dem_around
    d = read_dem_around(dem, crs, lambda lo, hi: frame_reach(camera, eos, lo), None)
    return None if d is None else dem_heights(d, crs)


def terrain(dem, crs, result, images=()):
    """The height source: the DEM in the map CRS (with the frames ``images``, :func:`frame_images`, the part under
    them, as ``fotogeo ortho`` reads it: :func:`fotogeo.tools.ortho.inputs.terrain`), else the mean height of the
    adjusted points."""
    if dem is not None and images:
        from ..ortho.inputs import terrain as ortho_terrain
        return ortho_terrain(dem, None, crs, images)[0]
    if dem is not None:
        from ..orient.rectify import dem_heights
        return dem_heights(dem, crs)
    z = result.point_xyz[:, 2]
    return float(np.nanmean(z)) if np.isfinite(z).any() else 0.0


def frame_images(result, block, frames) -> list:
    """The adjusted frames as the images ``fotogeo ortho`` orthorectifies
    (:class:`~fotogeo.tools.ortho.inputs.OrthoImage`, model :class:`AdjustedFrame`)."""
    from ..ortho.inputs import OrthoImage
    w, h = block.camera.image_size
    return [OrthoImage(str(p), n, m, "frame", int(w), int(h))
            for p, n, m in zip(frames, block.frames, frame_models(result, block))]


def footprints(result, block, heights, crs) -> dict:
    """The ``footprints`` layer: one polygon per frame on ``heights``; frames that leave the DEM
    get the outline of the points that reach it (empty when none does)."""
    import shapely
    w, h = block.camera.image_size
    polys, complete = [], []
    for model in frame_models(result, block):
        XY = Georeference(model, heights=heights, crs=crs).footprint(w, h)
        ok = np.isfinite(XY).all(axis=1)
        polys.append(shapely.polygons(XY[ok]) if ok.sum() >= 4 else shapely.Polygon())
        complete.append(bool(ok.all()))
    return {"geometry": np.array(polys, dtype=object), "name": np.array(block.frames, dtype=str),
            "on_terrain": np.array(complete), "area_m2": np.array([p.area for p in polys])}


def common_resolution(grids: dict) -> float | None:
    """One pixel size for every orthophoto of a mosaic (``fotogeo mosaic`` needs one lattice): the median of the
    frames' ground sample distances (their grids' resolutions), rounded to 3 significant digits; None when no
    frame has a grid."""
    res = [g.resolution for g in grids.values() if not isinstance(g, str)]
    return float(f"{np.median(res):.3g}") if res else None


def ortho_grids(paths: dict, images, heights, crs, dem, ground, resolution, quiet: bool = False,
                compress: str = "deflate") -> dict:
    """Per frame (``images``: :func:`frame_images`), the checked output grid of its orthophoto — ``fotogeo ortho``'s
    (:func:`fotogeo.tools.ortho.tool.plan_grid`: clipped to the DEM where the frame leaves it) once its heights pass
    :func:`fotogeo.tools.orient.rectify.check_terrain_heights` against those of the adjusted points ``ground``; nothing is
    resampled yet. A frame whose grid cannot be made (e.g. off the DEM) gets the reason instead (a string): it
    is reported and skipped, never losing the adjustment's outputs (``quiet``: without the warnings; ``compress``:
    the orthophotos' compression, for the free-space check)."""
    from ..ortho.tool import plan_grid
    from ..orient.rectify import check_terrain_heights
    where = f"the DEM {str(dem)!r}" if dem is not None else f"the mean height {heights:.1f} of the adjusted points"
    grids = {}
    for im in images:
        with warnings.catch_warnings():
            if quiet:
                warnings.simplefilter("ignore", FotogeoWarning)
            try:
                check_terrain_heights(Georeference(im.model, heights=heights, crs=crs), im.width, im.height,
                                      ground[:, 2], where, "the adjusted points")
                grids[im.name] = plan_grid(im, heights, crs, resolution, paths[im.name], str(dem), compress)
            except (ModelError, InputError) as exc:
                grids[im.name] = f"not orthorectified: {str(exc)[:300]}"
                if not quiet:
                    warnings.warn(f"frame {im.name!r} {grids[im.name]}", FotogeoWarning, stacklevel=2)
    return grids


def orthorectify(temp_paths: dict, grids: dict, images, heights, crs, resampling, progress,
                 compress: str = "deflate") -> dict:
    """Resample every frame onto its grid (:func:`ortho_grids`) into ``temp_paths`` through
    :func:`fotogeo.tools.ortho.tool.write_orthophoto`, ``fotogeo ortho``'s own, compressed with ``compress``
    (:mod:`fotogeo.io.compression`); a summary per frame."""
    from ..ortho.tool import write_orthophoto
    out = {}
    for k, im in enumerate(images):
        stage = progress.stage(k / len(images), (k + 1) / len(images), f"orthorectifying {im.name}")
        if isinstance(grids.get(im.name), str) or im.name not in temp_paths:  # reported; the rest is still written
            out[im.name] = {"error": grids.get(im.name, "no grid")}
            continue
        out[im.name] = write_orthophoto(temp_paths[im.name], im, heights, crs, grids[im.name], resampling, stage,
                                        compress=compress)
    return out


def sigma_paths(ortho_paths: dict, uncertainty: bool) -> dict:
    """``sigma:<frame>`` → ``<frame>_ortho_sigma.tif`` beside each orthophoto path of ``ortho_paths``
    (``ortho:<frame>`` keys) with ``uncertainty``; refused without orthophotos to put them beside."""
    if not uncertainty:
        return {}
    if not ortho_paths:
        raise InputError("--uncertainty writes a σ raster beside each orthophoto: give --orthorectify (or --mosaic)",
                         option="uncertainty")
    from ..ortho.products import product_paths
    names = {k.split(":", 1)[1]: p for k, p in ortho_paths.items()}
    return {f"sigma:{n}": d["sigma"] for n, d in product_paths(names, True, False).items()}


def sigma_of_dem(paths: dict, heights, dem_sigma, crs):
    """``(σ_h m, rule)`` of the height source ``heights`` (:func:`terrain`) when ``paths`` has σ rasters
    (:func:`sigma_paths`), else None; checked before anything is written (a constant height needs ``dem_sigma``:
    :func:`fotogeo.tools.ortho.products.dem_sigma_for`)."""
    if not any(k.startswith("sigma:") for k in paths):
        return None
    from ..ortho.products import dem_sigma_for
    return dem_sigma_for(dem_sigma, heights, crs)


def write_sigma_rasters(out, paths: dict, grids: dict, done: dict, rep: dict, heights, crs, images,
                        sigma_h, compress: str = "deflate") -> None:
    """Each orthorectified frame's σ raster (:func:`sigma_paths`) written through ``out``
    (:class:`~fotogeo.io.raster.AtomicOutputs`) on its orthophoto's grid, from the covariances of the report
    ``rep`` (as ``fotogeo ortho --uncertainty`` reads them from report.json), ``heights`` and the frames
    ``images`` (:func:`frame_images`); its entry goes into ``done[frame]`` (the report's ``orthorectified``),
    the DEM's σ into ``rep``; compressed with ``compress``."""
    from ...orientation.ground_sigma import covariances_from_report
    from ..ortho.products import write_products
    covs = covariances_from_report(rep)
    rep["dem_sigma_m"], rep["dem_sigma_rule"] = sigma_h
    for im in images:
        entry = done.get(im.name, {})
        if "error" in entry or f"sigma:{im.name}" not in paths:
            continue
        entry.update(write_products(out, {"sigma": paths[f"sigma:{im.name}"]}, im, heights, grids[im.name], crs,
                                    covs[im.name], sigma_h, compress))
