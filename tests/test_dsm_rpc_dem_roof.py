"""``fotogeo dsm --rpc --dem`` with a DEM of the ground (a DTM: no buildings, no trees): what stands on it is
one-sided, up, and a margin symmetric about the DEM cut a tall block's top out of the tile's heights
(:attr:`fotogeo.tools.dsm.dem_guide.DemFit.above`)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import rasterio

import rendered_rpc_pair
from fotogeo.tools.dsm import dem_guide, rpc_dem
from test_dsm_rpc_dem import _dem, _setup

SIZE = 256
#: the block at the scene's centre: its side (m), and its roof's height over the scene's highest ground (m)
BLOCK_M, BLOCK_H = 25.0, 40.0


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """The rendered pair (:func:`rendered_rpc_pair.render_rpc_pair`) with a block at its centre, its roof
    ``BLOCK_H`` m over the highest ground; ``ground`` the surface without it, ``roof`` the roof's height."""
    mp = pytest.MonkeyPatch()
    surface = rendered_rpc_pair.surface
    kept = {}

    def with_block(n_cells, cell, seed=0, relief=25.0):
        z, t = surface(n_cells, cell, seed, relief)
        kept["ground"] = z.copy()
        h = int(BLOCK_M / cell / 2)
        c = n_cells // 2
        z[c - h:c + h, c - h:c + h] = z.max() + BLOCK_H
        return z, t
    mp.setattr(rendered_rpc_pair, "surface", with_block)
    try:
        sc = rendered_rpc_pair.render_rpc_pair(tmp_path_factory.mktemp("sat"), SIZE)
    finally:
        mp.undo()
    t = sc["truth_transform"]
    c, r = ~t * tuple(rendered_rpc_pair.CENTRE)
    return {**sc, "ground": kept["ground"], "roof": float(sc["truth"][int(r), int(c)])}


def _ground_dem(sc, path) -> str:
    """The ground without the block averaged onto 20 m cells."""
    return _dem({**sc, "truth": sc["ground"]}, path)


def _pair(sc, monkeypatch, dem, out):
    return _setup(sc, monkeypatch, dem, out)[0]


def _block_tile(sc, m):
    """The tile of left pixels (the pair's ``TILE`` a side at most) around where the block's top is seen, and the
    true heights its pixels see."""
    from rendered_rpc_pair import _first_hit
    cam = sc["cameras"][0]
    x, y = rendered_rpc_pair.CENTRE
    c, r = cam.ground_to_image(np.array([x]), np.array([y]), np.array([sc["roof"]]))
    c, r = float(c[0]), float(r[0])
    tile = (int(max(0, c - 64)), int(max(0, r - 64)), int(min(SIZE, c + 64)), int(min(SIZE, r + 64)))
    col, row = np.meshgrid(np.linspace(tile[0], tile[2], 33), np.linspace(tile[1], tile[3], 33))
    return tile, _first_hit(cam, sc["truth"], sc["truth_transform"], col.ravel(), row.ravel())[2]


def test_a_tall_block_on_a_dem_of_the_ground_keeps_its_top(scene, tmp_path, monkeypatch):
    """A block 40 m over the highest ground, a 20 m DEM of the ground without it: the tile seeing it searches up to
    its top (before: the margin, symmetric about the DEM and bounding the 95th percentile of the tie points'
    departures, stopped the tile's heights 67 m below the roof), and the margin below stays the symmetric one."""
    m = _pair(scene, monkeypatch, _ground_dem(scene, tmp_path / "dem.tif"), tmp_path / "d.tif")
    fit = m.pair.extra["dem"]
    assert fit["guides_strips"], fit
    tile, truth = _block_tile(scene, m)
    assert truth.max() == pytest.approx(scene["roof"], abs=1.0), (truth.max(), scene["roof"])
    lo, hi = rpc_dem.tile_range(m.models[0], m.dem, tile, *m.zlim)
    assert lo < truth.min() and hi > truth.max(), (lo, hi, truth.min(), truth.max(), fit)
    assert m.dem.above > m.dem.margin and fit["margin_above_m"] == pytest.approx(m.dem.above, abs=0.01), fit


def _fit(z):
    """The fit of matches at heights ``z`` over a flat DEM at 0."""
    P = np.column_stack([np.arange(len(z)), np.zeros(len(z)), z])
    return dem_guide.fit(lambda XY: np.zeros(len(XY)), P)


def test_the_margin_above_the_dem_is_the_highest_rise_the_matches_measure():
    """2000 matches on the ground (± 0.5 m) and three on roofs 12-30 m over it: the margin above is the highest roof
    plus the pad; the one below the symmetric bound, which three roofs do not reach."""
    rng = np.random.default_rng(3)
    f = _fit(np.concatenate([rng.normal(0.0, 0.5, 2000), [12.0, 18.0, 30.0]]))
    assert f.rise == pytest.approx(30.0 + f.offset)
    assert f.above == pytest.approx(dem_guide.DEM_PAD_M + 30.0 + f.offset)
    assert f.margin < 10.0 < f.above


def test_from_few_matches_the_rise_reaches_beyond_the_highest():
    """20 matches, five on roofs: the rise bounds a higher roof than the highest of them (the exponential tail of
    :func:`.dem_guide.upper_quantile`), and never less than it."""
    f = _fit(np.array([0.0] * 15 + [4.0, 6.0, 8.0, 10.0, 12.0]))
    assert f.rise > 12.0 - f.offset
    assert f.above == pytest.approx(dem_guide.DEM_PAD_M + f.rise)


def test_the_guided_dsm_keeps_the_blocks_top(scene, tmp_path):
    """The whole run with that DEM: the DSM's cells on the block's roof (its middle, 2 m inside the walls) have
    heights within 1.5 m of the roof's for more than 60 % of them (before: the roof was outside the range of the
    tile seeing it, 8 % of its cells had a height, none that near)."""
    from fotogeo.tools.dsm import dsm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dsm(scene["images"], tmp_path / "d.tif", rpc=True, resolution=0.7, dem=_ground_dem(scene, tmp_path / "g.tif"),
            dem_heights="ellipsoid")
    x, y = rendered_rpc_pair.CENTRE
    half = BLOCK_M / 2 - 2.0
    roof = scene["roof"]
    with rasterio.open(tmp_path / "d.tif") as ds:
        win = ds.window(x - half, y - half, x + half, y + half).round_offsets().round_lengths()
        z = ds.read(1, window=win, masked=True).filled(np.nan).astype(float)
    have = np.isfinite(z)
    assert np.mean(have & (np.abs(np.where(have, z, 0.0) - roof) < 1.5)) > 0.6, (have.mean(), np.nanmedian(z), roof)
