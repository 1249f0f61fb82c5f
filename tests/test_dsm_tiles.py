"""fotogeo dsm in bounded memory: images read by windows, matching and fusion by output tiles, the DSM written by
windows — and the same surface as one tile gives, on a rendered pair with a known terrain."""
from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
from pyproj import CRS

from fotogeo.io.raster import AtomicOutputs
from fotogeo.stereo.fusion import GridSpec
from fotogeo.stereo.rectify import FrameView, rectify

from rendered_pair import CRS as PAIR_CRS
from rendered_pair import GSD, accuracy, render


def _write(path, data, dtype):
    with rasterio.open(path, "w", driver="GTiff", width=data.shape[2], height=data.shape[1], count=len(data),
                       dtype=dtype) as ds:
        ds.write(data.astype(dtype))
    return path


def test_source_image_reads_windows_and_decimated_windows(tmp_path):
    from fotogeo.tools.dsm.inputs import SourceImage, read_image
    rng = np.random.default_rng(3)
    data = rng.integers(100, 4000, (3, 70, 90))
    src = SourceImage(_write(tmp_path / "a.tif", data, "uint16"))
    whole = np.tensordot(src.weights, data.astype(np.float32), axes=1)  # the bands' fusion weights
    assert np.allclose(np.abs(src.weights).sum(), 1.0) and np.allclose(src.grey(10, 5, 50, 45), whole[5:45, 10:50])
    # k x k block means (GDAL's average resampling) of a window whose size k divides
    k2 = src.grey(10, 4, 50, 44, k=2)
    assert k2.shape == (20, 20)
    assert np.allclose(k2, whole[4:44, 10:50].reshape(20, 2, 20, 2).mean(axis=(1, 3)), atol=0.5)
    # colours: the whole image's stretch (read here undecimated: the image is small), as read_image gives
    _, cols = read_image(tmp_path / "a.tif")
    for c, w in zip(src.colours(10, 5, 50, 45), cols):
        assert c.dtype == np.uint8 and np.abs(c.astype(int) - w[5:45, 10:50]).max() <= 1


def _views(size=(240, 180)):
    """Two pinhole frames 60 m apart, 300 m above the ground, a little rotated."""
    def view(name, centre, kappa):
        c, s = np.cos(kappa), np.sin(kappa)
        R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([1.0, -1.0, -1.0])
        C, f = np.array(centre, float), 200.0
        pp = np.array(size, float) / 2

        def forward(P):
            x = (np.asarray(P, float) - C) @ R
            return f * x[:, :2] / x[:, 2:3] + pp

        def rays(px):
            xn = (np.asarray(px, float) - pp) / f
            return np.column_stack([xn, np.ones(len(xn))]) @ R.T
        return FrameView(name, C, R, f, size, forward, rays)
    return view("a", (0, 0, 300), 0.1), view("b", (60, 5, 302), 0.15)


def test_a_rectified_window_is_the_window_of_the_whole(tmp_path):
    """The rectified pixels of a window, read from the source window they need, equal those of the whole."""
    from fotogeo.tools.dsm.frames import rectified
    from fotogeo.tools.dsm.inputs import SourceImage
    rng = np.random.default_rng(5)
    img = rng.integers(1, 255, (1, 180, 240))
    src = SourceImage(_write(tmp_path / "a.tif", img, "uint8"))
    va, vb = _views()
    rp = rectify(va, vb)
    w, h = rp.size
    g, valid, _ = rectified(rp, va, 0, src, 0, h)
    gw, vw, rgb = rectified(rp, va, 0, src, 30, 90, 40, w - 20, colours=True)
    assert np.array_equal(vw, valid[30:90, 40:w - 20]) and vw.any()
    assert np.abs(gw - g[30:90, 40:w - 20])[vw].max() < 0.05
    assert len(rgb) == 3 and rgb[0].shape == gw.shape


def test_products_tile_by_tile_equal_one_tile(tmp_path):
    """Speckle removal over tiles expanded by the margin gives what the whole grid gives; the windows land in
    place; the report's counts add up."""
    from fotogeo.tools.dsm.outputs import TILE_MARGIN, Products
    rng = np.random.default_rng(1)
    grid = GridSpec(1000.0, 2000.0, 1.0, 230, 170)
    yy, xx = np.mgrid[0:170, 0:230]
    height = (50 + 0.05 * xx + 0.02 * yy).astype(np.float32)
    height[rng.random(height.shape) < 0.1] = np.nan  # holes
    for r, c in rng.integers(0, 160, (40, 2)):  # islands (mismatches) 30 m up, cut off by holes, some across tile edges
        height[r:r + 4, c:c + 5] += 30.0
        height[max(0, r - 1), c:c + 5] = np.nan
        height[min(169, r + 4), c:c + 5] = np.nan
        height[r:r + 4, max(0, c - 1)] = np.nan
        height[r:r + 4, min(229, c + 5)] = np.nan
    count = np.isfinite(height).astype(np.int16)
    spread = np.where(np.isfinite(height), 0.1, np.nan).astype(np.float32)

    def run(size):
        out_path = tmp_path / f"d{size}.tif"
        with AtomicOutputs(True) as out:
            pr = Products(out, out_path, grid, CRS("EPSG:32635"), fill=False, seen=lambda g, h: np.ones(h.shape, bool))
            for core, exp in grid.tiles(size, TILE_MARGIN if size < 230 else 0):
                cut = (slice(exp[0], exp[0] + exp[2]), slice(exp[1], exp[1] + exp[3]))
                pr.add(core, exp, height[cut].copy(), count[cut].copy(), spread[cut].copy())
            rep = pr.finish([], [], "rule", None, [], 0.0, 1.0, (0.0, 0.0), {}, "nothing")
            out.commit()
        with rasterio.open(out_path) as ds:
            return ds.read(), rep
    whole, rw = run(1000)
    tiled, rt = run(48)
    assert rw["speckle_cells_removed"] > 0
    assert np.array_equal(whole, tiled)
    assert rw["speckle_cells_removed"] == rt["speckle_cells_removed"]
    assert rw["completeness"] == rt["completeness"] and rw["heights"] == rt["heights"]


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    return render(tmp_path_factory.mktemp("pair"), 400, seed=2)


def test_tiles_and_a_coarse_sparse_check_give_the_surface_of_one_tile(pair, tmp_path, monkeypatch):
    """The rendered pair (400², held out from the tuning; the sparse check on a copy half as fine, read from
    2 x 2 averaged source pixels) as one tile, then in tiles of 64 cells: both within 1 GSD RMSE of the terrain
    and 93 % complete, the same heights to a small fraction of a GSD, every point written once."""
    from fotogeo.tools.dsm import dsm, frames, matching
    monkeypatch.setattr(frames, "SPARSE_SIDE", 200)
    runs = {}
    for label in ("one", "tiled"):
        if label == "tiled":
            monkeypatch.setattr(matching, "TILE_CELLS", 64)
        out = tmp_path / f"{label}.tif"
        rep = dsm(pair["images"], out, camera=pair["camera"], eo=pair["eo"], crs=PAIR_CRS,
                  point_cloud=tmp_path / f"{label}.las", report=tmp_path / f"{label}.json")
        with rasterio.open(out) as ds:
            runs[label] = (rep, accuracy(out), ds.read(1, masked=True))
    (r1, a1, h1), (rt, at, ht) = runs["one"], runs["tiled"]
    assert rt["grid"] == r1["grid"] and min(rt["grid"]["width"], rt["grid"]["height"]) > 64  # 2 x 4 tiles
    for rep, acc in ((r1, a1), (rt, at)):
        # the unmatched rim along the images' borders is a larger share of so small a pair than of the blocks'
        assert acc["rmse_m"] <= GSD and rep["completeness"] >= 0.93, (acc, rep["completeness"])
    assert at["rmse_m"] <= 1.1 * a1["rmse_m"] + 0.005
    both = ~h1.mask & ~ht.mask
    assert both.sum() >= 0.97 * (~h1.mask).sum()
    assert np.median(np.abs(h1[both] - ht[both])) <= 0.1 * GSD
    assert abs(rt["points_written"] / r1["points_written"] - 1.0) < 0.03
    assert json.loads((tmp_path / "tiled.json").read_text())["completeness"] == rt["completeness"]
