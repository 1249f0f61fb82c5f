"""One rule for an image given twice (:func:`fotogeo.tools.common.checks.distinct_files`), used by ``ortho``,
``dsm`` and ``triangulate``: the same path twice, one file by two paths, two files of one name."""
from __future__ import annotations

import pytest

from fotogeo.errors import InputError
from fotogeo.tools.common.checks import distinct_files


def test_the_same_path_twice_is_refused(tmp_path):
    """The rule compared each path with the first of its file or name, so the very same path given twice passed
    both checks (``ortho a.tif a.tif`` after ortho's own name check went to this rule)."""
    a = tmp_path / "a.tif"
    a.write_bytes(b"x")
    with pytest.raises(InputError, match=r"^frames: '.*a\.tif' is given twice; give each image once$"):
        distinct_files([str(a), str(a)], ["a", "a"], "frames")
    with pytest.raises(InputError, match=r"^images: 'gone\.tif' is given twice"):
        distinct_files(["gone.tif", "gone.tif"], ["gone", "gone"])


def test_one_file_by_two_paths_and_two_files_of_one_name(tmp_path):
    (tmp_path / "d1").mkdir()
    (tmp_path / "d2").mkdir()
    for d in ("d1", "d2"):
        (tmp_path / d / "img.tif").write_bytes(b"x")
    same = [str(tmp_path / "d1" / "img.tif"), str(tmp_path / "d2" / ".." / "d1" / "img.tif")]
    with pytest.raises(InputError, match=r"are the same file; give each image once"):
        distinct_files(same, ["img", "img2"])
    two = [str(tmp_path / "d1" / "img.tif"), str(tmp_path / "d2" / "img.tif")]
    with pytest.raises(InputError, match=r"^triangulate: the name img occurs twice \('.*d1/img\.tif', "
                                         r"'.*d2/img\.tif'\); every image needs its own file name: rename one$"):
        distinct_files(two, ["img", "img"], "triangulate")
    distinct_files(two, ["img1", "img2"])


def test_triangulate_refuses_a_frame_given_twice_before_reading_it(tmp_path):
    """triangulate kept its own copy of the name check ("the names X occur twice", no paths): the shared rule now."""
    from fotogeo.tools.triangulate.inputs import frame_names
    a = tmp_path / "f.tif"
    a.write_bytes(b"not read")
    with pytest.raises(InputError, match=r"^frames: '.*f\.tif' is given twice"):
        frame_names([a, a], camera=None)
