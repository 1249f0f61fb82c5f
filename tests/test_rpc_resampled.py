"""RPC tags of an image GDAL resampled (``gdal_translate -outsize 50% 50%``), against the Pleiades rigorous model.

GDAL's RPC convention puts (0, 0) at the centre of the first pixel, so rescaling an image by ``r`` maps an offset
``L`` to ``(L + ½) · r − ½`` — what gdal_translate does since GDAL 3.9.3 (GDAL issue 10600, pull request 10602).
GDAL before that (3.6.2 on Debian 12 and in QGIS 3.22) wrote ``L · r``: ventoux's left crop at 50 % gets LINE_OFF
8054.75 for 8054.5, (1 − r) / 2 = 0.25 px off, which a stereo pair turns into a height offset. Such a file still
carries the CRS-less geotransform ``(2, 0, 0, 0, 2, 0)`` GDAL gives the resampled image; fotogeo refused it before
as "a cut-out that kept the full product's tags would be 0 px off" (true for neither), and read without it the tags
put every point 0.25 px off. Now refused naming the resampling, the GDAL issue and both fixes; tags written the
GDAL ≥ 3.9.3 way are read as they are, and a crop resampled with its product's .geom beside it maps exactly.
"""
from __future__ import annotations

import shutil
import subprocess
import warnings
from dataclasses import replace

import numpy as np
import pytest
import rasterio

from fotogeo.errors import InputError
from fotogeo.io.rpc import write_rpc_geotiff
from fotogeo.io.rpc_image import image_rpc
from test_rpc_readers import _grid

GRID = "GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif"
pytestmark = [pytest.mark.data]


@pytest.fixture(scope="module")
def resized(data_dir, tmp_path_factory):
    """ventoux's left crop with its RPC as GDAL tags (``full.tif``), resampled 50 % by the machine's gdal_translate
    (``half.tif``), and the rigorous grid's nodes inside the crop in its pixels (corner convention)."""
    if shutil.which("gdal_translate") is None:
        pytest.skip("gdal_translate (GDAL's command-line tools) is not installed")
    v, tmp = data_dir / "rpc" / "ventoux", tmp_path_factory.mktemp("resized")
    crop = image_rpc(v / "left_image.tif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        write_rpc_geotiff(v / "left_image.tif", tmp / "full.tif", crop.rpc)
        subprocess.run(["gdal_translate", "-q", "-outsize", "50%", "50%", str(tmp / "full.tif"),
                        str(tmp / "half.tif")], check=True, env={"GDAL_PAM_ENABLED": "NO", "PATH": "/usr/bin:/bin"})
    a, c, _, f = crop.product_window
    llh, px = _grid(v / GRID)
    inside = np.all((px >= [c, f]) & (px < [c + 500, f + 500]), axis=1)
    return {"dir": tmp, "rpc": crop.rpc, "llh": llh[inside], "px": px[inside] - [c, f]}


def test_the_resampled_tags_are_refused_naming_the_resampling_and_both_fixes(resized):
    with pytest.raises(InputError, match=r"half.tif' has GDAL RPC tags and a geotransform without a CRS that "
                                         r"resamples its pixels 2 x 2 \(what gdal_translate -outsize or -tr leaves.*"
                                         r"GDAL before 3.9.3.*GDAL issue 10600\): 0.25 px off here.*gdal_edit.py "
                                         r"-unsetgt half.tif\); otherwise resample the original again with GDAL "
                                         r"3.9.3 or later, or give fotogeo the original") as info:
        image_rpc(resized["dir"] / "half.tif")
    assert "\n" not in str(info.value)


def test_a_resampled_crop_with_its_products_geom_projects_exactly(data_dir, resized):
    """The other way a resampled image is read right: a crop without tags, its place in the product as a CRS-less
    geotransform, resampled 50 % by gdal_translate (which scales that geotransform and knows nothing of the .geom),
    the product's .geom copied beside it: on the rigorous grid within 0.01 px."""
    v, tmp = data_dir / "rpc" / "ventoux", resized["dir"]
    subprocess.run(["gdal_translate", "-q", "-outsize", "50%", "50%", str(v / "left_image.tif"),
                    str(tmp / "crop50.tif")], check=True, env={"GDAL_PAM_ENABLED": "NO", "PATH": "/usr/bin:/bin"})
    shutil.copy(v / "left_image.geom", tmp / "crop50.geom")
    found = image_rpc(tmp / "crop50.tif")
    assert found.source.endswith("crop50.geom") and found.product_window[::2] == (2.0, 2.0)
    d = found.rpc.to_model().forward(resized["llh"]) - resized["px"] / 2
    assert len(d) >= 9 and np.abs(d).max() < 0.01, np.abs(d).max()


def test_the_tags_as_gdal_writes_them_since_3_9_3_project_right_and_the_older_ones_a_quarter_pixel_off(resized):
    """The tags read as they are (the geotransform removed): written ``(L + ½)·r − ½`` they land on the grid;
    GDAL 3.6's ``L·r`` (what this machine's gdal_translate wrote, kept in ``half.tif``) puts every node +0.25 px off
    in both directions — why fotogeo cannot read them as they are beside that geotransform."""
    from fotogeo.io.rpc import rpc_from_raster
    rpc, r = resized["rpc"], 0.5
    new = replace(rpc, line_off=(rpc.line_off + 0.5) * r - 0.5, samp_off=(rpc.samp_off + 0.5) * r - 0.5,
                  line_scale=rpc.line_scale * r, samp_scale=rpc.samp_scale * r)
    d = new.to_model().forward(resized["llh"]) - resized["px"] / 2
    assert np.abs(d).max() < 0.01, np.abs(d).max()
    old = rpc_from_raster(resized["dir"] / "half.tif")
    if np.isclose(old.line_off, new.line_off):  # a gdal_translate of 3.9.3 or later wrote it
        return
    assert np.isclose(old.line_off, rpc.line_off * r)
    d = old.to_model().forward(resized["llh"]) - resized["px"] / 2
    assert np.allclose(d, 0.25, atol=0.01), d


@pytest.mark.parametrize("gt", [(0.5, 0, 10, 0, -0.5, 20), (0, 1, 0, 1, 0, 0)])
def test_a_flipped_or_degenerate_window_is_not_called_a_resample(tmp_path, gt):
    """A north-up world-file geotransform (e < 0) or a degenerate one (a = 0) beside RPC tags is refused as a window
    (one line), not as a resample of '0.5 x -0.5' nor with a ZeroDivisionError (review of session 19)."""
    from affine import Affine
    from fotogeo.io.rpc_image import _refuse_tags_with_window
    with pytest.raises(InputError, match=r"GDAL RPC tags and a geotransform without a CRS \(its pixel") as info:
        _refuse_tags_with_window(tmp_path / "x.tif", Affine(*gt))
    assert "\n" not in str(info.value)
