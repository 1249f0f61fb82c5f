"""Checks of an output before any work: its name and folder (:func:`check_output`), several outputs at once
(:func:`check_outputs`), the size of an output grid (:func:`check_grid`) and the free space for it
(:func:`check_space`).

An output is refused when it equals an input, exists without ``overwrite``, is a folder, lies in a missing or
unwritable folder (a temporary file is created there and removed: permission bits do not tell about ACLs,
read-only mounts or quotas), or has a name that promises another format than the one written. A grid is refused
above :data:`MAX_GRID_PIXELS` pixels or :data:`MAX_GRID_UPSAMPLING` times its source's; the free space when it is
below the uncompressed size divided by the best ratio of its compression
(:data:`fotogeo.io.compression.BEST_RATIO`: 1 for an uncompressed output, ``compress`` ``"none"``).
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..errors import OutputError
from .compression import best_ratio


#: largest output grid fotogeo writes (pixels per band): 2^32, a 65536² raster
MAX_GRID_PIXELS = 2 ** 32
#: an output grid may have at most this many times the pixels of its source image (10x finer
#: than the source's own sampling, linearly); finer grids only interpolate
MAX_GRID_UPSAMPLING = 100


#: what fotogeo writes under a suffix (the formats are chosen by the tools, not by the name)
WRITTEN_AS = {".tif": "GeoTIFF", ".tiff": "GeoTIFF", ".gpkg": "GeoPackage", ".csv": "CSV", ".las": "LAS", ".laz": "LAZ"}
#: the names of a GeoTIFF output (``check_output``'s ``suffixes``)
GEOTIFF_SUFFIXES = (".tif", ".tiff")


def check_output(path, inputs, overwrite: bool, role: str = "output", suffixes: tuple | None = None) -> Path:
    """Refuse an output that equals an input, exists without ``overwrite``, is a folder, whose
    folder is missing or not writable (a temporary file is actually created there and removed), or,
    with ``suffixes``, whose name ends otherwise (a GeoTIFF named ``.jpg`` or a GeoPackage named
    ``.shp`` would be read wrongly by what the name promises)."""
    if suffixes and Path(path).suffix.lower() not in suffixes:
        kinds = " or ".join(dict.fromkeys(WRITTEN_AS.get(x, x) for x in suffixes))
        raise OutputError(f"{role} {str(path)!r}: fotogeo writes it as {kinds}; give a file name ending in "
                          f"{' or '.join(suffixes)}")
    p = Path(path).resolve()
    for i in inputs:
        if i is not None and Path(i).resolve() == p:
            raise OutputError(f"{role} {str(path)!r} is also an input; choose another output path")
    if p.is_dir():
        raise OutputError(f"{role} {str(path)!r} is a folder; give a file name")
    if p.exists() and not overwrite:
        raise OutputError(f"{role} {str(path)!r} exists; pass overwrite=True to replace it", option="overwrite")
    if not p.parent.is_dir():
        raise OutputError(f"folder of {role} {str(path)!r} does not exist; create it first")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=".probe", dir=p.parent)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise OutputError(f"cannot write {role} {str(path)!r}: the folder {str(p.parent)!r} is not writable "
                          f"({e.strerror or e}); choose another folder") from None
    return p


def check_outputs(outputs, inputs, overwrite: bool) -> None:
    """:func:`check_output` on every ``(path, role, suffixes)`` of ``outputs`` (None: not written); two of them at
    one path refused before any work (the second would be found at the end, or overwrite the first)."""
    seen: dict = {}
    for p, role, suffixes in (o for o in outputs if o[0] is not None):
        key = check_output(p, inputs, overwrite, role, suffixes)
        if key in seen:
            raise OutputError(f"{role} {str(p)!r} is also the {seen[key]}; give each output its own file name")
        seen[key] = role


def check_grid(width: int, height: int, *, source_pixels: int, what: str, resolution: float | None = None):
    """Refuse an output grid larger than :data:`MAX_GRID_PIXELS` or than
    :data:`MAX_GRID_UPSAMPLING` times the ``source_pixels`` it is resampled from.

    The limits are absolute and relative to the source, never scaled by the resolution, so a
    resolution far too fine is refused before any pixel is written; the message gives the
    finest resolution that passes (the grid's pixel count falls with the resolution squared).
    """
    n = int(width) * int(height)
    limit = min(MAX_GRID_PIXELS, MAX_GRID_UPSAMPLING * int(source_pixels))
    if n <= limit:
        return
    hint = ""
    if resolution:
        finest = float(resolution) * float(np.sqrt(n / limit))
        hint = f"; use a resolution of {finest:.4g} or coarser (now {float(resolution):.4g})"
    raise OutputError(f"{what} would be {width}x{height} = {n:.3g} pixels, more than "
                      f"{'the limit of ' + format(MAX_GRID_PIXELS, '.3g') if limit == MAX_GRID_PIXELS else f'{MAX_GRID_UPSAMPLING}x the source image ({int(source_pixels):.3g} pixels)'}"
                      f"{hint}")


def check_space(folder, nbytes: float, what: str, compress: str = "deflate"):
    """Refuse when the free space of ``folder`` is clearly too little for ``nbytes`` uncompressed
    output written with ``compress``: less than ``nbytes`` / its best ratio
    (:func:`~fotogeo.io.compression.best_ratio`; with ``"none"`` ``nbytes`` itself) plus 1 MB for the headers and
    side files, a margin that does not refuse a small output on a small disk."""
    need = float(nbytes) / best_ratio(compress) + 2 ** 20
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    if free < need:
        raise OutputError(f"not enough free space for {what} in {str(folder)!r}: {free / 2 ** 20:.0f} MB free, "
                          f"about {need / 2 ** 20:.0f} MB needed (uncompressed {nbytes / 2 ** 20:.0f} MB); "
                          f"free some space, choose another folder or a coarser resolution")


def grid_bytes(width: int, height: int, bands: int, dtype) -> float:
    """Uncompressed size of a ``bands``-band grid of ``dtype`` (overviews add a third)."""
    return float(width) * float(height) * bands * np.dtype(dtype).itemsize * 4 / 3
