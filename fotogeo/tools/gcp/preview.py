"""The GCP picker's live preview: the image warped onto the map canvas through the current fit.

:func:`preview_warp` is a session tool (``python -m fotogeo.worker --session``, JSON in and out,
like :func:`~fotogeo.tools.gcp.fit.fit_gcps`): the dock sends its GCPs and settings plus the
canvas's extent, CRS and size in pixels; the tool refits with orient's code
(:func:`~fotogeo.tools.gcp.fit.prepare`, :func:`~fotogeo.tools.gcp.fit.fit_prepared`) and
writes the warped image as raw RGBA bytes (row-major, 4 bytes per pixel, alpha 0 where the image
does not reach) to ``output``, which the dock draws over the canvas at the given extent.

The warp is an inverse mapping, as every rectification (:mod:`fotogeo.rectify`):

1. output pixel centre ``(i + ½, j + ½)`` → canvas map position (the extent, north up) → GCP
   CRS (pyproj, ``always_xy``) → height (3-D models: the DEM, else the constant, else the GCPs'
   mean height) → image pixel ``(col, row)`` = model(ground), corner convention;
2. step 1 is evaluated on a node grid every :data:`NODE_STEP` output pixels only and
   interpolated bilinearly in between (the models are smooth at that scale; a node the model
   has no answer for makes its cells transparent);
3. ``cv2.remap`` (bilinear) samples a decimated copy of the image (at most :data:`IMAGE_PIXELS`
   pixels, read once per file version and kept): ``u = col / f_x − ½`` (OpenCV's pixel-centre
   convention).

The output is at most :data:`MAX_SIDE` pixels on its long side (the dock stretches it over the
canvas): the cost does not grow with the image or the zoom.
"""
from __future__ import annotations

import os

import cv2
import numpy as np

from ...crs import parse_crs
from ...errors import InputError, ModelError, one_line
from ...geometry.georeference import Georeference
from ..common.boundary import tool
from .fit import cached_load, fit_prepared, grid_dem, prepare

MAX_SIDE = 1024  # output pixels on the long side
NODE_STEP = 16  # output pixels between the nodes where the model is evaluated
IMAGE_PIXELS = 1600 * 1600  # the decimated image the preview samples
OUTSIDE = -1.0e6  # pixel coordinate of a node without an answer: remap leaves its cells transparent
_TRANSFORMERS: dict = {}


def output_size(width: int, height: int, max_side: int = MAX_SIDE) -> tuple[int, int]:
    """``(w, h)`` of the preview for a canvas of ``width x height`` pixels: the canvas's shape, ≤ ``max_side``.

    >>> output_size(1600, 900), output_size(300, 200)
    ((1024, 576), (300, 200))
    """
    if width < 1 or height < 1:
        raise InputError(f"the canvas size must be positive; got {width} x {height} pixels")
    k = min(1.0, max_side / max(width, height))
    return max(1, round(width * k)), max(1, round(height * k))


def rgba_picture(path: str):
    """``(RGBA uint8 (h, w, 4), (f_x, f_y))``: the decimated image (full pixel = decimated × f), alpha from its mask;
    one band is shown grey, more bands as their first three; other types than 8 bits stretched 1–99 %."""
    from ...io.raster import open_raster, read_decimated

    def load(p):
        bands, mask, factor = read_decimated(open_raster(p, "image"), IMAGE_PIXELS, "image")
        rgb = bands[:3] if len(bands) >= 3 else np.repeat(bands[:1], 3, axis=0)
        if rgb.dtype != np.uint8:
            valid = rgb[:, mask] if mask.any() else rgb.reshape(3, -1)
            lo, hi = np.percentile(valid, [1, 99])
            rgb = np.clip((rgb.astype(np.float32) - lo) * (255.0 / max(float(hi - lo), 1e-9)), 0, 255)
        rgba = np.dstack([np.moveaxis(rgb.astype(np.uint8), 0, -1), np.where(mask, 255, 0).astype(np.uint8)])
        return np.ascontiguousarray(rgba), factor
    return cached_load("preview_image", path, load)


def _to_gcp_crs(extent_crs, map_crs, XY):
    """Canvas positions ``XY`` in ``extent_crs`` → the GCPs' CRS (one transformer per CRS pair, kept)."""
    if extent_crs == map_crs:
        return XY
    key = (extent_crs.to_wkt(), map_crs.to_wkt())
    if key not in _TRANSFORMERS:
        from pyproj import Transformer
        _TRANSFORMERS.clear()  # the canvas CRS rarely changes: keep the last pair only
        _TRANSFORMERS[key] = Transformer.from_crs(extent_crs, map_crs, always_xy=True)
    x, y = _TRANSFORMERS[key].transform(XY[:, 0], XY[:, 1])
    return np.column_stack([x, y])


def node_pixels(georef, extent, extent_crs, map_crs, size, step: int = NODE_STEP) -> np.ndarray:
    """Image ``(col, row)`` at the nodes ``(ny, nx, 2)``: output pixel centres ``(k·step + ½)`` of a ``size``
    ``(w, h)`` raster over ``extent`` ``(xmin, ymin, xmax, ymax)`` in ``extent_crs`` (north up); NaN where none."""
    w, h = size
    xmin, ymin, xmax, ymax = extent
    nx, ny = -(-(w - 1) // step) + 1, -(-(h - 1) // step) + 1
    jj, ii = np.arange(nx) * step + 0.5, np.arange(ny) * step + 0.5
    X, Y = np.meshgrid(xmin + jj * (xmax - xmin) / w, ymax - ii * (ymax - ymin) / h)
    XY = _to_gcp_crs(extent_crs, map_crs, np.column_stack([X.ravel(), Y.ravel()]))
    with np.errstate(all="ignore"):
        P = georef.map_to_pixel(XY)
    return P.reshape(ny, nx, 2)


def remap_tables(nodes: np.ndarray, factor, size, step: int = NODE_STEP):
    """OpenCV's ``(map_x, map_y)`` (float32, ``(h, w)``) into the decimated picture: the node pixels
    interpolated bilinearly to every output pixel (module docstring, step 2–3)."""
    w, h = size
    u = nodes[..., 0] / factor[0] - 0.5
    v = nodes[..., 1] / factor[1] - 0.5
    bad = ~(np.isfinite(u) & np.isfinite(v))
    u, v = np.where(bad, OUTSIDE, u).astype(np.float32), np.where(bad, OUTSIDE, v).astype(np.float32)
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float32) / step, np.arange(h, dtype=np.float32) / step)
    return (cv2.remap(u, gx, gy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE),
            cv2.remap(v, gx, gy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE))


def _heights(p, model_name, dem, default_height, map_crs):
    """The 3-D models' height source over the canvas: the DEM on a map grid, else a constant (module docstring)."""
    from ...models import get_model
    if get_model(model_name).src_dims != 3:
        return None
    used = p.ground[p.use, 2]
    fallback = float(default_height) if default_height is not None else (
        float(np.nanmean(used)) if np.isfinite(used).any() else 0.0)
    if not dem:
        return fallback
    grid = grid_dem(dem, map_crs)

    def heights(XY):
        z = grid.heights(XY)
        return np.where(np.isfinite(z), z, fallback)
    return heights


@tool(outputs=("output",))
def preview_warp(gcps, model, *, crs, image, extent, extent_crs, size, output, width=None, height=None, dem=None,
                 camera=None, default_height=None, progress=None) -> dict:
    """Refit ``model`` to the picker's GCPs and write the image warped over the canvas ``extent`` (module docstring).

    ``{"ok", "message", "model", "width", "height", "extent", "output", "covered"}`` (``covered``: the share of
    output pixels the image reaches); ``ok`` False (nothing written) while the model lacks points or cannot be fitted.
    """
    p = prepare(gcps, model, crs=crs, image=image, width=width, height=height, dem=dem, camera=camera,
                default_height=default_height)
    if p.needed:
        return {"ok": False, "message": p.message}
    try:
        name, fit, _ = fit_prepared(p, model)
    except (ModelError, np.linalg.LinAlgError) as e:
        return {"ok": False, "message": one_line(e)}
    try:
        xmin, ymin, xmax, ymax = (float(v) for v in extent)
    except (TypeError, ValueError):
        raise InputError("extent must be [xmin, ymin, xmax, ymax]") from None
    if not (xmax > xmin and ymax > ymin):
        raise InputError(f"the canvas extent is empty: {extent}")
    w, h = output_size(int(size[0]), int(size[1]))
    picture, factor = rgba_picture(image)
    georef = Georeference(fit.model, heights=_heights(p, name, dem, default_height, p.map_crs), crs=p.map_crs)
    nodes = node_pixels(georef, (xmin, ymin, xmax, ymax), parse_crs(extent_crs, "the canvas CRS"), p.map_crs, (w, h))
    map_x, map_y = remap_tables(nodes, factor, (w, h))
    warped = cv2.remap(picture, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                       borderValue=(0, 0, 0, 0))
    temp = f"{output}.part"
    warped.tofile(temp)
    os.replace(temp, output)
    return {"ok": True, "message": f"{name} preview", "model": name, "width": w, "height": h,
            "extent": [xmin, ymin, xmax, ymax], "output": str(output), "covered": float((warped[..., 3] > 0).mean())}
