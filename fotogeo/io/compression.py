"""The compression of fotogeo's GeoTIFF outputs (``--compress``, :data:`fotogeo.options.COMPRESSIONS`).

Each choice is a GDAL ``COMPRESS`` value of the GTiff and COG drivers, lossless:

- ``deflate`` (the default; every TIFF reader has it), at the level the caller asks (GDAL's 6 otherwise);
- ``zstd`` (Zstandard, Collet and Kucherawy 2018, RFC 8478) at level 1, its fastest: GDAL ≥ 2.3 and QGIS read
  it, some older TIFF readers do not;
- ``lzw`` (Welch 1984);
- ``none``.

The compressed ones use the TIFF predictor of the data type: 2 (horizontal differencing) for integers, 3 (floating
point, Ritter's byte-plane differencing) otherwise. :func:`check_compression` refuses, before anything is written, a
choice the GDAL build in use cannot write (GDAL writes such a file uncompressed with a mere warning).
"""
from __future__ import annotations

import functools
import warnings

import numpy as np

from ..errors import InputError
from ..options import COMPRESSIONS

#: GDAL's ``COMPRESS`` value of each choice
GDAL_COMPRESS = {"deflate": "DEFLATE", "zstd": "ZSTD", "lzw": "LZW", "none": "NONE"}
#: Zstandard level of a ``zstd`` output: 1, the fastest
ZSTD_LEVEL = 1
#: the best compression ratio (uncompressed size with overviews / file size) each choice is taken to reach on
#: imagery: the free-space check (:func:`fotogeo.io.output_checks.check_space`) finds free space below the
#: uncompressed size / this clearly too little. DEFLATE rarely compresses imagery better than 4; ZSTD at level 1 and
#: LZW, with the same predictor, compress fotogeo's orthophotos less than DEFLATE (their ratio to DEFLATE's, measured
#: in docs/benchmarks/products.md, "Compression per codec", times 4); an uncompressed file is its whole size
BEST_RATIO = {"deflate": 4.0, "zstd": 3.8, "lzw": 3.8, "none": 1.0}


def predictor_for(dtype) -> int:
    """The TIFF predictor of ``dtype``: 2 (horizontal differencing) for integers, 3 (floating point) otherwise."""
    return 2 if np.dtype(dtype).kind in "iu" else 3


def gtiff_options(compress: str = "deflate", dtype=None, *, zlevel: int | None = None) -> dict:
    """The GTiff creation options (rasterio profile keys) of ``compress``: with ``dtype``, its predictor;
    ``zlevel``: the DEFLATE level (other compressions ignore it).

    >>> gtiff_options("zstd", "uint16")
    {'compress': 'ZSTD', 'predictor': 2, 'zstd_level': 1}
    >>> gtiff_options("deflate", "float32", zlevel=1), gtiff_options("none", "uint8")
    ({'compress': 'DEFLATE', 'predictor': 3, 'zlevel': 1}, {'compress': 'NONE'})
    """
    name = compression_name(compress)
    options = {"compress": GDAL_COMPRESS[name]}
    if dtype is not None and name != "none":
        options["predictor"] = predictor_for(dtype)
    if name == "deflate" and zlevel:
        options["zlevel"] = int(zlevel)
    if name == "zstd":
        options["zstd_level"] = ZSTD_LEVEL
    return options


def cog_options(compress: str = "deflate") -> dict:
    """The COG driver's creation options of ``compress`` (its ``PREDICTOR=YES`` is the data type's predictor).

    >>> cog_options("zstd"), cog_options()
    ({'COMPRESS': 'ZSTD', 'PREDICTOR': 'YES', 'LEVEL': 1}, {'COMPRESS': 'DEFLATE', 'PREDICTOR': 'YES'})
    """
    name = compression_name(compress)
    options = {"COMPRESS": GDAL_COMPRESS[name]}
    if name != "none":
        options["PREDICTOR"] = "YES"
    if name == "zstd":
        options["LEVEL"] = ZSTD_LEVEL
    return options


def overview_env(compress: str = "deflate", zlevel: int | None = None) -> dict:
    """GDAL configuration options giving internal overviews the file's level (``ZLEVEL_OVERVIEW``,
    ``ZSTD_LEVEL_OVERVIEW``)."""
    name = compression_name(compress)
    if name == "deflate" and zlevel:
        return {"ZLEVEL_OVERVIEW": str(int(zlevel))}
    return {"ZSTD_LEVEL_OVERVIEW": str(ZSTD_LEVEL)} if name == "zstd" else {}


def best_ratio(compress) -> float:
    """:data:`BEST_RATIO` of ``compress`` (:func:`compression_name`).

    >>> best_ratio("DEFLATE"), best_ratio("lzw"), best_ratio("none")
    (4.0, 3.8, 1.0)
    """
    return BEST_RATIO[compression_name(compress)]


def compression_name(compress) -> str:
    """``compress`` as one of :data:`~fotogeo.options.COMPRESSIONS` (any case); else an :class:`InputError`."""
    name = str(compress).lower()
    if name not in GDAL_COMPRESS:
        raise InputError(f"compress must be one of {', '.join(COMPRESSIONS)}; got {compress!r}", option="compress")
    return name


@functools.cache
def gdal_writes(name: str) -> bool:
    """Whether this GDAL build writes ``name``-compressed GeoTIFFs (a one-pixel file in memory, its
    ``COMPRESSION`` read back)."""
    import rasterio
    import rasterio.shutil

    if name == "none":
        return True
    path = f"/vsimem/fotogeo-compress-{name}.tif"
    try:
        with warnings.catch_warnings(), rasterio.Env(CPL_LOG="OFF"):
            warnings.simplefilter("ignore")  # NotGeoreferencedWarning: the probe has no georeference
            with rasterio.open(path, "w", driver="GTiff", width=1, height=1, count=1, dtype="uint8",
                               compress=GDAL_COMPRESS[name]) as ds:
                ds.write(np.zeros((1, 1, 1), np.uint8))
            with rasterio.open(path) as ds:
                return ds.tags(ns="IMAGE_STRUCTURE").get("COMPRESSION", "").upper() == GDAL_COMPRESS[name]
    except Exception:  # noqa: BLE001 - any failure means: not writable here
        return False
    finally:
        if path_exists(path):
            rasterio.shutil.delete(path)


def path_exists(path: str) -> bool:
    """Whether GDAL has a file ``path`` (a /vsimem/ one included)."""
    import rasterio.shutil
    try:
        return rasterio.shutil.exists(path)
    except Exception:  # noqa: BLE001 - nothing to delete
        return False


def check_compression(compress) -> str:
    """``compress`` checked (:func:`compression_name`) and writable by this GDAL build; else a one-line
    :class:`InputError` naming the choices that are."""
    name = compression_name(compress)
    if not gdal_writes(name):
        import rasterio
        works = ", ".join(n for n in COMPRESSIONS if gdal_writes(n))
        raise InputError(f"compress {name!r}: this GDAL ({rasterio.__gdal_version__}) cannot write {name.upper()}-"
                         f"compressed GeoTIFFs; choose one of {works}", option="compress")
    return name
