"""RPC images that both lost their place in the product (issue 30): two ventoux crops without their window
geotransform, their product's RPC file beside each (an OSSIM .geom, or an _RPC.TXT GDAL reads as the image's own),
are read at the product's first pixel. Before: exit 0, a relative-pointing warning and a DSM 3.6 km from its place
with heights 309 m too high (median 845 m against 536 m). Now refused naming both images and the fix, after the
sparse matches (the pair's RPCs disagree by 13 px; 4.8 px with the windows)."""
from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.errors import InputError

pytestmark = [pytest.mark.data]


def _placeless(src, dst):
    """``src`` copied to ``dst`` without its geotransform (a cut-out that lost its place)."""
    with rasterio.open(src) as ds:
        a, prof = ds.read(), ds.profile
    prof.pop("transform", None)
    prof.pop("crs", None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(dst, "w", **prof) as out:
            out.write(a)


def placeless(im) -> str:
    """:func:`fotogeo.io.rpc_place.placeless` of an RPC image as ``dsm --rpc`` reads it (its RPC read once)."""
    from fotogeo.io.rpc_place import placeless as why
    return why(im.path, im.width, im.height, im.rpc)


def _rpc_text(rpc, path):
    md = rpc.to_gdal_metadata()
    lines = [f"{k}: {v}" for k, v in md.items() if not k.endswith("COEFF")]
    for k in ("LINE_NUM_COEFF", "LINE_DEN_COEFF", "SAMP_NUM_COEFF", "SAMP_DEN_COEFF"):
        lines += [f"{k}_{i + 1}: {v}" for i, v in enumerate(md[k].split())]
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("sidecar", [".geom", "_RPC.TXT", "tags"])
def test_two_crops_that_lost_their_place_are_refused_by_name(data_dir, tmp_path, monkeypatch, sidecar):
    """The product's RPC beside each crop, or written into it as GeoTIFF RPC tags (LINE_OFF 21109.5 on a 500-row
    image: before, taken at its word, exit 0 with the DSM 3.6 km off and median 845 m against 536 m)."""
    from fotogeo.io.rpc import read_rpc, write_rpc_geotiff
    from fotogeo.tools.dsm import dsm
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    for side in ("left", "right"):
        if sidecar == "tags":
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
                write_rpc_geotiff(v / f"{side}_image.tif", tmp_path / f"{side}.tif", read_rpc(v / f"{side}_image.geom"))
            continue
        _placeless(v / f"{side}_image.tif", tmp_path / f"{side}.tif")
        if sidecar == ".geom":
            shutil.copy(v / f"{side}_image.geom", tmp_path / f"{side}.geom")
        else:
            _rpc_text(read_rpc(v / f"{side}_image.geom"), tmp_path / f"{side}_RPC.TXT")
    out = tmp_path / "dsm.tif"
    what = "GeoTIFF RPC tags" if sidecar == "tags" else f"left{sidecar}"
    with pytest.raises(InputError, match=rf"pair left-right: 'left' \(500 x 500 px, no geotransform; {what}: "
                                         rf"a product of about 39999 x 42275\) and 'right' .* are read at the first "
                                         rf"pixel of the product their RPCs describe, and the pair's RPCs "
                                         rf"disagree by 13 px .* — cut them again from the product with "
                                         rf"gdal_translate -srcwin .*gdal_edit.py -a_ullr .*own pixels$") as info:
        dsm([tmp_path / "left.tif", tmp_path / "right.tif"], out, rpc=True)
    assert "\n" not in str(info.value) and not out.exists()


def test_images_that_keep_their_place_are_not_placeless(data_dir, tmp_path):
    """The ventoux crops with their windows, and a crop with GDAL's own tags (which GDAL moves into its cuts:
    ``OFF − SCALE ≈ −COL``), are not taken for cut-outs that lost their place; the product's tags on a crop are."""
    from fotogeo.io.rpc import read_rpc, write_rpc_geotiff
    from fotogeo.io.rpc_image import image_rpc
    from fotogeo.tools.dsm.rpc_tool import rpc_images
    v = data_dir / "rpc" / "ventoux"
    ims, _, _ = rpc_images([v / "left_image.tif", v / "right_image.tif"], "auto", None)
    assert [placeless(im) for im in ims] == ["", ""]
    write_rpc_geotiff(v / "left_image.tif", tmp_path / "tags.tif", image_rpc(v / "left_image.tif").rpc)
    assert image_rpc(tmp_path / "tags.tif").source == "GDAL RPC metadata"
    assert placeless(rpc_images([tmp_path / "tags.tif"], "auto", None)[0][0]) == ""
    write_rpc_geotiff(v / "left_image.tif", tmp_path / "product.tif", read_rpc(v / "left_image.geom"))
    assert "GeoTIFF RPC tags" in placeless(rpc_images([tmp_path / "product.tif"], "auto", None)[0][0])
    assert np.isfinite(ims[0].width)


def test_a_crop_with_its_own_moved_rpc_is_not_taken_for_one_that_lost_its_place(data_dir, tmp_path, monkeypatch):
    """A ventoux crop without a geotransform whose _RPC.TXT is the crop's own (offsets moved by the crop's corner, as
    ``gdal_translate -srcwin -co RPCTXT=YES`` writes) describes its pixels: it is not flagged (it was, from its size
    alone, by review of session 19), while the product's RPC beside the same pixels still is."""
    from fotogeo.io.rpc import read_rpc
    from fotogeo.io.rpc_image import image_rpc
    from fotogeo.tools.dsm.rpc_tool import rpc_images
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    for side in ("left", "right"):
        _placeless(v / f"{side}_image.tif", tmp_path / f"{side}.tif")
        _rpc_text(image_rpc(v / f"{side}_image.tif").rpc, tmp_path / f"{side}_RPC.TXT")
    ims, _, _ = rpc_images([tmp_path / "left.tif", tmp_path / "right.tif"], "auto", None)
    assert [placeless(im) for im in ims] == ["", ""]
    _rpc_text(read_rpc(v / "left_image.geom"), tmp_path / "left_RPC.TXT")
    ims, _, _ = rpc_images([tmp_path / "left.tif", tmp_path / "right.tif"], "auto", None)
    assert "no geotransform" in placeless(ims[0]) and placeless(ims[1]) == ""
