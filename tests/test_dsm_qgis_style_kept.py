"""A ``<name>.qml`` beside the DSM that fotogeo did not write — a user's, or the one QGIS's "Save as Default" writes
there — is not lost in silence: fotogeo's own style carries a marker (an XML comment QGIS does not write back,
tests/test_qgis_dsm_style_kept.py); any other is replaced only with ``overwrite``, the refusal naming the way to keep
it; ``--no-qgis-style`` (dsm and triangulate --dsm, one option of the table) writes none and leaves it whatever
``--overwrite`` says."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from fotogeo.errors import OutputError

CRS = "EPSG:32635"
USERS = "<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n<qgis version=\"3.22\"><pipe/></qgis>\n"


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    from rendered_pair import render
    return render(tmp_path_factory.mktemp("pair"), 256)


def _cli(pair, out, *extra):
    from fotogeo.cli import main
    return CliRunner().invoke(main, ["dsm", *map(str, pair["images"]), "--camera", str(pair["camera"]), "--eo",
                                     str(pair["eo"]), "--crs", CRS, "-o", str(out), "-q", *extra])


def test_no_qgis_style_writes_none_and_keeps_the_users_with_overwrite(pair, tmp_path):
    style = tmp_path / "d.qml"
    style.write_text(USERS)
    run = _cli(pair, tmp_path / "d.tif", "--no-qgis-style", "--overwrite", "--report", str(tmp_path / "r.json"))
    assert run.exit_code == 0, run.output
    assert style.read_text() == USERS
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.qml", "d.tif", "r.json"]
    assert "qgis_style" not in json.loads((tmp_path / "r.json").read_text())["outputs"]


def test_a_users_style_is_refused_naming_both_ways_and_fotogeos_own_is_told_apart(pair, tmp_path):
    from fotogeo.io.qml import MARKER, users_style
    out, style = tmp_path / "d.tif", tmp_path / "d.qml"
    style.write_text(USERS)
    assert users_style(out) == style
    run = _cli(pair, out)
    assert run.exit_code == 1 and "\n" not in run.output.strip(), run.output
    assert "exists; pass --overwrite to replace it" in run.output and "--no-qgis-style" in run.output, run.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.qml"] and style.read_text() == USERS
    # a DSM there too: the style is named first (the DSM's refusal alone would have the user pass --overwrite and
    # lose the style without a word)
    out.write_bytes(b"an earlier DSM")
    run = _cli(pair, out)
    assert run.exit_code == 1 and "--no-qgis-style" in run.output, run.output
    assert _cli(pair, out, "--overwrite").exit_code == 0
    assert MARKER in style.read_text() and users_style(out) is None
    # fotogeo's own style is the DSM's output: refused without --overwrite as the DSM is, not as a user's
    out.unlink()
    run = _cli(pair, out)
    assert run.exit_code == 1 and "exists; pass --overwrite" in run.output and "qgis-style" not in run.output


def test_triangulate_dsm_without_its_style_keeps_the_users(pair, tmp_path):
    """triangulate --dsm refused a user's style before the adjustment; with qgis_style off it leaves it."""
    from fotogeo.tools.triangulate import triangulate
    style = tmp_path / "d.qml"
    style.write_text(USERS)
    with pytest.raises(OutputError, match="qgis_style=False"):
        triangulate(pair["images"], pair["camera"], pair["eo"], None, tmp_path / "block", crs=CRS,
                    dsm=tmp_path / "d.tif")
    rep = triangulate(pair["images"], pair["camera"], pair["eo"], None, tmp_path / "block", crs=CRS,
                      dsm=tmp_path / "d.tif", qgis_style=False, overwrite=True, eo_sigma_position=0.05,
                      eo_sigma_angle=0.01)  # the datum from the orientation given
    assert rep["dsm"]["outputs"] == {"dsm": str(tmp_path / "d.tif")}, rep["dsm"]
    assert style.read_text() == USERS and Path(tmp_path / "d.tif").exists()


def test_the_rpc_dsm_follows_the_switch_too(tmp_path):
    from rendered_rpc_pair import render_rpc_pair

    from fotogeo.io.qml import MARKER
    from fotogeo.tools.dsm import dsm
    sc = render_rpc_pair(tmp_path, 256)
    style = tmp_path / "dsm.qml"
    rep = dsm(sc["images"], tmp_path / "dsm.tif", rpc=True, resolution=0.7, qgis_style=False)
    assert "qgis_style" not in rep["outputs"] and not style.exists()
    rep = dsm(sc["images"], tmp_path / "dsm.tif", rpc=True, resolution=0.7, overwrite=True)
    assert rep["outputs"]["qgis_style"] == str(style) and MARKER in style.read_text()


def test_without_a_style_an_earlier_runs_style_left_beside_the_dsm_is_named(pair, tmp_path):
    """--overwrite --no-qgis-style replaces the DSM but not the style fotogeo wrote for it earlier: QGIS would draw the
    new heights with the old range, so the run says so (a user's style is theirs: nothing said)."""
    from fotogeo.cli import main
    assert _cli(pair, tmp_path / "d.tif").exit_code == 0
    before = (tmp_path / "d.qml").read_text()
    args = ["dsm", *map(str, pair["images"]), "--camera", str(pair["camera"]), "--eo", str(pair["eo"]), "--crs", CRS,
            "-o", str(tmp_path / "d.tif"), "--overwrite", "--no-qgis-style"]
    run = CliRunner().invoke(main, args)
    assert run.exit_code == 0, run.output
    said = " ".join(run.output.split())
    assert "the QGIS style fotogeo wrote for an earlier DSM of that name, is left beside it" in said, said
    assert (tmp_path / "d.qml").read_text() == before
    (tmp_path / "d.qml").write_text(USERS)
    run = CliRunner().invoke(main, args)
    assert run.exit_code == 0 and "is left beside it" not in " ".join(run.output.split()), run.output
