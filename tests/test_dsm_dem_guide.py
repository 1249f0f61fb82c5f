"""``fotogeo dsm --dem``: a coarse DEM guides each strip (:mod:`fotogeo.tools.dsm.dem_guide`) — the heights it
expects and searches — after it has been fitted to the pair's sparse matches: an offset DEM (another vertical
reference) is named and used shifted, one that disagrees with the images is named and not followed, and where it
has voids the matches' heights take over."""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.errors import FotogeoWarning
from fotogeo.options.dsm import DSM
from fotogeo.tools.dsm import dem_guide, local

from dsm_scenes import make_scene, write_dem
from test_dsm_partnerless import _pair_match


@pytest.fixture(scope="module")
def nadir(tmp_path_factory):
    return make_scene("nadir", tmp_path_factory.mktemp("nadir"))


def _degraded(sc, path, *, offset=0.0, noise=0.0, void=False, cell=20.0):
    """The scene's true surface as a ``cell`` m DEM, ``offset`` m higher, with Gaussian ``noise`` (m) per cell and
    with ``void``, its middle third nodata."""
    write_dem(sc, path, cell=cell)
    with rasterio.open(path, "r+") as ds:
        z = ds.read(1).astype(float) + offset + np.random.default_rng(5).normal(0, noise or 1e-9, (ds.height, ds.width))
        if void:
            ds.nodata = -9999.0
            h, w = z.shape
            z[h // 3:2 * h // 3, w // 3:2 * w // 3] = -9999.0
        ds.write(z.astype(np.float32), 1)
    return str(path)


def _setup(sc, monkeypatch, dem):
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        m, grid = _pair_match_first(sc, monkeypatch, dem)
    return m, grid, [str(w.message) for w in got if issubclass(w.category, FotogeoWarning)]


def _pair_match_first(sc, monkeypatch, dem):
    """The first kept pair's :class:`~fotogeo.tools.dsm.matching.PairMatch` (two frames of the scene's first strip)."""
    two = {**sc, "images": sc["images"][:2]}
    return _pair_match(two, monkeypatch, dem=dem)


def _truth_on_rays(m, u, v, surface):
    """The true height where the rays of rectified left pixels ``(u, v)`` meet ``surface`` (bisection)."""
    d = m.rp.rays(u.ravel(), v.ravel(), 0)
    C = m.rp.centres[0]
    lo, hi = np.full(len(d), -500.0), np.full(len(d), C[2] - 1.0)
    for _ in range(60):
        z = 0.5 * (lo + hi)
        P = C + ((z - C[2]) / d[:, 2])[:, None] * d
        above = z > surface(P[:, :2])
        hi, lo = np.where(above, z, hi), np.where(above, lo, z)
    return 0.5 * (lo + hi)


def test_an_offset_dem_is_named_and_followed_shifted(nadir, tmp_path, monkeypatch):
    """A 20 m DEM of the true surface 50 m too high (geoid vs ellipsoid heights): named with the fix, and its
    heights used shifted by the offset measured at the sparse matches (before: followed silently, 50 m off, each
    strip searching the DEM's whole range)."""
    m, grid, said = _setup(nadir, monkeypatch, _degraded(nadir, tmp_path / "dem.tif", offset=50.0))
    assert any("+50.0 m" in s and "--dem-heights" in s for s in said), said
    named = {f for s in said for f in re.findall(r"--[a-z][a-z-]*", s)}
    assert named <= {o.cli_flag for o in DSM.values()}, named  # before: --geoid, which dsm did not have
    assert m.dem is not None and abs(m.dem.fitted.offset - 50.0) < 1.0
    assert m.pair.extra["dem"]["guides_strips"]
    u0, v0, u1, v1 = m.box(grid)
    u, v = np.meshgrid(np.linspace(u0 + 20, u1 - 20, 12), np.linspace(v0 + 20, v1 - 20, 12))
    z, _, _ = local._on_dem(m.rp, m.near, m.dem, u.ravel(), v.ravel())
    truth = _truth_on_rays(m, u, v, nadir["surface"])
    ok = np.isfinite(z)
    assert ok.mean() > 0.9 and np.median(np.abs(z[ok] - truth[ok])) < 2.0
    # each strip's heights bracket the truth under it and are narrower than the pair's
    box = (u0, v0, u1, min(v1, v0 + 384))
    lo, hi = local.local_heights(m.near, box, m.rp, m.dem)
    under = _truth_on_rays(m, *np.meshgrid(np.linspace(u0, u1, 20), np.linspace(box[1], box[3], 8)),
                           nadir["surface"])
    assert lo < under.min() and hi > under.max()
    assert hi - lo < m.zlim[1] - m.zlim[0]


def test_a_dem_of_other_ground_is_named_and_not_followed(nadir, tmp_path, monkeypatch):
    """A DEM whose cells scatter by 60 m about the surface (another place, another time): named, and the pair's
    strips take their heights from the sparse matches (before: followed without a word)."""
    m, _, said = _setup(nadir, monkeypatch, _degraded(nadir, tmp_path / "dem.tif", noise=60.0))
    assert any("disagree" in s and "NMAD" in s for s in said), said
    assert m.dem is None and m.local and m.near is not None
    assert not m.pair.extra["dem"]["guides_strips"]


def test_where_the_dem_has_a_void_the_matches_give_the_heights(nadir, tmp_path, monkeypatch):
    """A DEM with its middle third nodata: the nodes over the void take the nearest matches' heights, every pixel
    still has an expected disparity, and the strip's range is bounded."""
    m, grid, _ = _setup(nadir, monkeypatch, _degraded(nadir, tmp_path / "dem.tif", void=True))
    assert m.dem is not None
    u0, v0, u1, v1 = m.box(grid)
    u, v = np.meshgrid(np.arange(u0, u1, 16.0), np.arange(v0, v1, 16.0))
    zd, _, zm = local._on_dem(m.rp, m.near, m.dem, u.ravel(), v.ravel())
    assert np.isnan(zd).any() and np.isfinite(zm).all()
    g = local.expected_disparity(m.rp, m.near, (v0, v1), (u0, u1), m.dem)
    assert np.isfinite(g).all()
    lo, hi, is_local = local.local_range(m.rp, m.near, (u0, v0, u1, v1), *m.drange, m.dem)
    assert is_local and m.drange[0] <= lo < hi <= m.drange[1]


def test_a_dem_void_under_every_match_is_named_and_guides_nothing(nadir, tmp_path):
    """A pair with 30 sparse matches, all over the DEM's void: the DEM guides nothing there (``dem``: 0 matches, not
    guiding; the pair's strips take the matches' heights as without a DEM) and the void is named (before: left to
    the matches without a word; a benchmark row only)."""
    from types import SimpleNamespace
    from fotogeo.tools.dsm import tool
    from fotogeo.tools.ortho.inputs import image_models, terrain
    ims = image_models(nadir["images"][:2], nadir["crs"], camera=nadir["camera"], eo=nadir["eo"])
    source, _, _ = terrain(_degraded(nadir, tmp_path / "dem.tif", void=True), None, nadir["crs"], ims)
    with rasterio.open(tmp_path / "dem.tif") as ds:  # the void: the middle third of the DEM
        mid = np.array([(ds.bounds.left + ds.bounds.right) / 2, (ds.bounds.bottom + ds.bounds.top) / 2])
    rng = np.random.default_rng(2)
    sp = {"n": 30, "points": np.column_stack([mid + rng.uniform(-100, 100, (30, 2)), np.full(30, 100.0)])}
    p = SimpleNamespace(i=0, j=1, extra={})
    assert tool._pair_dem(p, sp, (source, None, 20.0), ims, 0.0, 200.0, 1e9) is None
    assert p.extra["dem"] == {"matches": 0, "guides_strips": False}
    with pytest.warns(FotogeoWarning, match=r"fewer than 20 of the 30 sparse matches of a-b.*does not cover"):
        tool._warn_dem("dem.tif", [("a-b", p.extra["dem"], 30)])


def test_the_fit_measures_offset_spread_and_margin():
    """The fit's equations (:func:`fotogeo.tools.dsm.dem_guide.fit`) on a plane and a DEM 12 m above it with
    ±3 m of error: offset 12, NMAD about 3 (1.4826 · median), margin ``DEM_PAD_M + 1.5 · P95``."""
    from fotogeo.geometry.dem import Dem
    from rasterio.transform import from_origin
    rng = np.random.default_rng(1)
    P = np.column_stack([rng.uniform(0, 1000, (400, 2)), np.zeros(400)])
    P[:, 2] = 100.0 + 0.05 * P[:, 0]
    X, Y = np.meshgrid(np.arange(0, 1000, 10.0) + 5, 1000 - np.arange(0, 1000, 10.0) - 5)
    Z = 112.0 + 0.05 * X + rng.normal(0, 3.0, X.shape)
    f = dem_guide.fit(Dem(Z, from_origin(0, 1000, 10, 10)), P)
    assert abs(f.offset - 12.0) < 0.7 and 1.0 < f.spread < 3.5 and f.matches > 350  # (bilinear: under 3)
    assert dem_guide.DEM_PAD_M + 5.0 < f.margin < dem_guide.DEM_PAD_M + 12.0
    assert dem_guide.problems(f, "a-b") and "+11.9 m" in dem_guide.problems(f, "a-b")[0]
    assert dem_guide.fit(Dem(Z, from_origin(5000, 1000, 10, 10)), P) is None  # no match on it


def test_geoid_undulations_make_a_geoid_dem_ellipsoidal(nadir, tmp_path, monkeypatch):
    """``--geoid`` (ortho's option, now dsm's too): a DEM of the true surface declared geoid heights, with
    undulations N = −30 m, is used as H + N, so the fit measures a −30 m offset (before: dsm had no --geoid, yet
    its DEM warning and ortho's refusal of a geoid DEM named it)."""
    dem = _degraded(nadir, tmp_path / "dem.tif")
    with rasterio.open(dem) as ds:
        profile, shape = ds.profile, ds.shape
    with rasterio.open(tmp_path / "n.tif", "w", **profile) as ds:
        ds.write(np.full(shape, -30.0, np.float32), 1)
    two = {**nadir, "images": nadir["images"][:2]}
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        m, _ = _pair_match(two, monkeypatch, dem=dem, dem_heights="geoid", geoid=str(tmp_path / "n.tif"))
    assert abs(m.dem.fitted.offset + 30.0) < 1.0
    said = [str(w.message) for w in got if issubclass(w.category, FotogeoWarning)]
    assert any(re.search(r"lie -3\d\.\d m", s) and "--geoid" in s for s in said), said


def test_a_pair_no_match_measured_guides_unchecked_is_named_and_searches_the_runs_padding(nadir, tmp_path):
    """A pair with fewer than 20 sparse matches and no fit of the run: its DEM is searched ± the larger of 30 m
    and the run's padding of the DEM's range, and named (before: ± 30 m, without a word)."""
    from types import SimpleNamespace
    from fotogeo.tools.dsm import tool
    from fotogeo.tools.ortho.inputs import image_models, terrain
    ims = image_models(nadir["images"][:2], nadir["crs"], camera=nadir["camera"], eo=nadir["eo"])
    source, _, _ = terrain(_degraded(nadir, tmp_path / "dem.tif"), None, nadir["crs"], ims)
    p = SimpleNamespace(i=0, j=1, extra={})
    sp = {"n": 7, "points": np.zeros((7, 3)) + [0.0, 0.0, 1e6]}  # none plausible: nothing measures the DEM
    g = tool._pair_dem(p, sp, (source, None, 80.0), ims, 0.0, 200.0, 1e9)
    assert g is not None and g.margin == 80.0 and p.extra["dem"]["matches"] == 0
    with pytest.warns(FotogeoWarning, match=r"not checked for pair a-b \(7 sparse matches.*± 80 m"):
        tool._warn_dem("dem.tif", [("a-b", p.extra["dem"], 7)])


def test_a_dem_all_void_under_a_pair_starts_no_node_and_says_nothing():
    """A pair's DEM grid all nodata: the nodes have no DEM height (NaN), without numpy's "All-NaN slice" warning
    (before: raised under -W error)."""
    from fotogeo.geometry.dem import Dem
    from rasterio.transform import from_origin

    class Nadir:  # a camera 100 m up looking down
        centres = [np.array([50.0, 50.0, 100.0])]

        def rays(self, u, v, k):
            return np.column_stack([np.zeros(len(u)), np.zeros(len(u)), -np.ones(len(u))])

    g = dem_guide.DemGuide(Dem(np.full((4, 4), np.nan), from_origin(0, 100, 25, 25)), dem_guide.DemFit(0, 0, 30, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        z, _, zm = local._on_dem(Nadir(), None, g, np.array([1.0, 2.0]), np.array([1.0, 2.0]))
    assert np.isnan(z).all() and np.isnan(zm).all()
