"""Cloud Optimized GeoTIFF: a written GeoTIFF converted in place with GDAL's COG driver.

The tools write their GeoTIFF as usual (window by window, through
:class:`~fotogeo.io.raster.AtomicOutputs`) and convert the temporary file before the commit:
GDAL's ``COG`` driver copies it into a tiled GeoTIFF with overviews, its header and tile
index at the start of the file (``LAYOUT=COG`` in GDAL's image structure metadata), so a
web client or QGIS reads any window or zoom level with few range requests. The copy goes to
a hidden file beside the source and replaces it; an error leaves the source as it was.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..errors import OutputError

#: creation options of the COG copy besides its compression (:func:`~fotogeo.io.compression.cog_options`)
COG_OPTIONS = {"BLOCKSIZE": 512, "OVERVIEWS": "AUTO", "BIGTIFF": "IF_SAFER"}


def convert_to_cog(path, resampling: str = "nearest", compress: str = "deflate") -> Path:
    """Rewrite the GeoTIFF ``path`` as a Cloud Optimized GeoTIFF (overviews by ``resampling``; ``compress``: one of
    :data:`fotogeo.options.COMPRESSIONS`, every one lossless), under fotogeo's
    bounded GDAL block cache (:func:`~fotogeo.io.raster.gdal_env`; GDAL's default, 5 % of RAM, holds blocks of a
    large grid while its overviews are built)."""
    import rasterio.shutil
    from rasterio.errors import RasterioError

    from .compression import cog_options
    from .raster import gdal_env

    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".cog.tif", dir=path.parent)
    os.close(fd)
    os.unlink(tmp)
    try:
        with gdal_env():
            rasterio.shutil.copy(path, tmp, driver="COG", OVERVIEW_RESAMPLING=resampling.upper(), **COG_OPTIONS,
                                 **cog_options(compress))
        os.replace(tmp, path)
    except (RasterioError, OSError) as e:
        raise OutputError(f"could not write the Cloud Optimized GeoTIFF {str(path)!r}: {e}") from None
    finally:
        for p in (tmp, tmp + ".aux.xml"):
            if os.path.exists(p):
                os.unlink(p)
    return path
