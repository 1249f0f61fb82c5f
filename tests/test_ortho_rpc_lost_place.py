"""``ortho --rpc`` of a cut-out that lost its place in its product: a 500 x 500 ventoux crop carrying the whole
product's RPC as GeoTIFF RPC tags (LINE_OFF 21109.5 on a 500-row image, no geotransform) was orthorectified with
exit 0 about 3.6 km from its place (the product's corner) without a word. ortho has no second image to measure the
error by, and a crop GDAL's ``-srcwin`` cut near the product's corner (it moves the tags into the cut) looks the
same in the file and is right (a reviewer refused it with a refusal here), so such an image is orthorectified with
a warning (:mod:`fotogeo.io.rpc_place`, the check ``dsm --rpc`` uses too)."""
from __future__ import annotations

import warnings

import pytest
import rasterio


pytestmark = [pytest.mark.data]


def _tagged(src, dst, rpc):
    from fotogeo.io.rpc import write_rpc_geotiff
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        write_rpc_geotiff(src, dst, rpc)


def test_ortho_warns_about_a_crop_carrying_its_products_rpc_tags(data_dir, tmp_path, monkeypatch):
    from fotogeo.errors import FotogeoWarning
    from fotogeo.io.rpc import read_rpc
    from fotogeo.tools.ortho import ortho
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    img, out = tmp_path / "crop.tif", tmp_path / "ortho.tif"
    _tagged(v / "left_image.tif", img, read_rpc(v / "left_image.geom"))
    with pytest.warns(FotogeoWarning, match=r"^RPC image '.*crop\.tif' \(500 x 500 px, no geotransform; GeoTIFF RPC "
                                            r"tags: a product of about 39999 x 42275\) is read at the first pixel .*"
                                            r"kilometres off.*gdal_edit.py -a_ullr"):
        ortho([img], out, rpc=True, height=500.0, resolution=5.0)
    assert out.exists()


def test_a_gdal_crop_near_the_products_corner_is_orthorectified(data_dir, tmp_path, monkeypatch):
    """``gdal_translate -srcwin 100 100 300 300`` of a tagged product: GDAL moves the offsets by 100 px, small beside
    the product's scales, so the crop looks like a cut-out that lost its place — and is right."""
    import subprocess
    from fotogeo.io.rpc import read_rpc
    from fotogeo.tools.ortho import ortho
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    _tagged(v / "left_image.tif", tmp_path / "product.tif", read_rpc(v / "left_image.geom"))
    subprocess.run(["gdal_edit.py", "-unsetgt", str(tmp_path / "product.tif")], check=True)
    crop = tmp_path / "crop.tif"
    subprocess.run(["gdal_translate", "-q", "-srcwin", "100", "100", "300", "300", str(tmp_path / "product.tif"),
                    str(crop)], check=True)
    ortho([crop], tmp_path / "ortho.tif", rpc=True, height=500.0, resolution=5.0)
    assert (tmp_path / "ortho.tif").exists()


def test_ortho_keeps_a_crop_with_its_own_rpc(data_dir, tmp_path, monkeypatch):
    """The same pixels with the RPC moved into them (as ``gdal_translate -srcwin`` writes the tags), and the
    ventoux crop with its window geotransform and .geom, are orthorectified."""
    from fotogeo.io.rpc_image import image_rpc
    from fotogeo.tools.ortho import ortho
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    img = tmp_path / "crop.tif"
    _tagged(v / "left_image.tif", img, image_rpc(v / "left_image.tif").rpc)
    for i, src in enumerate([img, v / "left_image.tif"]):
        out = tmp_path / f"ortho{i}.tif"
        ortho([src], out, rpc=True, height=500.0, resolution=5.0)
        assert out.exists()
