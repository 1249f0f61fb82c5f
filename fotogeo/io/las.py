"""LAS 1.4 point clouds (ASPRS LAS 1.4 R15), written with laspy.

:class:`LasWriter` streams chunks of points ``(X, Y, Z)`` with their RGB into one file: point data record
format 7 (coordinates, intensity, returns, classification, GPS time, RGB; LAS 1.4's format with colour), the
CRS as an OGC WKT VLR (global encoding's WKT bit set, as LAS 1.4 requires for formats 6–10), every point
classified 0 "created, never classified". Coordinates are stored as integers with ``scale`` (0.001 map units)
and offsets at the first chunk's minimum. RGB is 16 bits per channel (8-bit grey values are multiplied by 257).
A ``.laz`` name asks for LAZ compression (laspy's ``lazrs`` or ``laszip`` backend).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError

POINT_FORMAT = 7
NEVER_CLASSIFIED = 0


def _laspy():
    try:
        import laspy
    except ImportError:
        raise InputError("writing a point cloud needs the Python package laspy (pip install laspy)") from None
    return laspy


def check_writable(path) -> None:
    """Refuse, before any work, a point cloud this environment cannot write (laspy missing; ``.laz`` without a
    LAZ backend)."""
    laspy = _laspy()
    if Path(path).suffix.lower() == ".laz" and not laspy.LazBackend.detect_available():
        raise InputError(f"cannot write the compressed point cloud {str(path)!r}: no LAZ backend is installed; "
                         f"write .las instead, or install lazrs (pip install lazrs)")


class LasWriter:
    """``with LasWriter(path, crs, compress=None) as w: w.write(xyz, rgb)`` (module docstring); ``path`` may be a
    temporary name (``compress``: True/False, or None for the path's suffix)."""

    def __init__(self, path, crs, *, compress: bool | None = None, scale: float = 0.001):
        self.path, self.crs, self.scale = Path(path), crs, scale
        self.compress = self.path.suffix.lower() == ".laz" if compress is None else compress
        self._writer, self.count = None, 0

    def __enter__(self):
        return self

    def _open(self, offset):
        laspy = _laspy()
        header = laspy.LasHeader(point_format=POINT_FORMAT, version="1.4")
        header.scales = np.full(3, self.scale)
        header.offsets = np.floor(np.asarray(offset, float))
        if self.crs is not None:
            header.add_crs(self.crs)
        try:
            self._writer = laspy.open(str(self.path), mode="w", header=header, do_compress=self.compress)
        except laspy.errors.LaspyException as exc:
            raise InputError(f"cannot write the point cloud {str(self.path)!r} ({exc}); write .las instead of .laz "
                             f"or install lazrs (pip install lazrs)") from None

    def write(self, xyz, rgb=None) -> None:
        """Append points ``(N, 3)`` and their colours ``(N, 3)`` (uint8 or uint16; None: black)."""
        xyz = np.asarray(xyz, float)
        if not len(xyz):
            return
        if self._writer is None:
            self._open(xyz.min(axis=0))
        laspy = _laspy()
        rec = laspy.ScaleAwarePointRecord.zeros(len(xyz), header=self._writer.header)
        rec.x, rec.y, rec.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
        if rgb is not None:
            c = np.asarray(rgb)
            c16 = c.astype(np.uint16) * 257 if c.dtype == np.uint8 else c.astype(np.uint16)
            rec.red, rec.green, rec.blue = c16[:, 0], c16[:, 1], c16[:, 2]
        rec.classification = np.full(len(xyz), NEVER_CLASSIFIED, np.uint8)
        self._writer.write_points(rec)
        self.count += len(xyz)

    def close(self) -> None:
        if self._writer is None:  # no point at all: still a valid, empty file
            self._open((0.0, 0.0, 0.0))
        self._writer.close()

    def __exit__(self, *exc):
        self.close()
        return False
