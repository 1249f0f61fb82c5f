"""The RPC bias tool: an image with a vendor RPC + GCPs (paths) → a copy carrying the corrected RPC.

``rpc_bias(image, gcps, output)`` reads the RPC00B of ``image`` (GDAL's RPC metadata, else an RPC file beside
it: :func:`fotogeo.io.rpc_image.image_rpc`, which also moves a product's RPC into a crop's pixels), the
GCPs (:func:`fotogeo.io.gcps.read_gcps`: ground X, Y, h in any CRS + their pixels), fits the
image-space correction of Grodecki & Dial (2003) on the control points
(:func:`fotogeo.orientation.bias.estimate_bias`: a shift, or an affinity), builds it into the
RPC (:func:`fotogeo.orientation.bias.corrected_rpc`) and writes:

* ``output`` — a GeoTIFF copy of ``image`` whose GDAL RPC metadata is the corrected RPC, so
  ``gdalwarp -rpc -to RPC_DEM=dem.tif`` and QGIS orthorectify it onto the GCPs;
* ``report`` (JSON, default ``output`` with ``.json``) — the correction, the residuals before
  and after at control and check points, leave-one-out residuals, the GCPs skipped and why.

Heights are taken as given: RPC00B heights are ellipsoidal (WGS 84), so give ellipsoidal GCP
heights (or a DEM in the same vertical datum as the one ``gdalwarp`` will use). GCPs whose
pixel lies outside the image are skipped with a warning naming each (a vendor scene is often cropped), and
listed in the report's ``skipped`` (:func:`fotogeo.io.gcps.inside_image`, the policy ``orient`` shares); too few
left for the correction is an error. GCP pixels read on a copy of another size or turned are refused naming it,
for the shift and the affinity alike (:func:`fotogeo.tools.common.checks.copy_check` with the shift's fit).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...crs import to_lonlat
from ...errors import InputError
from ...io.gcps import read_gcps
from ...io.output_checks import check_outputs
from ...io.raster import AtomicOutputs, open_raster
from ...io.report import write_json
from ...io.rpc import write_rpc_geotiff
from ...io.rpc_image import image_rpc
from ...models.stats import residual_stats
from ...orientation.bias import MIN_GCPS, corrected_rpc, estimate_bias
from ...orientation.copy_reading import CLICK_SIGMA_PX
from ...pixels import from_centre
from ...progress import as_progress
from ..common.boundary import tool
from ..common.checks import check_gcp_crs, inside_fitted


@tool("RPC_BIAS", rasters={"image": None, "dem": None})
def rpc_bias(image, gcps, output, *, report=None, method: str = "shift", layer=None, crs=None, dem=None,
             height=None, fields=None, overwrite: bool = False, progress=None) -> dict:
    """Correct the vendor RPC of ``image`` with ``gcps``; write ``output`` and the report (module doc).

    Returns the report dict (``correction``, ``control``/``check`` statistics before and after
    in pixels, ``skipped`` GCPs ``{id, col, row, reason}``, ``heights`` sources, ``refit_max_px``).
    """
    prog = as_progress(progress)
    if method not in ("shift", "affine"):
        raise InputError(f"method {method!r} unknown; choose 'shift' or 'affine'")
    output = Path(output)
    report = Path(report) if report else output.with_suffix(".json")
    check_outputs(((output, "output raster", None), (report, "report", None)), [image, gcps, dem], overwrite)
    info = open_raster(image, "image")
    rpc = image_rpc(image).rpc
    g = read_gcps(gcps, layer=layer, crs=crs, dem=dem, height=height, **(fields or {}))
    check_gcp_crs(g, gcps)
    if not g.has_heights:
        raise InputError(f"GCP file {str(gcps)!r}: every GCP needs a height for an RPC (a z field, a DEM or a "
                         f"constant height)")
    needed = (f"{gcps}", MIN_GCPS[method], f"the {method} correction")
    g, skipped = inside_fitted(g, info.width, info.height, *needed, (_shift_rms(rpc, g.crs), 1, CLICK_SIGMA_PX))
    lonlat = to_lonlat(g.crs, g.ground[:, :2])
    ground = np.column_stack([lonlat, g.ground[:, 2]])
    control, check = g.role == "control", g.role == "check"
    prog(0.2, "GCPs read")
    bias = estimate_bias(rpc, ground[control], g.pixel[control], method)
    new, refit_max = corrected_rpc(rpc, bias)
    prog(0.5, "correction fitted")
    rep = {"fotogeo": "rpc-bias", "image": str(image), "gcps": str(gcps), "output": str(output),
           "report": str(report), "method": method, "correction": bias.summary(), "refit_max_px": refit_max,
           "skipped": skipped, "heights": g.heights,
           "units": "pixels (corner convention); residual = measured − projected",
           "rpc": new.to_gdal_metadata()}
    for role, sel in (("control", control), ("check", check)):
        before = g.pixel[sel] - from_centre(rpc.project(*ground[sel].T))
        after = g.pixel[sel] - from_centre(new.project(*ground[sel].T))
        rep[role] = {"ids": [str(i) for i in g.ids[sel]], "before": residual_stats(before),
                     "after": residual_stats(after)}
    with AtomicOutputs(overwrite) as out:
        write_rpc_geotiff(image, out.temp(output), new)
        prog(0.9, "corrected copy written")
        write_json(out.temp(report), rep)
        out.commit()
    prog(1.0, "done")
    return rep


def _shift_rms(rpc, crs):
    """``rms(ground, pixel)``: the RMS (px) of the residuals of the GCPs (``ground`` in ``crs``, ellipsoidal
    heights) after the shift correction of ``rpc`` fitted to all of them; a copy of another size or a turned one
    cannot be shifted onto the vendor RPC (:mod:`fotogeo.orientation.copy_reading`). The one check of both methods:
    an affinity would absorb a copy's scale or turn (a0 + a1·col + a2·row), which a vendor RPC's bias, a few pixels
    and parts per ten thousand (Grodecki & Dial 2003), never is."""
    def rms(ground, pixel) -> float:
        lonlat = to_lonlat(crs, ground[:, :2])
        d = pixel - from_centre(rpc.project(lonlat[:, 0], lonlat[:, 1], ground[:, 2]))
        d = d - d.mean(axis=0)
        return float(np.sqrt(np.mean(np.sum(d ** 2, axis=1))))
    return rms
