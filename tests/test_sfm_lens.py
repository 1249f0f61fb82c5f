"""The model of undistorted images (OpenSfM's/ODM's ``undistorted/reconstruction.json``, COLMAP's ``dense/sparse``
PINHOLE) given with the original images is refused naming both sources and the fix; the right pairs read right
(:mod:`fotogeo.io.sfm_lens`). Before the check such a pair was read and the orthophoto was off by the lens's
distortion: benchmarks/sfm_projects_bench.py, the ``undist-*`` rows."""
from __future__ import annotations

import shutil
import warnings

import pytest

import sfm_projects as sp
from fotogeo.crs import parse_crs
from fotogeo.errors import FotogeoWarning, InputError, InputNote
from test_sfm_projects import sc  # noqa: F401 (the rendered block, a module fixture)

MEDIAN_M, P90_M = 0.05, 0.10


def _persp(sc):
    (w, h), f = sc["size"], sc["camera"].fx
    return {"projection_type": "perspective", "width": w, "height": h, "focal": f / max(w, h), "k1": 0.0, "k2": 0.0}


def _undistorted_model(sc, folder, odm):
    rec = sp.opensfm_project(folder, sc, sc["rtk"], odm=odm, camera=_persp(sc))
    (rec.parent / "undistorted").mkdir()
    return shutil.copy(rec, rec.parent / "undistorted" / "reconstruction.json")


def _read(eo, images, frame="auto", crs=sp.TRUTH_CRS):
    """The block ``ortho`` reads and the texts of the notes it gave."""
    from fotogeo.tools.ortho.inputs import orientation_block
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always", FotogeoWarning)
        block = orientation_block(eo, parse_crs(crs) if crs else None, None, frame, images)
    return block, [str(w.message) for w in got if issubclass(w.category, InputNote)]


def _right(block, sc, cam):
    got = sp.measure(block, sc, cam)
    assert got["median_m"] <= MEDIAN_M and got["p90_m"] <= P90_M, got


def test_border_displacement_of_a_radial_lens():
    """A 2 x 2 frame, f = 1, centred: the corners at r² = 2 move by |x|·k1·r² in each axis, √2·2·k1 in all."""
    from fotogeo.io.sfm_lens import border_displacement
    assert border_displacement(2, 2, 1.0, 1.0, (1.0, 1.0), {"k1": 0.01}) == pytest.approx(2 ** 0.5 * 0.02)
    assert border_displacement(2, 2, 1.0, 1.0, (1.0, 1.0), {}) == 0.0


@pytest.mark.parametrize("odm", [False, True])
def test_each_opensfm_model_with_its_own_images_and_the_undistorted_one_refused_with_the_originals(sc, tmp_path, odm):
    """opensfm/reconstruction.json with the originals and undistorted/reconstruction.json with the images the
    camera undistorted (DewarpFlag 1, their tags kept) read right, without a note on the lens; the undistorted model
    with the originals is refused naming DewarpData and both fixes."""
    block, notes = _read(sp.opensfm_project(tmp_path / "lens", sc, sc["rtk"], odm=odm), sc["rtk"][:2])
    _right(block, sc, {"tool": "opensfm", **sp.opensfm_camera(sc["camera"], sc["dewarp"])})
    flat = _undistorted_model(sc, tmp_path / "flat", odm)
    block, more = _read(flat, sp.undistorted_images(sc, tmp_path / "images", tags=True, n=2))
    _right(block, sc, {"tool": "opensfm", **_persp(sc)})
    assert not any("lens distortion" in n for n in notes + more), notes + more
    with pytest.raises(InputError) as e:
        _read(flat, sc["rtk"][:2])
    msg = str(e.value)
    assert "\n" not in msg and "DewarpData" in msg and "far below the lens the images state" in msg
    assert "give opensfm/reconstruction.json" in msg and "opensfm/undistorted/images" in msg


def test_colmap_pinhole_model_reads_right_with_undistorted_images_and_is_refused_with_the_originals(sc, tmp_path):
    (w, h), f = sc["size"], sc["camera"].fx
    model = sp.colmap_model(tmp_path / "dense" / "sparse", sc, {1: ("PINHOLE", w, h, [f, f, w / 2, h / 2])})
    block, _ = _read(model / "images.txt", sp.undistorted_images(sc, tmp_path / "images", n=2))
    _right(block, sc, {"tool": "colmap", "model": "PINHOLE", "params": [f, f, w / 2, h / 2]})
    with pytest.raises(InputError, match=r"COLMAP PINHOLE.*DewarpData.*sparse/0.*dense/images"):
        _read(model / "images.txt", sc["rtk"][:2])


@pytest.mark.parametrize("odm", [False, True])
def test_undistorted_model_with_the_undistorted_images_reads_right_with_a_note(sc, tmp_path, odm):
    """The images as OpenSfM writes them (no EXIF/XMP): read, and said that the pair cannot be checked."""
    images = sp.undistorted_images(sc, tmp_path / "images", n=2)
    block, notes = _read(_undistorted_model(sc, tmp_path, odm), images, "grid" if odm else "topocentric")
    _right(block, sc, {"tool": "opensfm", **_persp(sc)})
    assert any("cannot be checked" in n and "no DJI DewarpData" in n for n in notes), notes


def test_small_self_calibrated_distortion_near_the_images_small_lens_is_not_refused(monkeypatch):
    """A self-calibrated camera moving the border by 0.9 px with images whose DewarpData says 1.2 px is not the
    undistorted model (0.3 px apart); 1.2 px is not far above 0.9 px, 4 px is, and is refused."""
    from types import SimpleNamespace as NS
    import fotogeo.io.sfm_lens as lens
    w, h, f = 5472, 3648, 3660.0
    k1 = 0.9 / lens.border_displacement(w, h, f, f, (w / 2, h / 2), {"k1": 1.0})
    cam = NS(camera=NS(image_size=(w, h), fx=f, fy=f, principal_point=(w / 2, h / 2)), distortion={"k1": k1},
             source="OpenSfM brown camera 'v2 dji fc6310r'")
    block = NS(shots={"DJI_0001": NS(camera_id="v2 dji fc6310r")}, camera_of=lambda k: cam)
    for px, refused in ((1.2, False), (4.0, True)):
        monkeypatch.setattr(lens, "_images_lens", lambda p: (px, f"drone-dji:DewarpData (up to {px} px)"))
        if refused:
            with pytest.raises(InputError, match=r"distortion \(.*up to 0\.90 px\) is far below the lens the images"):
                lens.check_lens(block, ["/x/DJI_0001.JPG"], "/p/opensfm/reconstruction.json")
        else:
            assert lens.check_lens(block, ["/x/DJI_0001.JPG"], "/p/opensfm/reconstruction.json") == ""


def test_undistorted_copies_keeping_the_originals_tags_at_another_size_cannot_be_checked(sc, tmp_path):
    """COLMAP's dense/images keep the originals' EXIF/XMP (DewarpData, PixelXDimension of the camera's frame): at
    another size than PixelXDimension the tags' pixels are not the file's, so the pair is noted as not checkable, not
    refused, and without the EXIF camera's resize note (the SfM model's camera is used)."""
    import rasterio
    import rendered_oblique as ro
    (w, h), f = sc["size"], sc["camera"].fx
    model = sp.colmap_model(tmp_path / "dense" / "sparse", sc, {1: ("PINHOLE", w, h, [f, f, w / 2, h / 2])})
    flat = sp.undistorted_images(sc, tmp_path / "flat", n=2)
    images = []
    for p, q in zip(sc["rtk"][:2], flat):
        with rasterio.open(p) as ds:
            tags, xmp = ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
        with rasterio.open(q) as ds:
            img = ds.read(1)
        tags.update(EXIF_PixelXDimension=str(2 * w), EXIF_PixelYDimension=str(2 * h))
        (tmp_path / "images").mkdir(exist_ok=True)
        ro._write(tmp_path / "images" / p.name, img, tags, xmp)
        images.append(tmp_path / "images" / p.name)
    block, notes = _read(model / "images.txt", images)
    assert any("cannot be checked" in n and f"DewarpData of a {2 * w}x{2 * h} frame" in n for n in notes), notes
    assert not any("--camera" in n or "resize" in n for n in notes), notes
