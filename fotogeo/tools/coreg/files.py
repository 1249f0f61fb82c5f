"""The files of ``fotogeo.tools.coreg.tool``: strips of both images on the target's grid, and the outputs.

:class:`RasterStrips` is the strip source of :mod:`fotogeo.coreg.pipeline` over two files:
the target's band as it is, the reference's band on the target's grid — read directly when
both grids are one (same CRS, pixel size and an integer offset), else through a GDAL
``WarpedVRT`` (average when the reference's pixels are finer than 2/3 of the target's, cubic
otherwise) — window by window, so memory is bounded by a strip. The target deformed by a
field (later passes) is read over the block its displaced pixels fall in and resampled by
:func:`fotogeo.coreg.pipeline.deform`.

Outputs: :func:`write_corrected` (every band of the target resampled through the field,
block by block, in the target's grid), :func:`write_field` (the displacement on the field's
coarse grid, 2 bands, target pixels) and :func:`write_shifts` (the windows as points).
"""
from __future__ import annotations

import contextlib
import threading

import cv2
import numpy as np
from affine import Affine
from rasterio.enums import Resampling
from rasterio.vrt import WarpedVRT
from rasterio.windows import Window

from ...coreg.pipeline import deform, source_box, source_maps
from ...errors import InputError
from ...io.raster import geotiff_profile, ropen
from ...pixels import pixel_to_map

#: cv2 interpolation of each resampling name
INTERPOLATIONS = {"nearest": cv2.INTER_NEAREST, "bilinear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC}
#: rows of the corrected output per block
BLOCK_ROWS = 512


def check_band(ds, band: int, role: str) -> int:
    """``band`` (1-based) of ``ds`` or an :class:`InputError` naming the band count."""
    if not 1 <= int(band) <= ds.count:
        raise InputError(f"{role}_band {band} is out of range: {ds.files[0] if ds.files else role!r} has "
                         f"{ds.count} band{'s' if ds.count > 1 else ''} (1..{ds.count})")
    return int(band)


def _aligned(ref, tgt) -> tuple[int, int] | None:
    """``(col, row)`` offset of the target's origin in the reference's pixels when both grids are one."""
    if ref.crs != tgt.crs:
        return None
    a, b = ref.transform, tgt.transform
    if not np.allclose([a.a, a.b, a.d, a.e], [b.a, b.b, b.d, b.e], rtol=1e-9, atol=0):
        return None
    off = (~a) * (b.c, b.f)
    r = np.round(off)
    return (int(r[0]), int(r[1])) if np.allclose(off, r, atol=1e-6) else None


def read_block(ds, band: int, nodata, row0: int, row1: int, col0: int, col1: int, dr: int = 0, dc: int = 0):
    """float32 block ``[row0:row1, col0:col1]`` of ``ds`` shifted by ``(dr, dc)`` pixels, NaN
    outside the raster, at nodata and where the mask says invalid."""
    out = np.full((row1 - row0, col1 - col0), np.nan, np.float32)
    r0, c0 = max(row0 + dr, 0), max(col0 + dc, 0)
    r1, c1 = min(row1 + dr, ds.height), min(col1 + dc, ds.width)
    if r1 <= r0 or c1 <= c0:
        return out
    win = Window(c0, r0, c1 - c0, r1 - r0)
    data = ds.read(band, window=win).astype(np.float32)
    bad = ds.read_masks(band, window=win) == 0
    if nodata is not None:
        bad |= data == np.float32(nodata)
    data[bad] = np.nan
    out[r0 - dr - row0:r1 - dr - row0, c0 - dc - col0:c1 - dc - col0] = data
    return out


class RasterStrips:
    """The strip source over a reference and a target file (see the module docstring); a
    context manager that keeps both open."""

    def __init__(self, reference, target, *, reference_band: int = 1, target_band: int = 1,
                 reference_nodata=None, target_nodata=None):
        self._stack = contextlib.ExitStack()
        self._lock = threading.Lock()
        self.ref = self._stack.enter_context(ropen(reference))
        self.tgt = self._stack.enter_context(ropen(target))
        self.ref_band = check_band(self.ref, reference_band, "reference")
        self.tgt_band = check_band(self.tgt, target_band, "target")
        self.ref_nodata = self.ref.nodata if reference_nodata is None else reference_nodata
        self.tgt_nodata = self.tgt.nodata if target_nodata is None else target_nodata
        self.offset = _aligned(self.ref, self.tgt)
        self.resampling = None
        if self.offset is None:
            ratio = np.sqrt(abs(self.ref.transform.determinant)) / np.sqrt(abs(self.tgt.transform.determinant))
            self.resampling = Resampling.average if ratio < 2 / 3 else Resampling.cubic
            self.vrt = self._stack.enter_context(WarpedVRT(
                self.ref, crs=self.tgt.crs, transform=self.tgt.transform, width=self.tgt.width,
                height=self.tgt.height, resampling=self.resampling, src_nodata=self.ref_nodata, nodata=np.nan,
                dtype="float32"))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._stack.close()
        return False

    @property
    def shape(self):
        return self.tgt.height, self.tgt.width

    def reference(self, row0, row1, col0, col1):
        if self.offset is not None:
            dc, dr = self.offset
            return read_block(self.ref, self.ref_band, self.ref_nodata, row0, row1, col0, col1, dr, dc)
        return read_block(self.vrt, self.ref_band, None, row0, row1, col0, col1)

    def target(self, row0, row1, col0, col1):
        return read_block(self.tgt, self.tgt_band, self.tgt_nodata, row0, row1, col0, col1)

    def __call__(self, row0, row1, col0, col1, field=None):
        """Thread-safe: the reads hold a lock (one GDAL handle per file), the resampling does not."""
        if field is None:
            with self._lock:
                return self.reference(row0, row1, col0, col1), self.target(row0, row1, col0, col1)
        dx, dy = field.block(row0, col0, row1 - row0, col1 - col0)
        br0, br1, bc0, bc1 = source_box(dx, dy, row0, col0)
        with self._lock:
            ref, block = self.reference(row0, row1, col0, col1), self.target(br0, br1, bc0, bc1)
        return ref, deform(block, br0, bc0, field, row0, row1, col0, col1, dxdy=(dx, dy))


def _to_dtype(values: np.ndarray, dtype, nodata):
    bad = ~np.isfinite(values)
    kind = np.dtype(dtype).kind
    if kind in "iu":
        info = np.iinfo(dtype)
        values = np.clip(np.round(np.where(bad, 0, values)), info.min, info.max)
    out = values.astype(dtype)
    if nodata is not None and not (isinstance(nodata, float) and np.isnan(nodata) and kind != "f"):
        out[bad] = nodata
    return out


def write_corrected(strips: RasterStrips, field, path, *, resampling: str = "cubic", nodata=None, progress=None):
    """Every band of the target resampled through ``field`` into ``path`` (the target's grid)."""
    src = strips.tgt
    H, W = src.height, src.width
    dtype = src.dtypes[0]
    prof = geotiff_profile(width=W, height=H, count=src.count, dtype=dtype, crs=src.crs, transform=src.transform,
                           nodata=nodata, predictor=True)
    interp = INTERPOLATIONS[resampling]
    with ropen(path, "w", **prof) as dst:
        for r0 in range(0, H, BLOCK_ROWS):
            h = min(BLOCK_ROWS, H - r0)
            dx, dy = field.block(r0, 0, h, W)
            br0, br1, bc0, bc1 = source_box(dx, dy, r0, 0)
            mx, my = source_maps(dx, dy, r0 - br0, -bc0)
            for b in range(1, src.count + 1):
                block = read_block(src, b, strips.tgt_nodata, br0, br1, bc0, bc1)
                out = cv2.remap(block, mx, my, interp, borderMode=cv2.BORDER_CONSTANT,
                                borderValue=np.nan)
                dst.write(_to_dtype(out, dtype, nodata), b, window=Window(0, r0, W, h))
            if progress is not None:
                progress(min(1.0, (r0 + h) / H), "writing the corrected target")
        for b in range(1, src.count + 1):
            dst.set_band_description(b, src.descriptions[b - 1] or "")


def write_field(path, field, crs, transform) -> None:
    """The displacement ``D`` (target px) on the field's coarse grid: band 1 dx, band 2 dy."""
    D = field.inside().astype(np.float32)
    prof = geotiff_profile(width=D.shape[2], height=D.shape[1], count=2, dtype="float32", crs=crs,
                           transform=transform * Affine.scale(field.step), nodata=None)
    with ropen(path, "w", **prof) as dst:
        dst.write(D)
        dst.set_band_description(1, "dx: target column displacement (target px)")
        dst.set_band_description(2, "dy: target row displacement (target px)")
        dst.update_tags(fotogeo_field=f"corrected(p) = target(p + D(p)); node spacing {field.step} target px")


def write_shifts(path, windows, status, residual, crs, transform, *, layer: str = "windows",
                 append: bool = False) -> None:
    """The windows as points at their centres (map coordinates): shifts, reliability, status; the
    layer ``layer`` of the GeoPackage ``path`` (added to an existing one with ``append``)."""
    import shapely
    from ...io.vector import write_layers
    XY = pixel_to_map(transform, windows.xy)
    t, (dx, dy) = transform, windows.shift.T
    cols = {"col": windows.xy[:, 0], "row": windows.xy[:, 1], "dx": dx, "dy": dy,
            "dx_map": t.a * dx + t.b * dy, "dy_map": t.d * dx + t.e * dy,
            "reliability": windows.reliability, "status": np.asarray(status).astype(str),
            "peak_ratio": np.where(np.isfinite(windows.ratio), windows.ratio, np.nan),
            "ncc_before": windows.ncc_before, "ncc_after": windows.ncc_after,
            "sigma_x": windows.sigma[:, 0], "sigma_y": windows.sigma[:, 1],
            "residual_dx": residual[:, 0], "residual_dy": residual[:, 1],
            "coverage": windows.coverage, "geometry": shapely.points(XY)}
    write_layers(path, {layer: cols}, crs.to_wkt() if crs is not None else None,
                 {layer: "Co-registration windows: shift (dx, dy) in target pixels, target = reference + shift; "
                             "residual = shift - field."}, append=append)
