"""``fotogeo dsm`` with frames and a DEM whose voids cover the high ground: the pairs search the heights their
sparse matches give as well as the DEM's valid ones (:func:`fotogeo.tools.dsm.plan.with_matches`), so the ground
above the DEM's highest valid height still gets heights."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio

from fotogeo.tools.dsm import dsm

from dsm_scenes import make_scene, write_dem


@pytest.fixture(scope="module")
def nadir(tmp_path_factory):
    return make_scene("nadir", tmp_path_factory.mktemp("nadir"))


def _high_voided(sc, path, share: float):
    """A 20 m DEM of the scene's true surface with its cells above the ``share`` quantile of its heights under the
    frames' centres ± 400 m nodata (an SRTM-like void over the peaks); returns the path and that height."""
    write_dem(sc, path, cell=20.0)
    with rasterio.open(path, "r+") as ds:
        z = ds.read(1).astype(float)
        t = ds.transform
        rows, cols = np.indices(z.shape)
        X, Y = t.c + (cols + 0.5) * t.a, t.f + (rows + 0.5) * t.e
        xy = np.array([[float(v) for v in line.split()[1:3]] for line in open(sc["eo"]) if line.strip()
                       and not line.startswith("#")])
        near = ((X > xy[:, 0].min() - 400) & (X < xy[:, 0].max() + 400) & (Y > xy[:, 1].min() - 400)
                & (Y < xy[:, 1].max() + 400))
        cut = float(np.quantile(z[near], share))
        ds.nodata = -9999.0
        ds.write(np.where(z > cut, -9999.0, z).astype(np.float32), 1)
    return str(path), cut


def test_ground_above_the_dems_void_gets_heights(nadir, tmp_path):
    """Before: each pair searched the DEM's valid heights plus a padding only, so the DSM had no height above
    them (3 % of the cells above that range, at its edge); the matches' heights now reach them, as they do for RPC
    pairs (36 %: as many as without a DEM, where the matches give every height), and those heights are right."""
    dem, cut = _high_voided(nadir, tmp_path / "dem.tif", 0.6)
    out = tmp_path / "dsm.tif"
    rep = dsm(nadir["images"][:3], out, camera=nadir["camera"], eo=nadir["eo"], crs=nadir["crs"], dem=dem,
              qgis_style=False)
    with rasterio.open(out) as ds:
        h, t, nod = ds.read(1).astype(float), ds.transform, ds.nodata
    rows, cols = np.indices(h.shape)
    XY = np.column_stack([(t.c + (cols + 0.5) * t.a).ravel(), (t.f + (rows + 0.5) * t.e).ravel()])
    truth = nadir["surface"](XY).reshape(h.shape)
    seen = h != nod
    high = truth > rep["height_search_range"][1]  # above the run's range from the DEM (its valid heights, padded)
    assert high.sum() > 50, high.sum()
    assert seen[high].mean() > 0.25, seen[high].mean()
    assert np.median(np.abs(h[high & seen] - truth[high & seen])) < 2.0


def test_a_lone_mismatch_among_a_few_dozen_matches_does_not_widen_a_dems_range():
    """Beyond the DEM's heights only heights that neighbouring matches support are searched: one match 800 m above
    ground at 100 ± 2 m among 25 widened [82, 117] to [-221, 1025] (review 3); a supported rise still does."""
    import numpy as np
    from fotogeo.tools.dsm.plan import with_matches
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 500, (25, 2))
    z = 100 + rng.normal(0, 2, 25)
    z[0] = 900.0
    lo, hi = with_matches({"n": 25, "points": np.column_stack([xy, z])}, (95.0, 105.0), 3000.0, 20)
    assert lo >= 85 and hi <= 120, (lo, hi)
    z[1:6] = 160 + rng.normal(0, 0.5, 5)  # a hill the DEM's void hides: five neighbouring matches on it
    xy[1:6] = xy[1] + rng.uniform(-5, 5, (5, 2))
    lo, hi = with_matches({"n": 25, "points": np.column_stack([xy, z])}, (95.0, 105.0), 3000.0, 20)
    assert 165 <= hi <= 175, (lo, hi)
