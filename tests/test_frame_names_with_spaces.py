"""Frames whose names hold spaces (or quotes, ``#``): the exterior orientation fotogeo writes is read back, by the
reader and by ``fotogeo ortho``; bare names with spaces written before are read too."""
from __future__ import annotations

import re
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

import box_scene as bs
from fotogeo.errors import InputError
from fotogeo.geometry.camera import ExteriorOrientation
from fotogeo.io.block import write_exterior_orientation
from fotogeo.io.camera import read_exterior_orientation

NAMES = ["plain", "DJI 0001", "two  spaces", "it's", 'say "x"', "a#b", "back\\slash", "tab\there"]


def test_names_round_trip(tmp_path):
    eos = [ExteriorOrientation(1000.0 + k, 2000.0, 300.0, 0.5, -0.25, 90.0 + k) for k in range(len(NAMES))]
    write_exterior_orientation(tmp_path / "eo.txt", NAMES, eos, "adjusted\nsecond line")
    got = read_exterior_orientation(tmp_path / "eo.txt")
    assert list(got) == NAMES
    for n, e in zip(NAMES, eos):
        assert got[n] == pytest.approx(e)
    assert (tmp_path / "eo.txt").read_text().splitlines()[2] == "plain 1000.0000 2000.0000 300.0000 0.50000000 " \
                                                               "-0.25000000 90.00000000"


def test_bare_names_with_spaces_and_comments(tmp_path):
    (tmp_path / "eo.txt").write_text("# a comment\nframe 01 1 2 3 4 5 6  # trailing comment\nf2 1 2 3 4 5 6\n"
                                     "  spaced   name   7 8 9 10 11 12\n")
    got = read_exterior_orientation(tmp_path / "eo.txt")
    assert list(got) == ["frame 01", "f2", "spaced   name"] and got["spaced   name"].kappa == 12.0
    (tmp_path / "bad.txt").write_text("frame 01 1 2 x 4 5 6\n")
    with pytest.raises(InputError, match="line 1: non-numeric"):
        read_exterior_orientation(tmp_path / "bad.txt")
    (tmp_path / "short.txt").write_text("'unclosed 1 2 3 4 5 6\nf 1 2 3\n")
    with pytest.raises(InputError, match="line 1: expected 'name X Y Z omega phi kappa'"):
        read_exterior_orientation(tmp_path / "short.txt")


def test_ortho_reads_back_the_orientation_of_a_frame_named_with_spaces(tmp_path):
    from fotogeo.cli import main
    paths = bs.write_scene(tmp_path)
    frame = tmp_path / "frame 01 'a'.tif"
    shutil.copy(paths["frame"], frame)
    eo = read_exterior_orientation(paths["eo"])["frame"]
    write_exterior_orientation(tmp_path / "eo written.txt", [frame.stem], [eo])
    run = CliRunner().invoke(main, ["ortho", str(frame), "--camera", str(paths["camera"]), "--eo",
                                    str(tmp_path / "eo written.txt"), "--dem", str(paths["dem"]), "-o",
                                    str(tmp_path / "o.tif"), "-q"])
    assert run.exit_code == 0, run.output
    ref = CliRunner().invoke(main, ["ortho", str(paths["frame"]), "--camera", str(paths["camera"]), "--eo",
                                    str(paths["eo"]), "--dem", str(paths["dem"]), "-o", str(tmp_path / "r.tif"), "-q"])
    assert ref.exit_code == 0, ref.output
    import rasterio
    with rasterio.open(tmp_path / "o.tif") as a, rasterio.open(tmp_path / "r.tif") as b:
        assert a.transform.almost_equals(b.transform) and np.array_equal(a.read(), b.read())


def test_comma_and_semicolon_separated_lines(tmp_path):
    """A spreadsheet's export of the same lines (',' or ';' between the seven fields, names with spaces) reads as the
    space-separated file; on main it was refused ("expected 'name X Y Z omega phi kappa'")."""
    (tmp_path / "eo.txt").write_text("# name,X,Y,Z,omega,phi,kappa\nframe 01,1,2,3,4,5,6\nf2 ; 7;8;9;10;11;12\n")
    got = read_exterior_orientation(tmp_path / "eo.txt")
    assert list(got) == ["frame 01", "f2"]
    assert got["frame 01"] == pytest.approx(ExteriorOrientation(1, 2, 3, 4, 5, 6))
    assert got["f2"] == pytest.approx(ExteriorOrientation(7, 8, 9, 10, 11, 12))


def test_orientation_lines_named_with_the_image_extension(data_dir, tmp_path):
    """NGI's exterior orientation with the frames named 'name.tif' (as Pix4D and Metashape write them) orients the
    frames as the stems do; on main ortho refused it ("has no orientation for the image(s)")."""
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models
    ngi = data_dir / "ngi"
    eo = tmp_path / "eo.txt"
    eo.write_text("".join(line.replace("_RGB ", "_RGB.TIF ", 1) + "\n"
                          for line in (ngi / "exterior_orientation.txt").read_text().splitlines()))
    frame = str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif")
    crs, _ = map_crs("auto", str(ngi / "dem.tif"), str(eo), [frame], False)
    cam = str(ngi / "interior_orientation.yaml")
    ours = image_models([frame], crs, camera=cam, eo=str(eo))[0]
    theirs = image_models([frame], crs, camera=cam, eo=str(ngi / "exterior_orientation.txt"))[0]
    px = np.array([[0.0, 0.0], [320.0, 576.0], [640.0, 1152.0]])
    np.testing.assert_array_equal(ours.model.inverse(px, 500.0), theirs.model.inverse(px, 500.0))


@pytest.mark.parametrize("name", ["two\nlines", "car\rreturn", "bell\x07", "sep\u2028arator"])
def test_a_name_with_a_line_break_or_control_character_is_refused_on_writing(tmp_path, name):
    """It was written, and the reader then refused the file it could not split into lines."""
    eo = ExteriorOrientation(1000.0, 2000.0, 300.0, 0.5, -0.25, 90.0)
    with pytest.raises(InputError, match=rf"^frame {re.escape(repr(name))}: its name holds the control character "
                                         rf".*rename the image$"):
        write_exterior_orientation(tmp_path / "eo.txt", ["plain", name], [eo, eo])
    assert not (tmp_path / "eo.txt").exists()
