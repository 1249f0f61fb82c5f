"""The warning for a DEM that misses part of an image states the share it covers without rounding it up to 100 %
(a one-cell hole under a frame read "covers 100 %", which contradicts itself)."""
from __future__ import annotations

import shutil
import warnings

import rasterio

from fotogeo.tools.ortho.inputs import image_models, map_crs, terrain
from fotogeo.tools.ortho.tool import plan_grid
from test_ortho_error_threshold import rendered  # noqa: F401  (the fixture)


def test_a_small_hole_is_not_reported_as_full_coverage(rendered, tmp_path):  # noqa: F811
    dem = str(tmp_path / "dem.tif")
    shutil.copy(rendered["dem"], dem)
    with rasterio.open(dem, "r+") as ds:  # one nodata cell instead of the fixture's 2 x 2
        z = ds.read(1)
        z[47:49, 55:57] = z[46, 55]
        z[47, 55] = ds.nodata
        ds.write(z, 1)
    crs = map_crs("auto", dem, rendered["eo"], [rendered["frame"]], False, rendered["camera"], None, "auto")[0]
    im = image_models([rendered["frame"]], crs, camera=rendered["camera"], eo=rendered["eo"], rpc=False, model=None,
                      sfm_frame="auto", said=[])[0]
    heights = terrain(dem, None, crs, [im])[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plan_grid(im, heights, crs, 0.2, str(tmp_path / "unused.tif"), dem)
    said = [str(w.message) for w in caught if "covers" in str(w.message)]
    assert len(said) == 1 and "covers 99." in said[0] and "100 %" not in said[0], said
