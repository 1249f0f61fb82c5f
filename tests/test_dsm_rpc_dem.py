"""``fotogeo dsm --rpc --dem``: the DEM guides each tile of a satellite pair through :mod:`fotogeo.tools.dsm.dem_guide`
(:mod:`fotogeo.tools.dsm.rpc_dem`), after it has been fitted to the pair's tie points: an offset DEM (geoid heights
read as ellipsoidal) is named with the fix and used shifted, a DEM beside the pair is named and guides nothing."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine

from fotogeo.errors import FotogeoWarning
from fotogeo.tools.dsm import matching, rpc_dem

from rendered_rpc_pair import _first_hit, render_rpc_pair

SIZE = 256


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return render_rpc_pair(tmp_path_factory.mktemp("sat"), SIZE)


def _dem(sc, path, *, offset=0.0, void=False, cell=20.0) -> str:
    """The truth averaged onto ``cell`` m cells (a coarse DEM), ``offset`` m higher; ``void``: nodata but for a
    ring of two cells around it."""
    t = sc["truth_transform"]
    k = int(round(cell / t.a))
    z = sc["truth"]
    n = (z.shape[0] // k, z.shape[1] // k)
    z = z[:n[0] * k, :n[1] * k].reshape(n[0], k, n[1], k).mean(axis=(1, 3)) + offset
    if void:
        z[2:-2, 2:-2] = -9999.0
    with rasterio.open(path, "w", driver="GTiff", width=n[1], height=n[0], count=1, dtype="float32", crs=sc["crs"],
                       transform=t * Affine.scale(k), nodata=-9999.0) as ds:
        ds.write(z.astype(np.float32)[None])
    return str(path)


class _Stop(Exception):
    pass


def _setup(sc, monkeypatch, dem, out):
    """The pair's :class:`~fotogeo.tools.dsm.rpc_pairs.RpcPairMatch` (stopped before matching) and the warnings."""
    from fotogeo.tools.dsm import dsm
    got = {}

    def capture(grid, matches, *a, **k):
        got.update(matches=matches)
        raise _Stop
    monkeypatch.setattr(matching, "match_tiles", capture)
    with warnings.catch_warnings(record=True) as said, pytest.raises(_Stop):
        warnings.simplefilter("always")
        dsm(sc["images"], out, rpc=True, resolution=0.7, dem=dem, dem_heights="ellipsoid")
    (m,) = got["matches"]
    return m, [str(w.message) for w in said if issubclass(w.category, FotogeoWarning)]


def _truth_under(sc, tile):
    """The true heights the left pixels of ``tile`` see."""
    col, row = np.meshgrid(np.linspace(tile[0], tile[2], 25), np.linspace(tile[1], tile[3], 25))
    return _first_hit(sc["cameras"][0], sc["truth"], sc["truth_transform"], col.ravel(), row.ravel())[2]


TILE = (64, 64, 192, 192)


def test_each_tile_searches_the_dems_heights_under_it(scene, tmp_path, monkeypatch):
    """A 20 m DEM of the truth: fitted at the tie points (offset ~0, guides), and a tile's heights bracket the
    true heights its pixels see while searching less than the pair's range (before: every tile searched the pair's
    whole range, the DEM's extremes ± 10 % and 30 m)."""
    m, said = _setup(scene, monkeypatch, _dem(scene, tmp_path / "dem.tif"), tmp_path / "d.tif")
    fit = m.pair.extra["dem"]
    assert fit["guides_strips"] and abs(fit["offset_m"]) < 1.0 and fit["matches"] >= 20, fit
    assert not [s for s in said if "(--dem)" in s], said
    lo, hi = rpc_dem.tile_range(m.models[0], m.dem, TILE, *m.zlim)
    truth = _truth_under(scene, TILE)
    assert lo < truth.min() and hi > truth.max(), (lo, hi, truth.min(), truth.max())
    assert hi - lo < 0.8 * (m.zlim[1] - m.zlim[0]), (lo, hi, m.zlim)


def test_a_dem_50_m_off_is_named_with_the_fix_and_used_shifted(scene, tmp_path, monkeypatch):
    """The DEM 50 m too high (EGM96 heights read as ellipsoidal, ~50 m at Ventoux): named with the fix
    (--dem-heights, --geoid, or the RPCs' pointing: rpc-bias) and used shifted by the offset the tie points
    measure: the pair's and the tile's heights still hold the truth (before: "the RPCs' absolute pointing is off"
    only, and the DEM's range, padded by 10 % and 30 m, cut off the heights 50 m below it)."""
    m, said = _setup(scene, monkeypatch, _dem(scene, tmp_path / "dem.tif", offset=50.0), tmp_path / "d.tif")
    named = [s for s in said if "(--dem)" in s and "+50" in s]
    assert named and all(f in named[0] for f in ("--dem-heights", "--geoid", "rpc-bias")), said
    fit = m.pair.extra["dem"]
    assert fit["guides_strips"] and fit["offset_m"] == pytest.approx(50.0, abs=1.5), fit
    truth = scene["truth"]
    assert m.zlim[0] < truth.min() and m.zlim[1] > truth.max(), (m.zlim, truth.min(), truth.max())
    lo, hi = rpc_dem.tile_range(m.models[0], m.dem, TILE, *m.zlim)
    under = _truth_under(scene, TILE)
    assert lo < under.min() and hi > under.max(), (lo, hi, under.min(), under.max())


def test_a_dem_void_under_the_pair_is_named_and_guides_nothing(scene, tmp_path, monkeypatch):
    """A DEM void under all the tie points (heights only on a ring around the scene): named, and the pair searches
    the tie points' heights as without a DEM (before: nothing said, the DEM's range searched)."""
    m, said = _setup(scene, monkeypatch, _dem(scene, tmp_path / "dem.tif", void=True), tmp_path / "d.tif")
    assert m.dem is None and m.pair.extra["dem"] == {"matches": 0, "guides_strips": False}
    assert any("(--dem)" in s and "does not cover" in s for s in said), said


def test_a_dem_the_few_tie_points_cannot_check_guides_nothing(scene, tmp_path, monkeypatch):
    """A pair with 15 tie points (10 are enough for its pointing, 20 check a DEM) and a DEM 50 m high: unchecked, the
    DEM is named as not used for that pair and guides no tile, whose heights are the tie points' and hold the truth
    (before: it guided every tile unchecked ± 41 m, and the tile searched 835.8-980.6 m over a true 817.1-890.6 m)."""
    from fotogeo.tools.dsm import rpc_pairs
    pointing = rpc_pairs.pointing

    def few(*a, **k):
        pt = pointing(*a, **k)
        keep = {key: v[:15] for key, v in pt.items() if key in ("z", "p1")}
        return {**pt, **keep, "n": 15}
    monkeypatch.setattr(rpc_pairs, "pointing", few)
    m, said = _setup(scene, monkeypatch, _dem(scene, tmp_path / "dem.tif", offset=50.0), tmp_path / "d.tif")
    assert m.dem is None and m.pair.extra["dem"] == {"matches": 0, "guides_strips": False}, m.pair.extra["dem"]
    named = [s for s in said if "(--dem)" in s and "sim_a-sim_b has 15" in s and "not used" in s]
    assert named, said
    under = _truth_under(scene, TILE)
    assert m.zlim[0] < under.min() and m.zlim[1] > under.max(), (m.zlim, under.min(), under.max())
