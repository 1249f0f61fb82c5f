"""``fotogeo triangulate --orthorectify`` writes ``fotogeo ortho``'s orthophotos: the same code
(:func:`fotogeo.tools.ortho.tool.plan_grid`, :func:`fotogeo.tools.ortho.tool.write_orthophoto`), so the same grid, pixels,
nodata, overviews and ``FOTOGEO_NADIR``; a frame partly off the DEM is clipped to it, as ortho clips."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.errors import FotogeoWarning
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.tools.ortho.tool import ortho
from fotogeo.tools.triangulate import triangulate

from test_triangulate_ortho_sigma import RES, _triangulate, block  # noqa: F401 - block: the module's fixture
from test_triangulate import write_block
from test_triangulate_inputs import _write_dem


def _textured(frames):
    """The frames filled with noise in 1..255 (nothing nodata), so that resampled pixels can be compared."""
    rng = np.random.default_rng(3)
    for path in frames:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with rasterio.open(path, "r+") as ds:
                ds.write(rng.integers(1, 256, (ds.count, ds.height, ds.width), dtype=np.uint8))
    return frames


def test_triangulate_orthophoto_is_fotogeo_orthos(tmp_path, block, monkeypatch):  # noqa: F811
    """The orthophoto of a frame equals ``fotogeo ortho``'s from triangulate's own exterior orientation: same
    lattice and size, the same pixels (nearest; the EO file's rounding may move a cell at an edge), the same
    nodata and overviews (down to 64 px here: the outputs are small), the nadir tag under the adjusted projection
    centre."""
    monkeypatch.setattr("fotogeo.io.warp.OVERVIEW_MIN", 64)
    frames = _textured(write_block(tmp_path, block)[0])
    dem = _write_dem(tmp_path / "dem.tif", block)
    rep, out = _triangulate(tmp_path, frames, orthorectify=True, dem=dem)
    name = block.block.frames[2]
    rep2 = ortho([frames[2]], tmp_path / "ortho.tif", dem=dem, camera=tmp_path / "camera.yaml",
                 eo=out / "exterior_orientation.txt", resolution=RES)
    entry, entry2 = rep["orthorectified"][name], rep2["images"][name]
    assert {k: entry[k] for k in ("width", "height", "transform", "dem_coverage")} == \
        {k: entry2[k] for k in ("width", "height", "transform", "dem_coverage")}
    with rasterio.open(out / f"{name}_ortho.tif") as a, rasterio.open(tmp_path / "ortho.tif") as b:
        assert (a.nodata, a.overviews(1), a.compression) == (b.nodata, b.overviews(1), b.compression)
        assert a.overviews(1)
        pa, pb = a.read(), b.read()
        assert np.mean(pa == pb) > 0.999 and np.mean(a.read_masks(1) > 0) > 0.5
        nadir = [float(v) for v in a.tags()["FOTOGEO_NADIR"].split()]
        assert b.tags()["FOTOGEO_NADIR"] == a.tags()["FOTOGEO_NADIR"]
    eo = read_exterior_orientation(out / "exterior_orientation.txt")[name]
    assert nadir == pytest.approx([eo.X, eo.Y], abs=1e-3)  # the projection centre, not its centre pixel's ground


def _west_half_dem(path, full):
    """The DEM ``full`` cut at the median X of its columns' range: only the western half of the block."""
    with rasterio.open(full) as ds:
        z, profile = ds.read(1), ds.profile
    half = z[:, : z.shape[1] // 2]
    profile.update(width=half.shape[1])
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(half[None])
    with rasterio.open(path) as ds:
        return path, ds.bounds.right


def test_frames_partly_off_the_dem_are_clipped_to_it(tmp_path, block):  # noqa: F811
    """A DEM under the western half of the block: a frame it covers in part gets its orthophoto clipped to the
    DEM (nodata east of it, its coverage in the report, a warning naming it) instead of none; a frame wholly off
    it is reported with the reason and has no file."""
    frames = _textured(write_block(tmp_path, block)[0])
    dem, east = _west_half_dem(tmp_path / "west.tif", _write_dem(tmp_path / "dem.tif", block))
    out = tmp_path / "out"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FotogeoWarning)
        rep = triangulate(frames, tmp_path / "camera.yaml", tmp_path / "eo.txt", tmp_path / "tie.csv", out,
                          gcps=tmp_path / "gcp_list.txt", image_sigma=0.3, resolution=RES, orthorectify=True, dem=dem)
    done = rep["orthorectified"]
    partial = [n for n, e in done.items() if "error" not in e and e["dem_coverage"] < 0.999]
    assert partial, done
    assert any("the orthophoto is clipped to the DEM" in str(w.message) for w in caught)
    for n, e in done.items():
        assert (out / f"{n}_ortho.tif").is_file() == ("error" not in e), (n, e)
    for n in partial:
        with rasterio.open(out / f"{n}_ortho.tif") as ds:
            assert ds.bounds.right <= east + RES and ds.bounds.left < east
            valid = ds.read_masks(1) > 0
            assert valid.any() and not valid[:, -1].all()
    assert json.loads((out / "report.json").read_text())["orthorectified"] == done
