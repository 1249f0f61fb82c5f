"""``fotogeo triangulate … --dsm DSM.tif``: the surface model of the adjusted frames, made by fotogeo dsm's
pipeline, where the user said; a DSM that cannot be made leaves the adjustment's outputs and says why."""
from __future__ import annotations

import json
import warnings

import pytest

from fotogeo.errors import OutputError

from rendered_pair import CRS, GSD, accuracy, render


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    return render(tmp_path_factory.mktemp("pair"), 400, seed=4)


def _triangulate(pair, folder, **kw):
    from fotogeo.tools.triangulate import triangulate
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rep = triangulate(pair["images"], pair["camera"], pair["eo"], None, folder, crs=CRS, eo_sigma_position=0.05,
                          eo_sigma_angle=0.01, **kw)
    return rep, [str(w.message) for w in caught]


def test_triangulate_writes_the_dsm_of_the_adjusted_frames(pair, tmp_path):
    out = tmp_path / "surface" / "dsm.tif"
    out.parent.mkdir()
    rep, _ = _triangulate(pair, tmp_path / "block", dsm=out)
    assert out.is_file() and "error" not in rep["dsm"], rep["dsm"]
    acc = accuracy(out)
    assert acc["rmse_m"] <= GSD and rep["dsm"]["completeness"] >= 0.9, (acc, rep["dsm"]["completeness"])
    assert rep["dsm"]["pairs_kept"] == 1 and rep["dsm"]["outputs"]["dsm"] == str(out)
    # the DSM's CRS rule is the block's (it said "given (--crs)" whatever chose the block's CRS)
    assert rep["dsm"]["crs_rule"] == f"the block's map CRS: {rep['start']['crs_rule']}", rep["dsm"]["crs_rule"]
    assert json.loads((tmp_path / "block" / "report.json").read_text())["dsm"]["completeness"] == \
        rep["dsm"]["completeness"]
    # the camera held fixed is written beside the orientation, so the folder alone serves dsm --orientation
    assert sorted(p.name for p in (tmp_path / "block").iterdir()) == sorted(
        ["block.gpkg", "camera.yaml", "exterior_orientation.txt", "report.html", "report.json"])


def test_a_dsm_that_cannot_be_made_leaves_the_adjustment(pair, tmp_path, monkeypatch):
    """No epipolar residual tolerated: no pair can be trusted, the DSM is refused, the orientation stays."""
    from fotogeo.tools.dsm import tool
    monkeypatch.setattr(tool, "MAX_EPIPOLAR_PX", 0.0)
    out = tmp_path / "dsm.tif"
    rep, messages = _triangulate(pair, tmp_path / "block", dsm=out)
    assert rep["dsm"]["error"].startswith("no DSM: ") and "does not fit the images" in rep["dsm"]["error"]
    assert any(m.startswith("no DSM: ") and "fotogeo dsm" in m for m in messages)
    assert (tmp_path / "block" / "exterior_orientation.txt").is_file() and not out.exists()
    assert "error" in json.loads((tmp_path / "block" / "report.json").read_text())["dsm"]


def test_the_dsm_path_is_checked_before_the_adjustment(pair, tmp_path):
    with pytest.raises(OutputError, match="DSM .* is also an input"):
        _triangulate(pair, tmp_path / "block", dsm=pair["images"][0])
    assert not (tmp_path / "block").exists()


def test_the_triangulate_folder_alone_orients_the_dsm(pair, tmp_path):
    """A user who triangulated with a camera held fixed (given, or from EXIF/XMP) makes the DSM from the output
    folder alone: ``dsm IMAGES --orientation OUT/`` finds the camera there (it used to ask for --camera) and the
    map CRS in the orientation file's header (it used to ask for --crs); another --crs is refused by name."""
    from click.testing import CliRunner

    from fotogeo.cli import main
    _triangulate(pair, tmp_path / "block")
    out = tmp_path / "dsm.tif"
    args = ["dsm", *map(str, pair["images"]), "--orientation", str(tmp_path / "block"), "-o", str(out)]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    assert accuracy(out)["rmse_m"] <= GSD
    res = CliRunner().invoke(main, [*args, "--crs", "EPSG:32636", "--overwrite"])
    assert res.exit_code != 0 and "exterior_orientation.txt' is in" in res.output and "--crs" in res.output, \
        res.output


def test_the_console_names_the_dsm_pairs_as_dsm_does(pair, tmp_path):
    """``triangulate --dsm`` prints the lines of ``fotogeo dsm`` for its surface model: each pair (before: none)
    and the DSM with the cells that got a height."""
    from click.testing import CliRunner

    from fotogeo.cli import main
    out = tmp_path / "dsm.tif"
    res = CliRunner().invoke(main, ["triangulate", *map(str, pair["images"]), "--camera", str(pair["camera"]),
                                    "--eo", str(pair["eo"]), "--crs", CRS, "--eo-sigma-position", "0.05",
                                    "--eo-sigma-angle", "0.01", "-o", str(tmp_path / "block"), "--dsm", str(out)])
    assert res.exit_code == 0, res.output
    names = [p.stem for p in map(__import__("pathlib").Path, pair["images"])]
    assert f"pair {names[0]}-{names[1]}: rays meet at " in res.output, res.output
    assert "% of the overlap with a matched height -> " + str(out) in res.output, res.output
