"""An RPC pair's tile keeps all its pixels whatever the heights it searches (issue 30): the rectified window's
margin before the tile is the disparity range's width (:func:`fotogeo.tools.dsm.rpc_pairs.window_margins`), so a
range whose terrain lies near one end (a DEM's: a few metres below the ground, the rise above it) no longer cut the
tile's last columns out of the left–right check; and a true DEM gives the DSM no fewer cells than none."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.tools.dsm import rpc_pairs as rp

from rendered_rpc_pair import render_rpc_pair
from test_dsm_rpc_dem import _dem, _setup

SIZE = 256


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return render_rpc_pair(tmp_path_factory.mktemp("sat"), SIZE)


#: a tile inside the images: the window around it has ground on every side
TILE = (64, 64, 192, 192)


def _matched(m, zlo, zhi):
    """The left pixels of ``TILE`` matched within the heights ``[zlo, zhi]``."""
    return rp.match_tile(*m.models, m.tau, m.sources, TILE, zlo, zhi, {})[0]


def test_a_range_near_the_ground_keeps_the_tiles_last_columns(scene, tmp_path, monkeypatch):
    """The same tile matched within 300 m centred on the ground and within 300 m from 10 m under it (or down from
    10 m over it): those match as many pixels (within 2 %), and as many in each tenth of the tile along its sides
    (before: the window's margin, the range's larger end, fell ~75 px short of the range's width on the side where
    the ground's disparities lay near the range's high end — which side depends on the rectification's sign — and
    the pixels there lost the right-to-left pass)."""
    m = _setup(scene, monkeypatch, None, tmp_path / "d.tif")[0]
    z0, z1 = float(np.nanmin(scene["truth"])), float(np.nanmax(scene["truth"]))
    mid = 0.5 * (z0 + z1)
    centred = _matched(m, mid - 150.0, mid + 150.0)
    side = TILE[2] - TILE[0]
    for zlo, zhi in ((z0 - 10.0, z0 + 290.0), (z1 - 290.0, z1 + 10.0)):
        near = _matched(m, zlo, zhi)
        assert len(near) >= 0.98 * len(centred), (zlo, zhi, len(near), len(centred))
        for axis in (0, 1):
            for edge in ((TILE[axis], TILE[axis] + 0.1 * side), (TILE[axis + 2] - 0.1 * side, TILE[axis + 2])):
                n_c = int(((centred[:, axis] >= edge[0]) & (centred[:, axis] < edge[1])).sum())
                n_n = int(((near[:, axis] >= edge[0]) & (near[:, axis] < edge[1])).sum())
                assert n_n >= 0.95 * n_c, (zlo, zhi, axis, edge, n_n, n_c)


def _completeness(path) -> float:
    with rasterio.open(path) as ds:
        return float((~ds.read(1, masked=True).mask).mean())


def test_a_true_dem_gives_no_fewer_cells_than_none(scene, tmp_path):
    """The truth averaged onto 20 m cells as ``--dem``: the DSM has a height in as many cells as without a DEM
    (within 0.5 %; before: 4 % fewer on a 700² pair, the ground at the low end of each tile's range)."""
    from fotogeo.tools.dsm import dsm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dsm(scene["images"], tmp_path / "none.tif", rpc=True, resolution=0.7)
        dsm(scene["images"], tmp_path / "true.tif", rpc=True, resolution=0.7, dem=_dem(scene, tmp_path / "dem.tif"),
            dem_heights="ellipsoid")
    with_dem, without = _completeness(tmp_path / "true.tif"), _completeness(tmp_path / "none.tif")
    assert with_dem >= without - 0.005, (with_dem, without)
