"""``dsm --fill --fill-max-distance``: holes filled no farther than a distance in cells from a matched height, as
``gdal_fillnodata -md`` limits its search in pixels; the cells beyond stay nodata and are not marked filled
(before, every hole inside the hull was filled: NGI cells 8-16 cells from the data came out 92 m RMSE,
``benchmarks/dsm_fill_bench.py``)."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.errors import InputError
from fotogeo.stereo.fusion import fill_holes

CRS = "EPSG:32635"


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    from rendered_pair import render
    return render(tmp_path_factory.mktemp("pair"), 256)


def _ramp_with_hole():
    rows, cols = np.mgrid[0:40, 0:40]
    h = (100 + 0.5 * cols + 0.25 * rows).astype(np.float32)
    h[10:30, 10:30] = np.nan
    return h, rows, cols


@pytest.mark.parametrize("reach", [1.0, 2.5, 4.0])
def test_fill_reaches_exactly_the_cells_within_the_distance(reach):
    """The filled cells are those whose centre is at most ``reach`` cells (Euclidean) from a valid cell's."""
    from scipy import ndimage
    h, rows, cols = _ramp_with_hole()
    out, mask = fill_holes(h, max_distance=reach)
    near = ndimage.distance_transform_edt(np.isnan(h)) <= reach + 1e-9
    assert ((mask == 1) == (np.isnan(h) & near)).all()
    assert np.isnan(out[np.isnan(h) & ~near]).all() and np.isfinite(out[mask == 1]).all()
    err = out[mask == 1] - (100 + 0.5 * cols + 0.25 * rows)[mask == 1]
    assert np.abs(err).max() < 0.5 * reach + 0.5  # a plane rising 0.5 a cell, filled from its own edge


def test_without_a_limit_the_whole_hole_is_filled():
    h, _, _ = _ramp_with_hole()
    out, mask = fill_holes(h)
    assert mask.sum() == 400 and np.isfinite(out).all()


def test_the_dsm_leaves_cells_beyond_the_reach_as_nodata_and_unmarked(pair, tmp_path):
    """Through the tool: band 4 marks only cells within the reach of a matched height; the report states it, and a
    smaller reach fills fewer cells."""
    import rasterio
    from scipy import ndimage

    from fotogeo.tools.dsm import dsm
    kw = dict(camera=pair["camera"], eo=pair["eo"], crs=CRS, fill=True)
    one = dsm(pair["images"], tmp_path / "one.tif", fill_max_distance=1, **kw)
    wide = dsm(pair["images"], tmp_path / "wide.tif", fill_max_distance=64, **kw)
    assert one["fill_max_distance_cells"] == 1 and 0 < one["filled_cells"] < wide["filled_cells"]
    with rasterio.open(tmp_path / "one.tif") as ds:
        h, mask = ds.read(1), ds.read(4)
        matched = (h != ds.nodata) & (mask == 0)
    dist = ndimage.distance_transform_edt(~matched)
    assert (mask == 1).sum() == one["filled_cells"] and dist[mask == 1].max() <= 1.0
    assert (h[(mask == 0) & ~matched] == ds.nodata).all()


def test_the_report_and_console_count_matched_and_filled_cells(pair, tmp_path):
    """The report's cell counts name what they count: ``overlap_cells`` both images see (the old
    ``stereo_cells``), ``matched_cells`` with a matched height in the DSM; the console's DSM line gives the cells
    --fill filled (before: the report only)."""
    import json

    import rasterio
    from click.testing import CliRunner

    from fotogeo.cli import main
    r = CliRunner().invoke(main, ["dsm", *pair["images"], "--camera", str(pair["camera"]), "--eo", str(pair["eo"]),
                                  "--crs", CRS, "--fill", "-o", str(tmp_path / "d.tif"),
                                  "--report", str(tmp_path / "d.json")])
    assert r.exit_code == 0, r.output
    rep = json.loads((tmp_path / "d.json").read_text())
    with rasterio.open(tmp_path / "d.tif") as ds:
        h, mask = ds.read(1), ds.read(4)
    matched = int(((h != ds.nodata) & (mask == 0)).sum())
    assert rep["matched_cells"] == matched and rep["overlap_cells"] == rep["stereo_cells"] > matched
    assert rep["completeness"] == round(matched / rep["overlap_cells"], 4)
    assert 0 < rep["filled_cells"] == int((mask == 1).sum())
    assert f", {rep['filled_cells']} cells filled (--fill) -> " in r.output, r.output


@pytest.mark.parametrize("value", ["0", "65", "-2"])
def test_the_cli_refuses_a_reach_outside_its_range(value, pair, tmp_path):
    from click.testing import CliRunner

    from fotogeo.cli import main
    r = CliRunner().invoke(main, ["dsm", *pair["images"], "--camera", str(pair["camera"]), "--eo", str(pair["eo"]),
                                  "--fill", "--fill-max-distance", value, "-o", str(tmp_path / "d.tif")])
    assert r.exit_code != 0 and "--fill-max-distance must be > 0.0 and <= 64.0" in r.output, r.output
    assert not (tmp_path / "d.tif").exists()


def test_the_tool_refuses_a_reach_outside_its_range(pair, tmp_path):
    from fotogeo.tools.dsm import dsm
    with pytest.raises(InputError, match="fill_max_distance"):
        dsm(pair["images"], tmp_path / "d.tif", camera=pair["camera"], eo=pair["eo"], fill=True,
            fill_max_distance=0)


def test_the_reach_stays_within_the_output_tiles_margin():
    """A reach up to the tiles' margin measures its distances inside the expanded tile, so tiles give the result of
    the whole grid: the option's maximum is that margin."""
    from fotogeo.options.dsm import DSM
    from fotogeo.tools.dsm.outputs import TILE_MARGIN
    assert DSM["fill_max_distance"].maximum == TILE_MARGIN and DSM["fill_max_distance"].default <= TILE_MARGIN


@pytest.mark.parametrize("value", ["2", "4"])
def test_the_cli_refuses_a_reach_without_fill_naming_both_flags(value, tmp_path):
    """``--fill-max-distance`` without ``--fill`` was ignored without a word (the table's default 4 was passed
    either way); now refused before any file is read, even when it is the default."""
    from click.testing import CliRunner

    from fotogeo.cli import main
    r = CliRunner().invoke(main, ["dsm", "a.tif", "b.tif", "--camera", "c.yaml", "--eo", "e.txt",
                                  "--fill-max-distance", value, "-o", str(tmp_path / "d.tif")])
    assert r.exit_code == 2 and r.output.strip() == (
        f"Error: --fill-max-distance {float(value)} acts only with --fill (alone it would be ignored): give both, "
        f"or leave it out"), r.output
    assert "[default: (4.0 with --fill)]" in " ".join(CliRunner().invoke(main, ["dsm", "--help"]).output.split())


def test_the_tool_refuses_a_reach_without_fill_and_fills_to_4_cells_by_default(pair, tmp_path):
    from fotogeo.tools.dsm import dsm
    with pytest.raises(InputError, match=r"^fill_max_distance 2 acts only with fill=True .*leave it out$") as e:
        dsm(pair["images"], tmp_path / "d.tif", camera=pair["camera"], eo=pair["eo"], fill_max_distance=2)
    assert (e.value.option, e.value.also) == ("fill_max_distance", ("fill",)) and not (tmp_path / "d.tif").exists()
    rep = dsm(pair["images"], tmp_path / "d.tif", camera=pair["camera"], eo=pair["eo"], crs=CRS, fill=True)
    assert rep["fill_max_distance_cells"] == 4.0
