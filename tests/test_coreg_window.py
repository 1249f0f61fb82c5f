"""A co-registration window larger than the overlap is refused before any matching, in the caller's words: the
command line names ``--window`` and a value that fits; nothing is written."""
from __future__ import annotations

from click.testing import CliRunner
from coreg_patch import patch_pair

from fotogeo.cli import main


def test_window_larger_than_the_overlap_is_refused_naming_the_flag_and_a_size_that_fits(data_dir, tmp_path):
    reference, target = patch_pair(data_dir, tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    r = CliRunner().invoke(main, ["coreg", str(reference), str(target), "-o", str(tmp_path / "out.tif"),
                                  "--window", "512"], terminal_width=200)
    assert r.exit_code == 2, r.output
    lines = [line for line in r.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in r.output
    assert "--window 512 is larger than the overlap" in lines[0] and "448 × 600" in lines[0]
    assert "use 448 or less" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no output, nothing beside the inputs


def test_a_window_that_fits_runs(data_dir, tmp_path):
    # the same pair with the window the refusal proposes is measured, not refused
    from fotogeo.tools.coreg.tool import coregister
    reference, target = patch_pair(data_dir, tmp_path)
    rep = coregister(reference, target, None, window=256, grid_spacing=64)
    assert rep["windows"]["reliable"] >= 10 and rep["grid"]["window"] == 256
