"""The warning for a DEM that misses part of an image states the share it covers without rounding it up to 100 %
(a one-cell hole under a frame read "covers 100 %", which contradicts itself)."""
from __future__ import annotations

import shutil
import warnings

import rasterio

from fotogeo.tools.ortho.crs_rule import map_crs
from fotogeo.tools.ortho.inputs import image_models, terrain
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


def test_dem_missing_every_frame_is_one_line_for_dsm_and_ortho(data_dir, tmp_path):
    """The NGI DEM warped to UTM 35S while the orientations are in the Lo25 TM: the frames' ground lies outside it.
    dsm crashed in OpenCV (intersectConvexConvex on NaN footprints from the NaN height range); both tools now
    refuse in one line naming the DEM, the images and the CRS to check."""
    import subprocess

    from click.testing import CliRunner

    from fotogeo.cli import main
    from test_bad_input import assert_one_line_error
    ngi = data_dir / "ngi"
    dem = tmp_path / "dem_utm.tif"
    subprocess.run(["gdalwarp", "-q", "-t_srs", "EPSG:32735", str(ngi / "dem.tif"), str(dem)], check=True)
    frames = [str(ngi / "frames" / f"3324c_2015_1004_05_018{k}_RGB.tif") for k in (2, 4)]
    common = ["--camera", str(ngi / "interior_orientation.yaml"), "--eo", str(ngi / "exterior_orientation.txt"),
              "--dem", str(dem), "-q"]
    for tool, out in (("dsm", "dsm.tif"), ("ortho", "ortho")):
        result = CliRunner().invoke(main, [tool, *frames, *common, "-o", str(tmp_path / out)])
        assert_one_line_error(result, "does not cover images '3324c_2015_1004_05_0182_RGB'")
        assert "same CRS (EPSG:32735)" in result.stderr and not (tmp_path / out).exists()
