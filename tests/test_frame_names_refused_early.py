"""A frame file whose name holds a control character (a line break, a bell) is refused when triangulate reads its
inputs, before any work: the name could not be written into exterior_orientation.txt at the end, and before this
check it was refused only there, after the whole adjustment. The writer's own check stays
(test_frame_names_with_spaces.py)."""
from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.errors import InputError
from fotogeo.tools.triangulate import tool as triangulate_tool


class WorkStarted(AssertionError):
    pass


@pytest.fixture
def no_work(monkeypatch):
    """Reading the block's start or adjusting it fails the test: the refusal must come before."""
    def started(*_, **__):
        raise WorkStarted("triangulate started work on a frame name it cannot write")
    monkeypatch.setattr(triangulate_tool, "block_start", started)
    monkeypatch.setattr(triangulate_tool, "adjust_determined", started)


def _frames(folder, odd):
    paths = [folder / "DJI_0001.tif", folder / odd, folder / "DJI_0003.tif"]
    for p in paths:
        p.write_bytes(b"")
    return paths


@pytest.mark.parametrize("odd", ["bell\x07.tif", "two\nlines.tif", "car\rreturn.JPG", "sep\u2028arator.tif"])
def test_a_frame_named_with_a_control_character_is_refused_before_any_work(tmp_path, no_work, odd):
    frames = _frames(tmp_path, odd)
    bad = re.search(r"[\x00-\x1f\u2028]", odd).group()
    with pytest.raises(InputError, match=rf"^image {re.escape(repr(str(frames[1])))}: its file name holds the control "
                                         rf"character {re.escape(repr(bad))}, .*; rename the file$"):
        triangulate_tool.triangulate(frames, None, None, None, tmp_path / "out", crs="EPSG:32633")
    assert not (tmp_path / "out").exists()


def test_the_command_line_says_it_in_one_line(tmp_path, no_work):
    frames = _frames(tmp_path, "two\nlines.tif")
    res = CliRunner().invoke(main, ["triangulate", *map(str, frames), "-o", str(tmp_path / "out")])
    assert res.exit_code != 0 and not isinstance(res.exception, WorkStarted), res.output
    said = [line for line in res.output.splitlines() if "rename the file" in line]
    assert len(said) == 1 and "two\\nlines.tif'" in said[0] and said[0].startswith("Error: image "), res.output
    assert not (tmp_path / "out").exists()


def test_a_tab_is_no_reason_to_refuse(tmp_path, no_work):
    """The writer quotes a tab (shlex), so the run goes on to read its inputs."""
    with pytest.raises(WorkStarted):
        triangulate_tool.triangulate(_frames(tmp_path, "tab\there.tif"), None, None, None, tmp_path / "out",
                                     crs="EPSG:32633")
