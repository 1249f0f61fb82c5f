"""The standard frame of a scan (``interior --resample``): the photo on square pixels centred on the
principal point (:func:`fotogeo.orientation.interior.standard_frame_maps`) and the pinhole camera YAML that
describes it, so that ``orient`` and ``triangulate`` take the scan like a digital frame."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...orientation.interior import standard_frame_maps


def frame_extent(report) -> tuple[float, float]:
    """The standard frame in mm: the report's ``frame_mm``, else twice the largest distance of a
    fiducial from the principal point along x and along y."""
    if report.frame_mm:
        return report.frame_mm
    mm = np.array(list(report.fiducials_mm.values()), float) - report.principal_point_mm
    return float(2 * np.abs(mm[:, 0]).max()), float(2 * np.abs(mm[:, 1]).max())


def camera_yaml(name: str, focal_mm: float, size, pixel_mm: float) -> str:
    """An orthority-style pinhole camera of the standard frame (principal point at the centre)."""
    cols, rows = size
    return (f"{name or 'scanned_frame'}:\n    type: pinhole\n    im_size: [{cols}, {rows}]\n    focal_len: {focal_mm}\n"
            f"    sensor_size: [{cols * pixel_mm:.6f}, {rows * pixel_mm:.6f}]\n    cx: 0.0\n    cy: 0.0\n")


def write_standard_frame(out, target: Path, scan, io, report, pixel_um=None) -> dict:
    """Resample ``scan`` (all bands, bilinear) to the standard frame beside ``target`` (the JSON) as
    ``<stem>_frame.tif`` with ``<stem>_camera.yaml``; temporary files through ``out`` (AtomicOutputs)."""
    import cv2
    import rasterio
    q = (pixel_um / 1000.0) if pixel_um else io.pixel_size_mm
    extent = frame_extent(report)
    mx, my, (cols, rows) = standard_frame_maps(io, extent, report.principal_point_mm, q)
    image = target.with_name(f"{target.stem}_frame.tif")
    camera = target.with_name(f"{target.stem}_camera.yaml")
    with rasterio.open(scan) as src:
        data = src.read()
        dtype = data.dtype
    bands = [cv2.remap(b.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
             for b in data]
    arr = np.stack(bands)
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        arr = np.clip(np.round(arr), info.min, info.max)
    with rasterio.open(out.temp(image), "w", driver="GTiff", width=cols, height=rows, count=len(bands), dtype=dtype,
                       compress="deflate", tiled=True) as dst:
        dst.write(arr.astype(dtype))
    Path(out.temp(camera)).write_text(camera_yaml(report.name, report.focal_mm, (cols, rows), q))
    return {"image": str(image), "camera": str(camera), "pixel_um": round(q * 1000, 6), "size": [cols, rows],
            "frame_mm": [round(extent[0], 6), round(extent[1], 6)]}
