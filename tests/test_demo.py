"""The embedded default scene (no data needed): generated, registered, checked against its truth."""
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.tools.demo import run_demo

from auto_choice import assert_auto_choice


def test_demo_registers_against_known_truth(tmp_path):
    res = run_demo(tmp_path, seed=7)
    t2, t3 = res["truth"], res["terrain_truth"]
    assert t2["dense_rmse_m"] < 1.3 * t2["best_homography_rmse_m"]  # the homography is as good as any
    assert t3["dense_rmse_m"] < 1.5  # the 3-D model is right to well under a 4 m pixel
    assert res["registration"].report["check"]["n"] > 100
    rep = res["terrain"].report
    assert_auto_choice(rep["terrain"], rep["check"]["n"])  # simplest candidate within 5 % of the best


def test_demo_cli(tmp_path):
    r = CliRunner().invoke(main, ["demo", "-o", str(tmp_path / "d"), "-q"])
    assert r.exit_code == 0, r.output
    assert "truth" in r.output and (tmp_path / "d" / "orthorectified.tif").exists()
