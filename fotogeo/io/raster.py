"""Raster input checks and reads, and atomic outputs (temporary file renamed when complete).

The checks of an output before any work (its name, folder, free space, grid size) are in
:mod:`fotogeo.io.output_checks`; the names they had here (``check_output`` is documented public API) are kept."""
from __future__ import annotations

import contextlib
import functools
import os
import re
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio
from rasterio._err import CPLE_BaseError  # GDAL's errors (rasterio.errors does not name them)
from rasterio.enums import ColorInterp, Resampling
from rasterio.errors import NotGeoreferencedWarning, RasterioIOError
from rasterio.windows import Window

from ..errors import InputError, OutputError, RasterError, one_line
from ..geometry.dem import Dem
from .compression import gtiff_options
from .output_checks import (GEOTIFF_SUFFIXES, check_grid, check_output, check_outputs,  # noqa: F401 (kept names)
                            check_space, grid_bytes)


@contextlib.contextmanager
def ropen(path, mode: str = "r", **kwargs):
    """``rasterio.open`` without the NotGeoreferencedWarning: raw frames have no georeference
    by nature, and fotogeo checks georeferences itself where one is needed."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(path, mode, **kwargs) as ds:
            yield ds


@dataclass(frozen=True)
class RasterInfo:
    path: Path | str  # text for a GDAL virtual path or URL (is_virtual_path)
    width: int
    height: int
    count: int
    dtype: str
    #: the CRS as the raster states it: rasterio's (GDAL's parse, no pyproj import), or None; :attr:`crs` is pyproj's
    raster_crs: object
    transform: object  # affine.Affine
    nodata: float | None
    #: the 0-based indices of the bands holding data: all but those GDAL's colour interpretation calls alpha (a mask,
    #: as :func:`read_decimated` takes it); every band when GDAL cannot read the interpretation (:func:`open_raster`)
    data_bands: tuple = ()

    @functools.cached_property
    def crs(self):
        """The raster's CRS as a pyproj CRS (parsed from :attr:`raster_crs`'s WKT when first asked), or None."""
        if self.raster_crs is None:
            return None
        from pyproj import CRS
        return CRS.from_wkt(self.raster_crs.to_wkt())

    @property
    def georeferenced(self) -> bool:
        return self.raster_crs is not None and not self.transform.is_identity


#: GDAL virtual file systems (``/vsizip/``, ``/vsicurl/``, ``/vsis3/``, ...) and URL schemes rasterio opens
_URL = re.compile(r"^(?:[a-z][a-z0-9+.-]*)://", re.IGNORECASE)


def is_virtual_path(path) -> bool:
    """True for a GDAL virtual path (``/vsizip//data/a.zip/b.tif``, ``/vsicurl/https://...``) or a URL
    (``https://...``, ``s3://...``, ``zip+file://...``): GDAL reads it, the local file system does not know it,
    so it is kept as text (``Path`` would fold ``//``) and not checked for existence."""
    text = str(path)
    return text.startswith("/vsi") or bool(_URL.match(text))


def raster_path(path):
    """``path`` as fotogeo keeps a raster input: text for a virtual path or URL, else a ``Path``."""
    return str(path) if is_virtual_path(path) else Path(path)


def open_raster(path, role: str = "raster") -> RasterInfo:
    """Open ``path`` and describe it; a clear :class:`RasterError` if it cannot be read.

    ``path`` may be a GDAL virtual path or a URL (:func:`is_virtual_path`), read through GDAL as rasterio
    reads it (``rio info /vsizip/...``); its :attr:`RasterInfo.path` then stays text."""
    p = raster_path(path)
    if not isinstance(p, str) and not p.exists():
        raise RasterError(f"{role} {str(p)!r} does not exist")
    try:
        with ropen(p) as ds:
            info = RasterInfo(p, ds.width, ds.height, ds.count, ds.dtypes[0], ds.crs or None, ds.transform,
                              ds.nodata, _data_bands(ds))
    except RasterioIOError as e:
        if isinstance(p, str):
            raise RasterError(one_line(f"{role} {p!r} cannot be read through GDAL ({e}); check the virtual path "
                                       f"(e.g. /vsizip//folder/archive.zip/image.tif) or the URL")) from None
        raise RasterError(f"{role} {str(p)!r} cannot be read as a raster ({e}); is it a GeoTIFF "
                          f"or another GDAL-readable image, and not truncated?") from None
    if info.width < 16 or info.height < 16:
        raise InputError(f"{role} {str(p)!r} is only {info.width}x{info.height} pixels; at least 16x16 is needed")
    return info


def _data_bands(ds) -> tuple:
    """:attr:`RasterInfo.data_bands` of the open raster ``ds``. GDAL may fail to read the colour interpretation
    (a JPEG whose XMP packet is cut raises CPLE_AppDefined when asked): then every band is data."""
    try:
        keep = tuple(i for i, c in enumerate(ds.colorinterp) if c != ColorInterp.alpha)
    except CPLE_BaseError:
        keep = ()
    return keep or tuple(range(ds.count))


#: GDAL block cache for fotogeo's reads and writes (bytes). GDAL's default, 5 % of RAM, let
#: one decimated read of a 20000² target reach 1.4 GB of resident memory.
GDAL_CACHE_BYTES = 256 * 2 ** 20


def gdal_env():
    """The GDAL configuration fotogeo reads and writes rasters under (bounded block cache)."""
    return rasterio.Env(GDAL_CACHEMAX=GDAL_CACHE_BYTES)


def read_decimated(info: RasterInfo, max_pixels: int, role: str = "raster", strip_rows: int = 256):
    """All bands and the validity mask, decimated (average) so that rows*cols ≤ ``max_pixels``.

    Returns ``(bands (B, r, c), mask (r, c) bool, factor)`` where full-resolution pixel
    coordinates = decimated coordinates × ``factor`` (both in the corner convention). The
    read goes in strips of ``strip_rows`` output rows under a bounded GDAL cache, so memory
    stays near the size of the decimated result however large the file (measured on a
    20000x20000x3 target: 400 MB peak instead of 1.4 GB, and faster).
    """
    factor = max(1.0, float(np.sqrt(info.width * info.height / max_pixels)))
    out_w = max(1, int(round(info.width / factor)))
    out_h = max(1, int(round(info.height / factor)))
    fx, fy = info.width / out_w, info.height / out_h
    try:
        with gdal_env(), ropen(info.path) as ds:
            rs = Resampling.average if factor > 1 else Resampling.nearest
            bands = np.empty((ds.count, out_h, out_w), dtype=ds.dtypes[0])
            mask = np.empty((out_h, out_w), bool)
            for r0 in range(0, out_h, strip_rows):
                r1 = min(out_h, r0 + strip_rows)
                win = Window(0, r0 * fy, info.width, (r1 - r0) * fy)
                bands[:, r0:r1] = ds.read(window=win, out_shape=(ds.count, r1 - r0, out_w), resampling=rs)
                m = ds.read_masks(window=win, out_shape=(ds.count, r1 - r0, out_w), resampling=Resampling.nearest)
                mask[r0:r1] = (m > 0).all(axis=0)
    except RasterioIOError as e:
        raise RasterError(f"{role} {str(info.path)!r} could not be read ({e}); the file may be corrupt") from None
    return bands, mask, (fx, fy)


#: Tile size of every GeoTIFF fotogeo writes (GDAL's default for TILED=YES).
GEOTIFF_BLOCK = 256


#: profile entries that rasterio reads itself rather than passing to GDAL as creation options
_NOT_OPTIONS = frozenset({"driver", "dtype", "crs", "transform", "nodata", "width", "height", "count"})


def geotiff_profile(base: dict | None = None, *, predictor: bool = False, compress: str = "deflate",
                    **fields) -> dict:
    """The rasterio profile of a GeoTIFF output: ``base`` (e.g. a source's ``profile``)
    updated with ``fields`` (width, height, count, dtype, crs, transform, nodata, …) and
    fotogeo's creation options — driver GTiff, tiled in 256x256 blocks, ``compress``
    (:mod:`fotogeo.io.compression`: DEFLATE unless asked; a ``zlevel`` field is its level).

    With ``predictor``, also the predictor for the data type (2, horizontal
    differencing, for integers; 3, floating point, otherwise) and ``BIGTIFF=IF_SAFER``, for
    large outputs such as rectified images. Without ``base`` and ``fields`` the result are
    the creation options alone, e.g. for ``rasterio.shutil.copy``.

    Creation options given as text are passed upper case (a source's profile says ``interleave="pixel"``): GDAL
    compares them with the C library's ``strcasecmp``, for which ``i`` and ``I`` differ in a Turkish locale
    (``LANG=tr_TR.UTF-8``), where GDAL refused "INTERLEAVE=pixel unsupported, value must be PIXEL or BAND".

    >>> geotiff_profile({"interleave": "pixel", "dtype": "uint8"})["interleave"], geotiff_profile()["compress"]
    ('PIXEL', 'DEFLATE')
    """
    profile = dict(base or {})
    profile.update(fields)
    profile.update({k: v.upper() for k, v in profile.items() if isinstance(v, str) and k not in _NOT_OPTIONS})
    options = gtiff_options(compress, profile["dtype"] if predictor else None, zlevel=profile.pop("zlevel", None))
    for key in ("predictor", "zstd_level") if options["compress"] == "NONE" else ():
        profile.pop(key, None)  # a source's, meaningless uncompressed
    profile.update(driver="GTiff", tiled=True, blockxsize=GEOTIFF_BLOCK, blockysize=GEOTIFF_BLOCK, **options)
    if predictor:
        profile.update(BIGTIFF="IF_SAFER")
    return profile


#: side files GDAL may write beside a raster; they follow it on commit and are deleted with it
SIDE_FILES = (".aux.xml", ".ovr", ".msk")


class AtomicOutputs:
    """Temporary paths beside each final path, committed together by :meth:`commit`.

    Used as a context manager: leaving it without ``commit()`` (an error, a cancel, a signal
    turned into an exception) deletes every temporary file, so no half-written output is left.

    :meth:`commit` is all or nothing. Without ``overwrite`` each final name is claimed
    exclusively (``os.link``, which fails if the name exists, or ``O_EXCL`` creation where
    links are unsupported): an output that appeared since the start — e.g. written by a
    concurrent run — is never replaced, and of two runs writing the same new path exactly one
    succeeds. With ``overwrite`` an existing file is kept as a hidden backup until the whole
    set is in place. If any step fails, what was committed is undone (backups restored, new
    files removed) and an :class:`OutputError` names the file.
    """

    def __init__(self, overwrite: bool = False):
        self.overwrite = overwrite
        self._pairs: list[tuple[Path, Path]] = []

    def temp(self, final) -> Path:
        final = Path(final)
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{final.stem}.", suffix=f".part{final.suffix}", dir=final.parent)
        except OSError as e:
            raise OutputError(f"cannot write {str(final)!r} ({e.strerror or e}); choose a writable folder") from None
        os.close(fd)
        os.unlink(tmp)  # writers (GDAL, SQLite) want to create the file themselves
        self._pairs.append((Path(tmp), final))
        return Path(tmp)

    def _files(self):
        """(temporary, final) of every file to commit: the outputs and their GDAL side files."""
        for tmp, final in self._pairs:
            yield tmp, final
            for sfx in SIDE_FILES:
                if Path(str(tmp) + sfx).exists():
                    yield Path(str(tmp) + sfx), Path(str(final) + sfx)

    def commit(self):
        done: list[tuple[Path, Path | None]] = []  # (final, backup of what it replaced or None)
        for tmp, final in list(self._files()):
            try:
                done.append((final, self._place(tmp, final)))
            except OSError as e:
                self._rollback(done)
                if isinstance(e, OutputError):
                    raise
                raise OutputError(f"could not write {str(final)!r} ({e.strerror or e}); no output was "
                                  f"changed") from None
        for _, backup in done:
            if backup is not None:
                with contextlib.suppress(OSError):
                    backup.unlink()
        self.discard()

    def _place(self, tmp: Path, final: Path):
        """Move ``tmp`` to ``final``; return the backup of a replaced file (None if none was)."""
        if final.is_dir():
            raise OutputError(f"{str(final)!r} is a folder; it cannot be replaced by an output")
        if not self.overwrite or not os.path.lexists(final):
            _claim(tmp, final)
            return None
        fd, backup = tempfile.mkstemp(prefix=f".{final.stem}.", suffix=f".bak{final.suffix}", dir=final.parent)
        os.close(fd)
        os.replace(final, backup)
        try:
            os.replace(tmp, final)
        except OSError:
            os.replace(backup, final)
            raise
        return Path(backup)

    def _rollback(self, done):
        for final, backup in reversed(done):
            with contextlib.suppress(OSError):
                if backup is not None:
                    os.replace(backup, final)
                else:
                    final.unlink()

    def discard(self):
        for tmp, _ in self._pairs:
            for p in (tmp, *(Path(str(tmp) + sfx) for sfx in SIDE_FILES)):
                with contextlib.suppress(FileNotFoundError):
                    p.unlink()
        self._pairs = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.discard()
        return False


def _claim(tmp: Path, final: Path):
    """Give ``tmp`` the name ``final`` only if no file has it (exclusive); ``tmp`` is removed."""
    try:
        os.link(tmp, final)
    except FileExistsError:
        raise OutputError(f"{str(final)!r} appeared while fotogeo was working (another run?); it was not "
                          f"replaced — pass overwrite=True to replace it", option="overwrite") from None
    except OSError:  # no hard links here (e.g. FAT, some network shares): claim the name with O_EXCL
        try:
            os.close(os.open(final, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644))
        except FileExistsError:
            raise OutputError(f"{str(final)!r} appeared while fotogeo was working (another run?); it was not "
                              f"replaced — pass overwrite=True to replace it", option="overwrite") from None
        try:
            os.replace(tmp, final)
        except OSError:
            final.unlink()
            raise
        return
    os.unlink(tmp)


def raster_transform(raster):
    """Geotransform of ``raster`` (a path) if it is georeferenced, else None (unreferenced convention)."""
    if raster is None:
        return None
    info = open_raster(raster, "source raster")
    return info.transform if not info.transform.is_identity else None


def read_dem(path, band: int = 1):
    """A :class:`~fotogeo.geometry.dem.Dem` from band ``band`` of a raster; nodata becomes NaN.

    Refuses a raster without georeference (identity transform): heights need map positions. The one
    DEM reader: the file-format layer builds the array-layer ``Dem`` (imports go down the layers). Heights
    stated in another length unit than the CRS's (a band unit ``ft`` under metres) are converted to it
    (:func:`dem_height_scale`).
    """
    try:
        with ropen(path) as ds:
            if ds.transform.is_identity:
                raise RasterError(f"DEM {path}: has no georeference (identity transform); georeference it first")
            z = ds.read(band, masked=True).astype(np.float64) * dem_height_scale(ds, band)
            return Dem(z.filled(np.nan), ds.transform, ds.crs, str(path))
    except RasterioIOError as exc:
        raise RasterError(f"cannot read DEM {path}: {exc}") from None


def dem_height_scale(ds, band: int = 1, crs=None) -> float:
    """The factor bringing the heights of band ``band`` of the open raster ``ds`` into its CRS's length unit:
    :func:`~fotogeo.geometry.vertical.height_scale` of its CRS (``crs``: the same, already parsed by pyproj)
    and the band's unit type (1 when unstated)."""
    from ..geometry.vertical import height_scale
    units = ds.units or ()
    return height_scale(ds.crs if crs is None else crs, units[band - 1] if len(units) >= band else None)


#: a raster's metadata item stating its heights' reference ("ellipsoid", "geoid"): fotogeo's DSMs write it, as a
#: GeoTIFF cannot carry a projected CRS with ellipsoidal heights
HEIGHT_REFERENCE_TAG = "HEIGHT_REFERENCE"


def stated_height_reference(path, crs) -> tuple:
    """``(reference, where)``: the height reference the raster ``path`` of CRS ``crs`` states, ``"ellipsoid"``,
    ``"geoid"`` or None, and where it says so, ``"CRS"`` (:func:`~fotogeo.geometry.vertical.crs_height_reference`,
    first) or ``"metadata"`` (its :data:`HEIGHT_REFERENCE_TAG` item)."""
    from ..geometry.vertical import crs_height_reference
    ref = crs_height_reference(crs)
    if ref is not None:
        return ref, "CRS"
    with ropen(path) as ds:
        tag = ds.tags().get(HEIGHT_REFERENCE_TAG, "").strip().lower()
    return (tag, "metadata") if tag in ("ellipsoid", "geoid") else (None, None)
