"""``--compress`` of ortho and mosaic: the file is written with the compression asked (its tags read back), the same
pixels whatever the choice, DEFLATE by default; a bad value or one this GDAL cannot write is one Error line."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

import box_scene as bs
import fotogeo.io.compression as compression
from fotogeo.cli import main
from fotogeo.errors import InputError
from fotogeo.io.raster import geotiff_profile
from fotogeo.tools.ortho.mosaic import mosaic
from fotogeo.tools.ortho.tool import ortho
from test_bad_input import assert_one_line_error
from test_mosaic import _ortho as mosaic_input


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return bs.write_scene(tmp_path_factory.mktemp("boxes"))


def _ortho_args(scene):
    """0.2 m: a 1000² orthophoto, large enough for an overview level."""
    return {"dem": str(scene["dsm"]), "camera": str(scene["camera"]), "eo": str(scene["eo"]), "resolution": 0.2}


def _structure(path):
    """``(COMPRESSION tag or None, predictor, pixels, overview pixels, layout)`` of a GeoTIFF."""
    with rasterio.open(path) as ds:
        s = ds.tags(ns="IMAGE_STRUCTURE")
        ov = ds.overviews(1)
        low = ds.read(out_shape=(ds.count, ds.height // ov[0], ds.width // ov[0])) if ov else None
        return s.get("COMPRESSION"), s.get("PREDICTOR"), ds.read(), low, s.get("LAYOUT")


@pytest.mark.parametrize("cog", [False, True])
def test_ortho_writes_the_compression_asked_with_the_same_pixels(scene, tmp_path, cog):
    """deflate (the default, also when not given), zstd, lzw and none: each file says its compression, the
    compressed ones the horizontal predictor (uint8), and every one holds the same pixels and overviews."""
    plain = tmp_path / "default.tif"
    ortho([str(scene["frame"])], str(plain), cog=cog, **_ortho_args(scene))
    base = _structure(plain)
    assert base[:2] == ("DEFLATE", "2") and base[3] is not None and (base[4] == "COG") == cog
    for name, tag in (("deflate", "DEFLATE"), ("zstd", "ZSTD"), ("lzw", "LZW"), ("none", None)):
        out = tmp_path / f"{name}.tif"
        ortho([str(scene["frame"])], str(out), cog=cog, compress=name, **_ortho_args(scene))
        got = _structure(out)
        assert got[:2] == (tag, None if tag is None else "2"), name
        assert np.array_equal(got[2], base[2]) and np.array_equal(got[3], base[3]) and got[4] == base[4], name


def test_ortho_free_space_check_takes_an_uncompressed_output_whole(scene, tmp_path, monkeypatch):
    """A disk with room for a quarter of the orthophoto (DEFLATE's best) but not for all of it: the default run
    goes on, --compress none is refused before anything is written."""
    import collections
    import shutil
    from fotogeo.errors import OutputError
    from fotogeo.io.output_checks import grid_bytes
    plain = tmp_path / "default.tif"
    ortho([str(scene["frame"])], str(plain), **_ortho_args(scene))
    with rasterio.open(plain) as ds:
        nbytes = grid_bytes(ds.width, ds.height, ds.count, ds.dtypes[0])
    free = int((nbytes / 4 + nbytes) / 2 + 2 ** 20)
    usage = collections.namedtuple("Usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda folder: usage(10 * free, 9 * free, free))
    ortho([str(scene["frame"])], str(tmp_path / "deflate.tif"), **_ortho_args(scene))
    with pytest.raises(OutputError, match="not enough free space"):
        ortho([str(scene["frame"])], str(tmp_path / "none.tif"), compress="none", **_ortho_args(scene))
    assert not (tmp_path / "none.tif").exists()


def test_ortho_cli_takes_compress(scene, tmp_path):
    out = tmp_path / "z.tif"
    result = CliRunner().invoke(main, ["ortho", str(scene["frame"]), "--camera", str(scene["camera"]), "--eo",
                                       str(scene["eo"]), "--dem", str(scene["dsm"]), "--resolution", "0.5",
                                       "--compress", "zstd", "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    assert _structure(out)[:2] == ("ZSTD", "2")


def test_mosaic_writes_the_compression_asked_with_the_same_pixels(tmp_path):
    pair = [str(mosaic_input(tmp_path / "a.tif", 0, 300, 150, box_value=240)),
            str(mosaic_input(tmp_path / "b.tif", 180, 480, 330, 1.3, 20.0, box_value=30))]
    mosaic(pair, str(tmp_path / "deflate.tif"))
    mosaic(pair, str(tmp_path / "zstd.tif"), compress="zstd")
    a, b = _structure(tmp_path / "deflate.tif"), _structure(tmp_path / "zstd.tif")
    assert (a[0], a[4], b[0], b[4]) == ("DEFLATE", "COG", "ZSTD", "COG")
    assert np.array_equal(a[2], b[2]) and np.array_equal(a[3], b[3])


def test_a_bad_compression_is_one_error_line(scene, tmp_path):
    result = CliRunner().invoke(main, ["ortho", str(scene["frame"]), "--camera", str(scene["camera"]), "--eo",
                                       str(scene["eo"]), "--dem", str(scene["dsm"]), "--compress", "jpeg",
                                       "-o", str(tmp_path / "o.tif"), "-q"])
    assert_one_line_error(result, "--compress")
    with pytest.raises(InputError, match="choose one of deflate, zstd, lzw, none"):
        ortho([str(scene["frame"])], str(tmp_path / "o.tif"), compress="jpeg", **_ortho_args(scene))
    assert not list(tmp_path.iterdir())


def test_a_compression_this_gdal_cannot_write_names_the_ones_it_can(scene, tmp_path, monkeypatch):
    """GDAL writes a file it cannot compress as asked uncompressed, with a warning only: refused before anything
    is written, naming --compress and the choices this build writes."""
    monkeypatch.setattr(compression, "gdal_writes", lambda name: name != "zstd")
    result = CliRunner().invoke(main, ["ortho", str(scene["frame"]), "--camera", str(scene["camera"]), "--eo",
                                       str(scene["eo"]), "--dem", str(scene["dsm"]), "--compress", "zstd",
                                       "-o", str(tmp_path / "o.tif"), "-q"])
    assert_one_line_error(result, "--compress 'zstd': this GDAL")
    assert "choose one of deflate, lzw, none" in result.stderr
    assert not list(tmp_path.iterdir())


def test_this_gdal_is_probed_for_what_it_writes():
    """The probe reads back what GDAL wrote: a name GDAL does not know is written uncompressed, so not writable."""
    assert compression.gdal_writes("deflate") and compression.gdal_writes("none")
    saved = dict(compression.GDAL_COMPRESS)
    try:
        compression.GDAL_COMPRESS["lzw"] = "NOT_A_CODEC"
        compression.gdal_writes.cache_clear()
        assert not compression.gdal_writes("lzw")
    finally:
        compression.GDAL_COMPRESS.update(saved)
        compression.gdal_writes.cache_clear()


def test_profile_without_compression_drops_a_sources_predictor():
    p = geotiff_profile({"dtype": "uint16", "predictor": 2, "compress": "lzw"}, compress="none")
    assert p["compress"] == "NONE" and "predictor" not in p
    assert geotiff_profile({"dtype": "uint16"}, predictor=True, compress="zstd", zlevel=1)["zstd_level"] == 1
