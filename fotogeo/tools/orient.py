"""The orientation tools: GCPs + image (paths) → fitted model, report, error vectors, exports,
rectified raster; and the model comparison table.

``orient(image, gcps, model=...)`` reads the GCPs (:mod:`fotogeo.io.gcps`), fits the model on
the control points with data snooping (:mod:`fotogeo.orientation`), and writes what is asked:

* ``report`` — JSON: model and coefficients, ``control`` / ``check`` statistics
  (``n``, ``rms_x_px``, ``rms_y_px``, ``rms_xy_px``, min, max, median; ``*_mm`` with a scan
  pixel size), per-point residuals, blunders, warnings;
* ``vectors`` — GeoPackage, layers ``gcps`` (points with residuals) and ``error_vectors``
  (lines from each GCP to where the model puts its measured image point on the ground,
  with ``dx``, ``dy``, ``length`` in map units and ``dx_px``, ``dy_px``; ``exaggeration``);
* ``plot`` — PNG: the residual vectors over the image, coloured by role;
* ``points`` — QGIS Georeferencer ``.points`` file with the residuals;
* ``rpc`` — for the RFM models: a GeoTIFF copy of the image carrying the model as GDAL RPC
  metadata (RPC00B, refitted in lon/lat/h), usable by ``gdalwarp -rpc`` and QGIS;
* ``gcp_tiff`` — for ``poly1``–``poly3``: a GeoTIFF copy of the image carrying the control
  points as GDAL GCPs, so that ``gdalwarp -order N`` / QGIS reproduce the fitted polynomial
  (GDAL fits the same least-squares polynomial of total degree N to the same points);
* ``rectify`` — the image resampled to a map grid in the GCPs' CRS through the model,
  heights from ``dem`` or ``height`` for 3-D models, window by window.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..errors import InputError, ModelError
from ..io.camera import load_camera
from ..io.gcps import check_inside, read_gcps
from ..io.raster import AtomicOutputs, check_output, open_raster, read_decimated
from ..io.report import write_json
from ..io.vector import error_vectors, write_layers
from ..io.warp import grid_covering, warp_to_grid
from ..orientation.adjustment import fit_orientation, resolve_model
from ..progress import as_progress


def _ground_of_pixels(model, pixel, z):
    """Where ``model`` puts image points on the ground (at heights ``z`` for 3-D models)."""
    if model.src_dims == 3:
        return model.inverse(pixel, z=z)[:, :2]
    return model.inverse(pixel)


def orient(image, gcps, *, model: str = "poly1", report=None, vectors=None, plot=None, points=None, rpc=None,
           gcp_tiff=None, rectify=None, dem=None, height=None, scan_pixel_um=None, snooping: bool = True,
           remove_blunders: bool = False, exaggeration: float = 1.0, resolution=None,
           resampling: str = "nearest", crs=None, layer=None, fields=None, camera=None, overwrite: bool = False,
           progress=None) -> dict:
    """Fit ``model`` to the GCPs of ``image`` and write the requested outputs; returns the report.

    ``camera`` (a :class:`~fotogeo.geometry.camera.FrameCamera` or an interior-orientation YAML file)
    is needed by ``collinearity`` only.
    """
    prog = as_progress(progress)
    camera = load_camera(camera)
    cls = resolve_model(model, camera)
    outs = {k: v for k, v in dict(report=report, vectors=vectors, plot=plot, points=points, rpc=rpc,
                                  gcp_tiff=gcp_tiff, rectify=rectify).items() if v}
    if gcp_tiff and model not in ("poly1", "poly2", "poly3"):
        raise InputError(f"a GCP GeoTIFF reproduces polynomial models only (poly1, poly2, poly3 = gdalwarp -order "
                         f"1-3); model {model!r} is not one")
    for k, v in outs.items():
        check_output(v, [image, gcps, dem], overwrite, k)
    if len({Path(v).resolve() for v in outs.values()}) < len(outs):
        raise InputError("two outputs have the same path; give each its own")
    if rpc and not model.startswith("rfm") or (rpc and model.endswith("-i2g")):
        raise InputError(f"--rpc exports a ground-to-image RFM; model {model!r} is not one (use rfm, rfm-common, rfm-poly)")
    info = open_raster(image, "image")
    g = read_gcps(gcps, layer=layer, crs=crs, raster=image if info.georeferenced else None, dem=dem,
                  height=height, **(fields or {}))
    check_inside(g, info.width, info.height, f"{gcps}")
    prog(0.1, "GCPs read")
    scale_mm = scan_pixel_um / 1000.0 if scan_pixel_um else None
    fit = fit_orientation(model, g.ground, g.pixel, g.role, g.ids, snooping=snooping,
                          remove_blunders=remove_blunders, scale_mm=scale_mm, camera=camera)
    prog(0.3, "model fitted")
    z = g.ground[:, 2] if cls.src_dims == 3 else None
    on_ground = _ground_of_pixels(fit.model, g.pixel, z)
    d_ground = on_ground - g.ground[:, :2]
    rep = {"fotogeo": "orient", "image": str(image), "gcps": str(gcps), "model_name": model,
           "crs": g.crs.to_string(), "n_gcps": len(g), **fit.stats, "snooping": fit.snooping,
           "warnings": fit.warnings, "model": fit.model.to_dict(),
           "model_info": {k: v for k, v in getattr(fit.model, "info", {}).items()
                          if isinstance(v, (int, float, str, list, bool))},
           "scan_pixel_um": scan_pixel_um, "units": "pixels (corner convention); ground units of the GCP CRS",
           "points": [{"id": i, "role": r, "col": float(p[0]), "row": float(p[1]), "dx_px": float(v[0]),
                       "dy_px": float(v[1]), "dx_ground": float(dg[0]), "dy_ground": float(dg[1]),
                       **({"dx_mm": float(v[0] * scale_mm), "dy_mm": float(v[1] * scale_mm)} if scale_mm else {})}
                      for i, r, p, v, dg in zip(g.ids, fit.role, g.pixel, fit.residual, d_ground)]}
    with AtomicOutputs() as out:
        if vectors:
            _write_vectors(out.temp(vectors), g, fit, on_ground, d_ground, exaggeration)
        if plot:
            _plot(out.temp(plot), info, g.pixel, fit.residual, fit.role)
        if points:
            from ..io.points import pixel_to_source, write_points
            src = pixel_to_source(g.pixel, info.transform if info.georeferenced else None)
            write_points(out.temp(points), g.ground[:, :2], src, enabled=fit.role == "control",
                         residual=fit.residual, crs=g.crs.to_wkt())
        if rpc:
            from ..io.rpc import write_rpc_geotiff
            from ..orientation.rpc import fit_rpc
            ctrl = fit.role == "control"
            rpc_model, _ = fit_rpc(g.ground[ctrl], g.pixel[ctrl], g.crs, model=model)
            tmp = out.temp(rpc)
            write_rpc_geotiff(image, tmp, rpc_model)
            rep["rpc"] = {"path": str(rpc), **rpc_model.to_gdal_metadata()}
        if gcp_tiff:
            ctrl = fit.role == "control"
            _write_gcp_tiff(image, out.temp(gcp_tiff), g.pixel[ctrl], g.ground[ctrl], g.ids[ctrl], g.crs)
            rep["gcp_tiff"] = {"path": str(gcp_tiff), "order": int(model[-1]), "gcps": int(ctrl.sum())}
        prog(0.4, "vectors and exports written")
        if rectify:
            rep["rectified"] = _rectify(out.temp(rectify), info, g, fit.model, dem, height, resolution,
                                        resampling, prog.stage(0.4, 0.98, "rectifying"))
        if report:
            write_json(out.temp(report), rep)
        prog(1.0, "done")
        out.commit()
    return rep


def _write_gcp_tiff(src_path, dst_path, pixel, ground, ids, crs):
    """Copy ``src_path`` with GDAL GCPs (pixel/line in the corner convention, as GDAL's are)."""
    from rasterio.control import GroundControlPoint
    from rasterio.crs import CRS as RioCRS

    from ..io.raster import geotiff_profile, ropen
    gcps = [GroundControlPoint(row=float(p[1]), col=float(p[0]), x=float(q[0]), y=float(q[1]),
                               z=float(q[2]) if np.isfinite(q[2]) else 0.0, id=str(i))
            for p, q, i in zip(pixel, ground, ids)]
    with ropen(src_path) as src:
        prof = geotiff_profile(src.profile)
        for k in ("transform", "crs", "photometric", "jpeg_quality", "jpegtablesmode"):
            prof.pop(k, None)
        if src.count == 3 and src.dtypes[0] == "uint8":
            prof["photometric"] = "RGB"
        with ropen(dst_path, "w", **prof, gcps=gcps, crs=RioCRS.from_wkt(crs.to_wkt())) as dst:
            for _, win in src.block_windows(1):
                dst.write(src.read(window=win), window=win)


def _write_vectors(path, g, fit, on_ground, d_ground, exaggeration):
    import shapely
    d_px = fit.residual
    common = {"id": g.ids.astype(object), "role": fit.role.astype(object), "col": g.pixel[:, 0],
              "row": g.pixel[:, 1], "z": g.ground[:, 2], "dx_px": d_px[:, 0], "dy_px": d_px[:, 1],
              "residual_px": np.hypot(*d_px.T)}
    layers = {"gcps": {**common, "geometry": shapely.points(g.ground[:, :2])},
              "error_vectors": {**common, "dx": d_ground[:, 0], "dy": d_ground[:, 1],
                                "length": np.hypot(*d_ground.T), "exaggeration": np.full(len(g), float(exaggeration)),
                                "geometry": error_vectors(g.ground[:, :2], on_ground, exaggeration)}}
    write_layers(path, layers, g.crs.to_wkt())


def _plot(path, info, pixel, residual, role, size: int = 1000):
    """PNG of the residual vectors (scaled to be visible) over a grey thumbnail of the image."""
    bands, _, (fx, fy) = read_decimated(info, size * size, "image")
    img = bands[:3].mean(axis=0)
    lo, hi = np.percentile(img, [1, 99])
    grey = np.clip((img - lo) / max(hi - lo, 1e-9) * 200 + 30, 0, 255).astype(np.uint8)
    canvas = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    d = np.hypot(*residual.T)
    k = 0.05 * max(canvas.shape) / max(np.percentile(d, 90), 1e-9)  # the 90th percentile ~ 5 % of the image
    colours = {"control": (40, 160, 40), "check": (30, 30, 220), "blunder": (200, 0, 200)}
    for p, v, r in zip(pixel, residual, role):
        a = (p[0] / fx, p[1] / fy)
        b = (a[0] + k * v[0], a[1] + k * v[1])
        cv2.circle(canvas, (int(a[0]), int(a[1])), 3, colours.get(r, (0, 0, 0)), -1, cv2.LINE_AA)
        cv2.arrowedLine(canvas, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), colours.get(r, (0, 0, 0)), 2,
                        cv2.LINE_AA, tipLength=0.25)
    cv2.putText(canvas, f"vectors x{k * fx:.0f}  green control, red check, magenta blunder",
                (10, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 2, cv2.LINE_AA)
    if not cv2.imwrite(str(path) if str(path).endswith(".png") else str(path) + ".png", canvas):
        raise InputError(f"could not write the plot {path}")
    if not str(path).endswith(".png"):
        Path(str(path) + ".png").replace(path)


def _rectify(path, info, g, model, dem, height, resolution, resampling, prog):
    """Resample the image to a north-up grid in the GCP CRS through ``model`` (ground → image)."""
    hsrc = None
    if model.src_dims == 3:
        from pyproj import CRS

        from ..geometry.dem import Dem, as_height_source
        if dem is not None:
            d = dem if isinstance(dem, Dem) else Dem.open(dem)
            if CRS.from_user_input(d.crs) != g.crs:
                raise InputError(f"rectification with a DEM needs the DEM in the GCPs' CRS ({g.crs.to_string()})")
            hsrc = as_height_source(d)
        else:
            z0 = height if height is not None else float(np.nanmean(g.ground[:, 2]))
            hsrc = as_height_source(float(z0))
    t = np.linspace(0, 1, 33)
    w, h = info.width, info.height
    edge = np.concatenate([np.column_stack([t * w, 0 * t]), np.column_stack([w + 0 * t, t * h]),
                           np.column_stack([(1 - t) * w, h + 0 * t]), np.column_stack([0 * t, (1 - t) * h])])
    zmean = float(np.nanmean(g.ground[:, 2])) if model.src_dims == 3 else None
    if model.src_dims == 3:
        XY = model.inverse(edge, dem=hsrc) if dem is not None else model.inverse(edge, z=zmean if height is None else height)
    else:
        XY = model.inverse(edge)
    XY = XY[:, :2]
    if not np.isfinite(XY).all():
        raise ModelError("the model does not map the whole image footprint to the ground; rectify with another model")
    c = np.array([[w / 2, h / 2], [w / 2 + 1, h / 2], [w / 2, h / 2 + 1]])
    cg = model.inverse(c, z=zmean)[:, :2] if model.src_dims == 3 else model.inverse(c)
    u, v = cg[1] - cg[0], cg[2] - cg[0]
    res = float(resolution or np.sqrt(abs(u[0] * v[1] - u[1] * v[0])))
    transform, width, height_px = grid_covering(XY, res)
    if width * height_px > 4 * w * h * max(1.0, (np.sqrt(abs(u[0] * v[1] - u[1] * v[0])) / res) ** 2) + 1e6:
        raise ModelError(f"rectified grid would be {width}x{height_px} px: the model is unstable outside the GCPs")

    def inverse_map(XYm):
        if model.src_dims == 3:
            zz = hsrc.heights_and_gradient(XYm)[0]
            return model.forward(np.column_stack([XYm, zz]))
        return model.forward(XYm)

    warp_to_grid(info.path, path, inverse_map, crs=g.crs, transform=transform, width=width, height=height_px,
                 resampling=resampling, progress=prog)
    return {"width": width, "height": height_px, "resolution": res, "transform": list(transform)[:6]}
