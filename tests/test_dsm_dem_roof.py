"""``fotogeo dsm --dem`` on a frame pair with a DEM of the ground (a DTM: no buildings): what stands on it rises
over it, and a margin symmetric about the DEM cut a block's roof out of the strips' heights and the pair's range;
frame pairs now search above the DEM as RPC tiles do (:meth:`fotogeo.tools.dsm.dem_guide.DemGuide.span`)."""
from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import rasterio

from fotogeo.tools.dsm import local

from dsm_scenes import BLOCK, BLOCK_RELIEF, NARROW_BLOCK, make_scene, write_dem
from test_dsm_partnerless import _pair_match

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """The rendered ``nadir_block`` pair (a block :data:`dsm_scenes.BLOCK` on gentle ground) and a 20 m DEM of the
    ground without the block."""
    folder = tmp_path_factory.mktemp("block")
    sc = make_scene("nadir_block", folder)
    return {**sc, "dem": str(write_dem({**sc, "surface": sc["surface"].ground}, folder / "ground.tif"))}


def test_a_strip_over_a_block_searches_up_to_its_roof(scene, monkeypatch):
    """The block stands higher over the DEM than the symmetric margin: the strip seeing it searches up to its roof
    and past it (before: the DEM's heights ± the margin stopped under the roof), the pair's heights reach it too,
    and below the DEM the margin stays the symmetric one."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m, grid = _pair_match(scene, monkeypatch, dem=scene["dem"])
    roof, ground = scene["surface"].roof, scene["surface"].ground
    assert m.dem is not None and m.dem.margin < BLOCK[1] < m.dem.above  # the symmetric margin does not reach it
    u, v = m.rp.project(np.array([[*scene["surface"].centre, roof]]), 0)[0]
    u0, _, u1, _ = m.box(grid)
    box = (u0, v - 100, u1, v + 100)
    lo, hi = local.local_heights(m.near, box, m.rp, m.dem)
    under = ground(np.array([scene["surface"].centre]))[0]
    assert hi > roof + 1.0, (lo, hi, roof, under)
    # below: the margin under the strip's lowest ground (the ground's hills are ± BLOCK_RELIEF m), not widened
    assert under - 2 * BLOCK_RELIEF - m.dem.margin - 1.0 < lo < under - m.dem.margin + 1.0, (lo, under, m.dem.margin)
    assert m.zlim[1] > roof + 1.0, m.zlim
    assert m.pair.extra["dem"]["margin_above_m"] == pytest.approx(m.dem.above, abs=0.01)


def test_the_guided_dsm_of_a_frame_pair_keeps_the_roof(scene, tmp_path):
    """The whole run with the DEM of the ground: more than 60 % of the roof's cells (2 m inside its walls) are within
    1.5 m of its height (before: none), and the ground around keeps its error."""
    from fotogeo.tools.dsm import dsm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dsm(scene["images"], tmp_path / "d.tif", camera=scene["camera"], eo=scene["eo"], crs=scene["crs"],
            dem=scene["dem"])
    assert _roof_share(tmp_path / "d.tif", scene["surface"]) > 0.6


def _roof_cells(path, surface) -> np.ndarray:
    """The DSM ``path``'s heights on the block's roof cells (2 m inside its walls), NaN where it has none."""
    half = surface.side / 2 - 2.0
    with rasterio.open(path) as ds:
        win = ds.window(surface.centre[0] - half, surface.centre[1] - half, surface.centre[0] + half,
                        surface.centre[1] + half)
        return ds.read(1, window=win.round_offsets().round_lengths(), masked=True).filled(np.nan).astype(float)


def _roof_share(path, surface) -> float:
    """The share of the block's roof cells (2 m inside its walls) in the DSM ``path`` within 1.5 m of its height."""
    z = _roof_cells(path, surface)
    have = np.isfinite(z)
    return float(np.mean(have & (np.abs(np.where(have, z, 0.0) - surface.roof) < 1.5)))


@pytest.fixture(scope="module")
def narrow(tmp_path_factory):
    """The rendered ``nadir_narrow_block`` pair (a block :data:`dsm_scenes.NARROW_BLOCK`, narrower than it is high)
    and a 20 m DEM of the ground without the block."""
    folder = tmp_path_factory.mktemp("narrow")
    sc = make_scene("nadir_narrow_block", folder)
    return {**sc, "dem": str(write_dem({**sc, "surface": sc["surface"].ground}, folder / "ground.tif"))}


@pytest.mark.parametrize("with_dem", [True, False], ids=["dem", "no-dem"])
def test_a_narrow_roof_gets_no_wrong_height(narrow, tmp_path, with_dem):
    """A roof narrower than its disparity step to the ground: SGM's costs there have no clear minimum. Its cells
    are holes or its height, never a plausible height between roof and ground (before: with the DEM of the ground
    two thirds of its cells, without one a third, at heights down to the ground's)."""
    from fotogeo.tools.dsm import dsm
    assert NARROW_BLOCK[0] < NARROW_BLOCK[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dsm(narrow["images"], tmp_path / "d.tif", camera=narrow["camera"], eo=narrow["eo"], crs=narrow["crs"],
            dem=narrow["dem"] if with_dem else None)
    z = _roof_cells(tmp_path / "d.tif", narrow["surface"])
    have = np.isfinite(z)
    off = have & (np.abs(np.where(have, z, 0.0) - narrow["surface"].roof) >= 1.5)
    assert z.size >= 16 and off.mean() <= 0.05, (off.mean(), z[off] - narrow["surface"].roof)


def test_without_a_dem_the_small_roof_is_kept(scene, tmp_path):
    """No DEM: the block covers a small share of the overlap and carries as small a share of the sparse matches; the
    pair's heights reach its roof (its matches support one another) and more than 60 % of the roof's cells are
    within 1.5 m of it (before: the matches' 99th percentile, padded, stopped under the roof: none)."""
    from fotogeo.tools.dsm import dsm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = dsm(scene["images"], tmp_path / "d.tif", camera=scene["camera"], eo=scene["eo"], crs=scene["crs"])
    pair = next(p for p in rep["pairs"] if p["kept"])
    assert pair["height_range"][1] > scene["surface"].roof + 1.0, pair["height_range"]
    assert _roof_share(tmp_path / "d.tif", scene["surface"]) > 0.6


@pytest.mark.parametrize("ties", ["0", "-3"])
def test_the_dem_benchmark_refuses_too_few_tie_points_in_one_line(ties):
    """``benchmarks/dsm_dem_bench.py --ties 0`` (before: silently all of them) and ``--ties -3`` (before: a
    traceback): one line naming the option and what to give."""
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "dsm_dem_bench.py"), "--ties", ties],
                       capture_output=True, text=True, timeout=120)
    last = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert f"--ties {ties}" in last and "--ties 10 or more" in last, last
