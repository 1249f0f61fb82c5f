"""One refusal report for every tool that writes one (:mod:`fotogeo.tools.common.refusal`): ``fotogeo dsm --report``
is written by every refusal once the outputs were checked — those of the inputs' first checks too (two images
needed, ``--rpc`` with a frames' orientation, a bad or geographic ``--crs``, which wrote nothing, its help saying
otherwise) — with the option refused named; ``triangulate``'s ``report.json`` has the same keys (its ``refused``
kept for its readers)."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from fotogeo.cli import main


@pytest.fixture(scope="module")
def nadir(tmp_path_factory):
    from dsm_scenes import make_scene
    return make_scene("nadir", tmp_path_factory.mktemp("nadir"))


@pytest.mark.parametrize("case, option, words", [
    ("one image", "images", "at least two overlapping images"),
    ("unknown crs", "crs", "EPSG:999999"),
    ("geographic crs", "crs", "geographic"),
    ("rpc with eo", "eo", "give either --rpc or the frames' orientation"),
])
def test_a_run_refused_by_its_first_checks_writes_the_report(nadir, tmp_path, case, option, words):
    """These refusals came before the report's context: ``--report`` was not written."""
    images = list(map(str, nadir["images"][:1 if case == "one image" else 2]))
    crs = {"unknown crs": "EPSG:999999", "geographic crs": "EPSG:4326"}.get(case, nadir["crs"])
    out, rep = tmp_path / "dsm.tif", tmp_path / "r.json"
    args = ["dsm", *images, "--camera", str(nadir["camera"]), "--eo", str(nadir["eo"]), "--crs", crs,
            "-o", str(out), "--report", str(rep), *(["--rpc"] if case == "rpc with eo" else [])]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and words in r.output and "Traceback" not in r.output, r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"], r.output  # the report alone
    got = json.loads(rep.read_text())
    assert got["fotogeo"] == "dsm" and got["status"] == "refused" and got["option"] == option, got
    assert got["error"] == got["refused"] and words in got["error"] and got["inputs"]["crs"] == crs


def test_a_refused_triangulation_writes_the_same_format(tmp_path):
    """triangulate's report of a refusal once the frames were matched: the keys of every refusal report, its
    ``refused`` line as before (with the pairs tried and the report named)."""
    from fotogeo.errors import ModelError
    from fotogeo.tools.triangulate.refusal import reporting_refusal
    path = tmp_path / "out" / "report.json"
    path.parent.mkdir()
    matching = {"pairs": [{"pair": [0, 1], "matches": 40, "inliers": 12}]}
    with pytest.raises(ModelError) as e:
        with reporting_refusal(path, matching, ["a", "b"], {"frames": ["a.tif", "b.tif"], "folder": str(path.parent)}):
            raise ModelError("frame b is reached by 3 tie points — add images that overlap it", frames=["b"])
    got = json.loads(path.read_text())
    assert got["refused"] == got["error"] == str(e.value) and got["status"] == "refused"
    assert got["fotogeo"] == "triangulate" and got["option"] is None and got["frames"] == ["a", "b"]
    assert "a–b 40/12" in got["refused"] and got["refused"].endswith("every pair in out/report.json")
    assert got["matching"] == matching and got["inputs"]["frames"] == ["a.tif", "b.tif"] and e.value.frames == ("b",)


def test_a_triangulation_refused_before_matching_writes_nothing(tmp_path):
    from fotogeo.errors import InputError
    from fotogeo.tools.triangulate.refusal import reporting_refusal
    with pytest.raises(InputError, match="^bad$"):
        with reporting_refusal(tmp_path / "report.json", None, ["a"], {}):
            raise InputError("bad")
    assert not (tmp_path / "report.json").exists()
