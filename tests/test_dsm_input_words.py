"""``fotogeo dsm``'s input refusals in the caller's words (:func:`fotogeo.errors.in_callers_words`): the option
named once, by its flag on the command line (its label in QGIS), never inside a file name that holds the option's
word (``pairs.txt``, ``camera.yaml``, a folder ``orientation``); a bad ``--crs`` is a usage error as a bad
``--bounds`` is."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.cli.common import _in_flags
from fotogeo.errors import InputError, in_callers_words
from fotogeo.tools.dsm.inputs import orientation_files, read_pairs


def test_an_unknown_name_in_the_pairs_file_is_named(tmp_path):
    """``--pairs pairs.txt`` naming ``right_imag``: the message read ``--pairs '--pairs.txt'`` and did not say
    which name was unknown."""
    pairs = tmp_path / "pairs.txt"
    pairs.write_text("# left right\nleft_image right_imag\n")
    with pytest.raises(InputError) as e:
        read_pairs(pairs, ["left_image", "right_image"])
    assert _in_flags(e.value) == (f"--pairs {str(pairs)!r} line 2: 'right_imag' is not among the images "
                                  f"(left_image, right_image); give their file names without folder and extension")
    assert in_callers_words(str(e.value), e.value.option, "Pairs file").startswith(f"Pairs file {str(pairs)!r}")


def test_the_pairs_file_names_frames_with_spaces_quoted_or_tab_separated(tmp_path):
    """Frames called ``frame one.png`` ran, but ``--pairs`` could not name them (quoted or tab-separated, both
    refused); unquoted, the refusal says how."""
    names = ["frame one", "frame three", "frame two"]
    pairs = tmp_path / "pairs.txt"
    pairs.write_text('"frame one" "frame two"  # quoted\nframe two\tframe three\n\'frame three\',"frame one.png"\n')
    assert read_pairs(pairs, names) == [(0, 1), (0, 2), (1, 2)]
    pairs.write_text("frame one frame two\n")
    with pytest.raises(InputError, match=r"a name with spaces in quotes or the two names separated by a tab"):
        read_pairs(pairs, names)
    pairs.write_text("O'Brien_1 O'Brien_2\n")  # an apostrophe inside a name is no quote (review 3)
    assert read_pairs(pairs, ["O'Brien_1", "O'Brien_2"]) == [(0, 1)]


def test_an_orientation_folder_without_its_camera_is_named_in_flags(tmp_path):
    """A folder called ``orientation`` holding no camera.yaml: the message read ``--orientation '…/--orientation'``
    and ``holds no --camera.yaml``."""
    folder = tmp_path / "orientation"
    folder.mkdir()
    (folder / "exterior_orientation.txt").write_text("")
    with pytest.raises(InputError) as e:
        orientation_files(folder, None, None)
    text = _in_flags(e.value)
    assert text.startswith(f"--camera needed: --orientation {str(folder)!r} holds no camera.yaml "), text
    assert text.count("--") == 2


def test_a_bad_crs_is_a_usage_error_as_a_bad_bounds_is(tmp_path):
    paths = [tmp_path / f"{n}.tif" for n in ("left", "right")]
    for p in paths:
        with rasterio.open(p, "w", driver="GTiff", width=32, height=32, count=1, dtype="uint8") as ds:
            ds.write(np.zeros((1, 32, 32), np.uint8))
    base = ["dsm", *map(str, paths), "--rpc", "-o", str(tmp_path / "d.tif")]
    crs = CliRunner().invoke(main, base + ["--crs", "EPSG:999999"])
    bounds = CliRunner().invoke(main, base + ["--bounds", "1,2,3"])
    assert crs.output.strip().splitlines()[-1].startswith("Error: --crs 'EPSG:999999' is not a CRS"), crs.output
    assert bounds.output.strip().splitlines()[-1].startswith("Error: --bounds '1,2,3': give"), bounds.output
    assert (crs.exit_code, bounds.exit_code) == (2, 2)
    assert not (tmp_path / "d.tif").exists()
