"""OpenSfM's ``undistorted/reconstruction.json`` and ODM's flag file decide an SfM file's local frame where GPS cannot
(:mod:`fotogeo.io.sfm_frame`): the undistorted model holds the poses of the OpenSfM folder's own file above it
(OpenSfM's ``undistort`` copies them; ODM runs it after ``export_geocoords``, so its copy is along the grid), and
ODM 2.4.7 to 2.6.3 rewrote ``reconstruction.json`` along the grid beside ``exported_geocoords.txt`` without keeping
the topocentric copy. The undistorted images carry no GPS (OpenSfM writes them without EXIF), so only the layout
can tell; a file copied out of its folder is still refused naming ``sfm_frame``."""
from __future__ import annotations

import json
import shutil
import warnings

import pytest

import sfm_projects as sp
from fotogeo.crs import parse_crs
from fotogeo.errors import FotogeoWarning, InputError
from test_sfm_projects import sc  # noqa: F401 (the rendered block, a module fixture)

MEDIAN_M, P90_M = 0.05, 0.10


@pytest.fixture(scope="module")
def flat(sc, tmp_path_factory):  # noqa: F811
    """Two of the block's images undistorted as OpenSfM writes them (no EXIF/XMP, so no GPS)."""
    return sp.undistorted_images(sc, tmp_path_factory.mktemp("undistorted_images"), n=2)


def _persp(sc):  # noqa: F811
    (w, h), f = sc["size"], sc["camera"].fx
    return {"projection_type": "perspective", "width": w, "height": h, "focal": f / max(w, h), "k1": 0.0, "k2": 0.0}


def _undistorted(sc, folder, **kw):  # noqa: F811
    rec = sp.opensfm_project(folder, sc, sc["rtk"], camera=_persp(sc), **kw)
    (rec.parent / "undistorted").mkdir()
    return rec, shutil.copy(rec, rec.parent / "undistorted" / "reconstruction.json")


def _read(eo, images, frame="auto"):
    from fotogeo.tools.ortho.inputs import orientation_block
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return orientation_block(eo, parse_crs(sp.TRUTH_CRS), None, frame, images)


def _right(block, sc):  # noqa: F811
    got = sp.measure(block, sc, {"tool": "opensfm", **_persp(sc)})
    assert got["median_m"] <= MEDIAN_M and got["p90_m"] <= P90_M, got


def _refused(eo, images, match="sfm_frame topocentric .OpenSfM. or grid .ODM.", frame="auto"):
    with pytest.raises(InputError, match=match) as err:
        _read(eo, images, frame)
    assert err.value.option == "sfm_frame" and "\n" not in str(err.value)
    return str(err.value)


@pytest.mark.parametrize("odm", [False, True])
def test_undistorted_model_is_read_in_the_frame_of_the_file_holding_its_poses(sc, flat, tmp_path, odm):  # noqa: F811
    """OpenSfM's folder: topocentric; ODM's (its topocentric copy and coords.txt one level up): its grid. Copied
    out of the folder — alone, or its undistorted/ folder elsewhere — or beside a file of other poses: refused."""
    rec, eo = _undistorted(sc, tmp_path / "p", odm=odm)
    block = _read(eo, flat)
    assert "undistorted/ holds the poses of the OpenSfM folder's reconstruction.json" in block.frame_reading
    assert ("read as grid" in block.frame_reading and "UTM zone 34N" in block.frame_reading) if odm else \
        "read as topocentric" in block.frame_reading
    _right(block, sc)
    alone = tmp_path / "alone"
    alone.mkdir()
    _refused(shutil.copy(eo, alone / "reconstruction.json"), flat)
    (tmp_path / "elsewhere" / "undistorted").mkdir(parents=True)
    _refused(shutil.copy(eo, tmp_path / "elsewhere" / "undistorted" / "reconstruction.json"), flat)
    data = json.loads(rec.read_text())
    next(iter(data[0]["shots"].values()))["translation"][0] += 0.01  # the folder's file of another run
    rec.write_text(json.dumps(data))
    _refused(eo, flat)


def test_undistorted_model_without_its_reference_reads_opensfms_reference_above(sc, flat, tmp_path):  # noqa: F811
    """OpenSfM versions that keep reference_lla in reference_lla.json only: the one of the folder above."""
    _, eo = _undistorted(sc, tmp_path, odm=False)
    data = json.loads(eo.read_text())
    data[0].pop("reference_lla")
    eo.write_text(json.dumps(data))
    _right(_read(eo, flat), sc)


def test_odm_flag_of_the_versions_without_a_topocentric_copy_marks_the_grid(sc, flat, tmp_path):  # noqa: F811
    """ODM 2.4.7-2.6.3 (OpenSfM's own reference, coords.txt's offset, exported_geocoords.txt, no topocentric copy):
    read along the grid, its undistorted model too; without coords.txt the offset is unknown: refused (main read it
    as OpenSfM's topocentric folder, metres off in silence)."""
    rec, eo = _undistorted(sc, tmp_path / "a", odm=True, imposed=False, topocentric_copy=False)
    (rec.parent / "exported_geocoords.txt").write_text("")
    for path in (rec, eo):  # the model's camera is the undistorted one: the undistorted images for both
        block = _read(path, flat)
        assert "exported_geocoords.txt" in block.frame_reading and "coords.txt" in block.frame_reading
        _right(block, sc)
    rec, eo = _undistorted(sc, tmp_path / "b", odm=True, imposed=False, topocentric_copy=False, coords=False)
    (rec.parent / "exported_geocoords.txt").write_text("")
    assert "exported_geocoords.txt beside it" in _refused(rec, flat, "offset is not known")
    assert "exported_geocoords.txt in the folder above" in _refused(eo, flat, "offset is not known")


def test_grid_told_without_odms_offset_is_refused_naming_coords_txt(sc, flat, tmp_path):  # noqa: F811
    """sfm_frame grid on ODM 2.4.7-2.6.3's grid file (exported_geocoords.txt beside it) without coords.txt: the
    offset would come from reference_lla, which is not ODM's there (main read it so, metres off in silence);
    refused naming coords.txt. With coords.txt, told grid reads it right."""
    rec, eo = _undistorted(sc, tmp_path / "a", odm=True, imposed=False, topocentric_copy=False)
    (rec.parent / "exported_geocoords.txt").write_text("")
    _right(_read(rec, flat, "grid"), sc)
    rec, eo = _undistorted(sc, tmp_path / "b", odm=True, imposed=False, topocentric_copy=False, coords=False)
    (rec.parent / "exported_geocoords.txt").write_text("")
    for path in (rec, eo):
        text = _refused(path, flat, "offset is not known", frame="grid")
        assert "sfm_frame grid was told" in text and "copy coords.txt" in text
