"""Where an image's RPC comes from: two RPCs of one image that disagree are refused, the source of each image's
RPC is named in ``dsm --rpc``'s console line and report, and the refusals of an image without an RPC and of a
pair of images of different places say what to do."""
from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.errors import InputError

pytestmark = [pytest.mark.data]


def _tagged(src, dst, rpc):
    from fotogeo.io.rpc import write_rpc_geotiff
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        write_rpc_geotiff(src, dst, rpc)


def test_tags_and_a_different_geom_beside_are_refused_naming_both(data_dir, tmp_path):
    """Tags and a .geom beside the image 60 lines off (the product's RPC as tags, ventoux's right_image_bias.geom
    beside): before, the tags were used without a word."""
    from fotogeo.io.rpc import read_rpc
    from fotogeo.io.rpc_image import image_rpc, source_label
    v = data_dir / "rpc" / "ventoux"
    _tagged(v / "right_image.tif", tmp_path / "right_image.tif", read_rpc(v / "right_image.geom"))
    assert source_label(tmp_path / "right_image.tif", image_rpc(tmp_path / "right_image.tif")) == "GeoTIFF RPC tags"
    shutil.copy(v / "right_image_bias.geom", tmp_path / "right_image.geom")
    with pytest.raises(InputError, match=r"'.*right_image.tif' has two RPCs that disagree by 60 px: GeoTIFF RPC tags "
                                         r"\(read first\) and right_image.geom beside it; keep one: to keep "
                                         r"right_image.geom remove the tags "
                                         r"\(gdal_edit.py -unsetrpc right_image.tif\), "
                                         r"to keep the tags move right_image.geom away$"):
        image_rpc(tmp_path / "right_image.tif")


def test_tags_and_the_same_rpc_beside_agree(data_dir, tmp_path):
    """The same RPC as tags and as a .geom beside: no conflict, the tags named."""
    from fotogeo.io.rpc import read_rpc
    from fotogeo.io.rpc_image import image_rpc, rpc_gap_px, source_label
    v = data_dir / "rpc" / "ventoux"
    _tagged(v / "left_image.tif", tmp_path / "left_image.tif", read_rpc(v / "left_image.geom"))
    shutil.copy(v / "left_image.geom", tmp_path / "left_image.geom")
    info = image_rpc(tmp_path / "left_image.tif")
    assert source_label(tmp_path / "left_image.tif", info) == "GeoTIFF RPC tags"
    r = read_rpc(v / "right_image.geom")
    shifted = read_rpc(v / "right_image_bias.geom")
    assert rpc_gap_px(r, r, 500, 500) < 1e-6
    assert rpc_gap_px(r, shifted, 500, 500) == pytest.approx(60.0, abs=0.5)


def test_an_image_without_rpc_is_told_the_names_read(data_dir, tmp_path):
    from fotogeo.io.rpc_image import image_rpc
    shutil.copy(data_dir / "rpc" / "ventoux" / "left_image.tif", tmp_path / "a.tif")
    with pytest.raises(InputError, match=r"'.*a.tif' has no RPC: .*; put the RPC of its product beside it as a.geom "
                                         r"\(OSSIM\), a.RPB or a_RPC.TXT$"):
        image_rpc(tmp_path / "a.tif")


def test_images_of_different_continents_are_told_their_footprints_do_not_overlap(data_dir, tmp_path):
    """rpcm's IKONOS (Uruguay) and SPOT 6 (Haiti) RPCs beside two 800 x 800 images: before, the refusal told how to
    re-place a cut-out in its product (gdal_edit.py -a_ullr)."""
    from fotogeo.tools.dsm import dsm
    m = data_dir / "rpc" / "rpcm"
    g = np.random.default_rng(0).integers(0, 255, (1, 800, 800)).astype("uint8")
    for n in ("ik", "spot"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(tmp_path / f"{n}.tif", "w", driver="GTiff", width=800, height=800, count=1,
                               dtype="uint8") as d:
                d.write(g)
    shutil.copy(m / "rpc_IKONOS.txt", tmp_path / "ik_rpc.txt")
    shutil.copy(m / "rpc_SPOT6.xml", tmp_path / "spot.XML")
    with pytest.raises(InputError, match=r"no stereo pair .*; their footprints do not overlap: 'ik' is centred at "
                                         r"lon -56\.\d+, lat -34\.\d+ and 'spot' at lon -72\.\d+, lat 18\.\d+, \d+ km "
                                         r"apart .*different angles$") as info:
        dsm([tmp_path / "ik.tif", tmp_path / "spot.tif"], tmp_path / "d.tif", rpc=True)
    assert "a_ullr" not in str(info.value)


def test_dsm_names_each_images_rpc_source(data_dir, tmp_path):
    """The console's notes and each pair of the report name where each image's RPC was read."""
    from fotogeo.io.rpc_image import image_rpc
    from fotogeo.tools.dsm import dsm
    v = data_dir / "rpc" / "ventoux"
    _tagged(v / "left_image.tif", tmp_path / "left.tif", image_rpc(v / "left_image.tif").rpc)
    rep = dsm([tmp_path / "left.tif", v / "right_image.tif"], tmp_path / "d.tif", rpc=True)
    assert rep["pairs"][0]["rpc_sources"] == ["GeoTIFF RPC tags", "right_image.geom + window geotransform"]
    assert "RPCs: left from GeoTIFF RPC tags; right_image from right_image.geom + window geotransform" in rep["notes"]


def test_tags_that_a_dimap_xml_beside_hides_from_gdal_are_compared(data_dir, tmp_path):
    """A ``gdal_translate -srcwin`` cut of a tagged product (GDAL moves the tags into the cut) kept under a Pleiades
    ``IMG_…_R1C1`` name beside the product's ``RPC_….XML``: GDAL reads the XML and hides the file's own tags, so
    the cut was read with the whole product's RPC, 141 px off, without a word (a reviewer's finding). Tags and the
    XML of the same pixels (the uncut product) still agree."""
    import subprocess
    from fotogeo.io.rpc import read_rpc
    from fotogeo.io.rpc_image import image_rpc
    v = data_dir / "rpc" / "ventoux"
    xml = next(v.glob("RPC_PHR1B_*.XML"))
    shutil.copy(xml, tmp_path / xml.name)
    _tagged(v / "left_image.tif", tmp_path / "product.tif", read_rpc(xml))
    subprocess.run(["gdal_edit.py", "-unsetgt", str(tmp_path / "product.tif")], check=True)  # a sensor image
    stem = xml.stem.replace("RPC_", "IMG_")
    cut = tmp_path / f"{stem}_R1C1.tif"
    subprocess.run(["gdal_translate", "-q", "-srcwin", "100", "100", "300", "300", str(tmp_path / "product.tif"),
                    str(cut)], check=True)
    with pytest.raises(InputError, match=r"has two RPCs that disagree by 1\d\d px: RPC_PHR1B_.*XML beside it "
                                         r"\(GDAL reads it first\) and its own GeoTIFF RPC tags; keep one"):
        image_rpc(cut)
    shutil.copy(tmp_path / "product.tif", cut)  # the uncut product's tags: the XML's RPC, read as before
    assert image_rpc(cut).rpc.line_off == pytest.approx(read_rpc(xml).line_off, abs=1.5)
