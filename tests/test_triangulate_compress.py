"""``fotogeo triangulate --compress``: the orthophotos, their σ rasters and the mosaic of the adjustment are written
with the compression asked (their tags read back), with the same pixels as the default DEFLATE's; a bad choice is
refused before anything is written."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.tools.triangulate import triangulate

from test_triangulate import CAMERA, write_block
from test_triangulate_inputs import _write_dem


@pytest.fixture(scope="module")
def block():
    return simulate_block(seed=6, strips=2, frames_per_strip=3, camera=CAMERA, point_spacing=50.0, margin=3.0,
                          n_check=6, blunder_fraction=0.0)


def _run(folder, frames, dem, name, **kw):
    out = folder / name
    out.mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        rep = triangulate(frames, folder / "camera.yaml", folder / "eo.txt", folder / "tie.csv", out,
                          gcps=folder / "gcp_list.txt", image_sigma=0.3, resolution=2.0, dem=dem, **kw)
    return rep, out


def _read(path):
    with rasterio.open(path) as ds:
        return ds.tags(ns="IMAGE_STRUCTURE").get("COMPRESSION"), ds.read()


def test_orthophotos_sigma_and_mosaic_take_the_compression(tmp_path, block):
    frames, _ = write_block(tmp_path, block)
    dem = _write_dem(tmp_path / "dem.tif", block)
    rep0, deflate = _run(tmp_path, frames, dem, "deflate", mosaic=True, uncertainty=True, dem_sigma=1.0)
    rep1, zstd = _run(tmp_path, frames, dem, "zstd", mosaic=True, uncertainty=True, dem_sigma=1.0, compress="zstd")
    assert "error" not in rep1["mosaic"]
    names = [f"{n}_ortho.tif" for n in rep1["orthorectified"]] + [f"{n}_ortho_sigma.tif"
                                                                   for n in rep1["orthorectified"]] + ["mosaic.tif"]
    for name in names:
        (c0, a0), (c1, a1) = _read(deflate / name), _read(zstd / name)
        assert (c0, c1) == ("DEFLATE", "ZSTD"), name
        np.testing.assert_array_equal(a0, a1)


def test_cli_takes_compress_and_refuses_a_bad_one_before_writing(tmp_path, block):
    frames, _ = write_block(tmp_path, block)
    out = tmp_path / "out"
    args = ["triangulate", *map(str, frames), "--camera", str(tmp_path / "camera.yaml"), "--eo",
            str(tmp_path / "eo.txt"), "--observations", str(tmp_path / "tie.csv"), "--gcps",
            str(tmp_path / "gcp_list.txt"), "--image-sigma", "0.3", "--resolution", "2", "-o", str(out),
            "--orthorectify", "-q"]
    result = CliRunner().invoke(main, args + ["--compress", "jpeg"])
    assert result.exit_code != 0 and "--compress" in result.output and "Traceback" not in result.output
    assert not out.exists() or not any(out.iterdir())
    with pytest.raises(InputError, match="compress"):
        _run(tmp_path, frames, None, "api", orthorectify=True, compress="jpeg")
    assert not any((tmp_path / "api").iterdir())
    result = CliRunner().invoke(main, args + ["--compress", "lzw"])
    assert result.exit_code == 0, result.output
    tif = sorted(out.glob("*_ortho.tif"))
    assert tif and all(_read(p)[0] == "LZW" for p in tif)
