"""``fotogeo dsm --rpc`` by output tiles: a rendered pair whose images carry RPCs fitted to their frames
(``tests/rendered_pair.py``: a converging pair seen from high up through a narrow view, base-to-height ratio
0.25, over a known terrain of ±16 m) against its truth; output tiles and small locally epipolar tiles against
one tile; bad input refused."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import rasterio

from fotogeo.errors import FotogeoError

from rendered_pair import GSD, accuracy, render_rpc

SIZE = 400


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    return render_rpc(tmp_path_factory.mktemp("rpc_pair"), SIZE, seed=4)


def _heights(path):
    with rasterio.open(path) as ds:
        return ds.read(1, masked=True)


def test_rendered_rpc_pair_against_its_terrain(pair, tmp_path):
    """The RPCs reproduce their frames (the fit); the DSM at 2 GSD lies within 1 GSD RMSE of the terrain, its
    median within half a GSD, and covers most of the overlap; the pointing correction finds nothing to correct
    (both RPCs are exact) and the rays meet to a fraction of a pixel."""
    from fotogeo.tools.dsm import dsm
    assert pair["rpc_fit_px"] < 0.01
    rep = dsm(pair["images"], tmp_path / "d.tif", rpc=True, point_cloud=tmp_path / "d.las")
    acc = accuracy(tmp_path / "d.tif")
    assert acc["rmse_m"] < GSD and abs(acc["median_m"]) < 0.5 * GSD, acc
    assert rep["completeness"] > 0.9 and rep["grid"]["resolution"] == pytest.approx(2 * GSD)
    p = rep["pairs"][0]
    assert np.hypot(*p["relative_pointing_px"]) < 0.1
    assert p["ray_miss_px"]["median"] < 0.3
    # every point once in the cloud: those of each output tile's core
    assert rep["points_written"] == p["points"] > 0.5 * acc["cells_with_height"]


def test_output_tiles_and_small_epipolar_tiles_give_the_surface_of_one_tile(pair, tmp_path, monkeypatch):
    """Output tiles of 96 cells (the grid is about 170 cells a side: 2 x 2 tiles, each expanded by the speckle
    margin) and locally epipolar matching tiles of 192 pixels (each rectified with its own geometry) against one
    output tile and one matching tile: the same cells get a height (to 2 % of them); their heights differ as two
    matchings of the same pixels through other rectifications do (the matching noise: median 0.4 GSD, 95 % within
    1.3 GSD measured), with no bias between them, and the tiled one is as close to the terrain (1 GSD RMSE)."""
    from fotogeo.tools.dsm import dsm, matching, rpc_pairs
    one = dsm(pair["images"], tmp_path / "one.tif", rpc=True)
    monkeypatch.setattr(matching, "TILE_CELLS", 96)
    monkeypatch.setattr(rpc_pairs, "TILE", 192)
    tiled = dsm(pair["images"], tmp_path / "tiled.tif", rpc=True)
    assert tiled["grid"] == one["grid"] and min(one["grid"]["width"], one["grid"]["height"]) > 96
    h1, ht = _heights(tmp_path / "one.tif"), _heights(tmp_path / "tiled.tif")
    both = ~h1.mask & ~ht.mask
    either = ~h1.mask | ~ht.mask
    assert both.sum() > 0.98 * either.sum()
    dz = (ht.data - h1.data)[both]
    assert abs(np.median(dz)) < 0.1 * GSD
    assert np.median(np.abs(dz)) < 0.6 * GSD and np.percentile(np.abs(dz), 95) < 2 * GSD
    a1, at = accuracy(tmp_path / "one.tif"), accuracy(tmp_path / "tiled.tif")
    assert at["rmse_m"] < GSD and at["rmse_m"] < 1.15 * a1["rmse_m"], (a1, at)


def test_bad_rpc_input_is_refused_and_writes_nothing(pair, tmp_path):
    """An image without an RPC, and bounds where the images see nothing: one-line errors naming the input; no
    output left behind."""
    from fotogeo.tools.dsm import dsm
    a, b = pair["images"]
    bare = tmp_path / "bare.tif"
    shutil.copy(b, bare)
    with rasterio.open(bare, "r+") as ds:
        ds.update_tags(ns="RPC", **{k: "" for k in ds.tags(ns="RPC")})
    out = tmp_path / "d.tif"
    with pytest.raises(FotogeoError) as e:
        dsm([a, bare], out, rpc=True)
    assert "bare" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(FotogeoError) as e:
        dsm([a, b], out, rpc=True, bounds="400000,4300000,400100,4300100")
    assert "\n" not in str(e.value)
    assert not out.exists() and list(tmp_path.iterdir()) == [bare]
