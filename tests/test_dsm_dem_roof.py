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

from dsm_scenes import BLOCK, BLOCK_RELIEF, make_scene, write_dem
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
    s = scene["surface"]
    half = s.side / 2 - 2.0
    with rasterio.open(tmp_path / "d.tif") as ds:
        win = ds.window(s.centre[0] - half, s.centre[1] - half, s.centre[0] + half, s.centre[1] + half)
        z = ds.read(1, window=win.round_offsets().round_lengths(), masked=True).filled(np.nan).astype(float)
    have = np.isfinite(z)
    assert np.mean(have & (np.abs(np.where(have, z, 0.0) - s.roof) < 1.5)) > 0.6, (have.mean(), np.nanmedian(z))


@pytest.mark.parametrize("ties", ["0", "-3"])
def test_the_dem_benchmark_refuses_too_few_tie_points_in_one_line(ties):
    """``benchmarks/dsm_dem_bench.py --ties 0`` (before: silently all of them) and ``--ties -3`` (before: a
    traceback): one line naming the option and what to give."""
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "dsm_dem_bench.py"), "--ties", ties],
                       capture_output=True, text=True, timeout=120)
    last = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert f"--ties {ties}" in last and "--ties 10 or more" in last, last
