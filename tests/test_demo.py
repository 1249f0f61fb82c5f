"""The embedded default scene (no data needed): generated, registered, checked against its truth;
then a rendered aerial block, triangulated and checked against its truth — one run of ``fotogeo demo``, its
console and its files checked by one test, the result of the tool it ran (``run_demo``) by the other."""
import pytest
from click.testing import CliRunner

import fotogeo.tools.demo.tool as demo_tool
from fotogeo.cli import main
from fotogeo.tools.demo.block import FRAMES_DIR, OUTPUT_DIR

from auto_choice import assert_auto_choice


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """``(result, res, folder)``: ``fotogeo demo -o folder`` (seed 7, the default) run once, the CLI's result and
    what ``run_demo`` returned to it."""
    folder = tmp_path_factory.mktemp("demo") / "d"
    kept, real = {}, demo_tool.run_demo

    def spy(*args, **kwargs):
        kept["res"] = real(*args, **kwargs)
        return kept["res"]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(demo_tool, "run_demo", spy)
        result = CliRunner().invoke(main, ["demo", "-o", str(folder), "-q"])
    return result, kept.get("res"), folder


def test_demo_registers_against_known_truth(demo):
    result, res, folder = demo
    assert result.exit_code == 0, result.output
    t2, t3 = res["truth"], res["terrain_truth"]
    assert t2["dense_rmse_m"] < 1.3 * t2["best_homography_rmse_m"]  # the homography is as good as any
    assert t3["dense_rmse_m"] < 1.5  # the 3-D model is right to well under a 4 m pixel
    assert res["registration"].report["check"]["n"] > 100
    rep = res["terrain"].report
    assert_auto_choice(rep["terrain"], rep["check"]["n"])  # simplest candidate within 5 % of the best
    # the aerial block: matched tie points, 5 GCPs, check points at the noise level of a 60/30 block
    block, truth = res["block"]["report"], res["block"]["truth"]
    assert block["matching"]["tracks"] > 300 and len(block["frames"]) == 8  # thinned to Gruber regions
    assert truth["check_n"] >= 8
    assert truth["check_planimetric_gsd"] < 0.5 and truth["check_z_gsd"] < 1.5
    assert truth["centre_rmse_m"] < 2.0 and truth["angle_rmse_deg"] < 0.1  # from 5 m / 0.5 deg approximations
    assert block["folder"] == str(folder / OUTPUT_DIR) and not list(folder.glob(".fotogeo-demo*"))


def test_demo_cli(demo):
    r, _, folder = demo
    assert r.exit_code == 0, r.output
    assert "truth" in r.output and (folder / "orthorectified.tif").exists()
    assert "aerial triangulation" in r.output and "GSD" in r.output
    assert (folder / FRAMES_DIR / "s1_01.tif").exists()
    assert (folder / OUTPUT_DIR / "exterior_orientation.txt").exists()
    again = CliRunner().invoke(main, ["demo", "-o", str(folder), "-q"])  # no overwrite: refused at once
    assert again.exit_code != 0 and "exists" in again.output
