"""Third-party SfM projects written as each tool writes them, held out from the ones the readers were built on
(issue 32): read right (orthophoto shift ≤ 0.05 m median, ≤ 0.10 m p90) or refused by name.

The block (``tests/sfm_projects.py``) is rendered at 60° N straddling the 18° E edge of UTM zones 33/34, where ODM's
grid offsets and OpenSfM's topocentric frame part by the meridian convergence (2.6°) and ODM's zone (of its first
photo, 34) is not the zone of the reference (33). The full case table: ``benchmarks/sfm_projects_bench.py``.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import sfm_projects as sp
from fotogeo.crs import parse_crs
from fotogeo.errors import FotogeoWarning, InputError

MEDIAN_M, P90_M = 0.05, 0.10


@pytest.fixture(scope="module")
def sc(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sp.scene(tmp_path_factory.mktemp("sfm_projects"), per_strip=2)


def _read(eo, images, camera=None, crs=sp.TRUTH_CRS):
    from fotogeo.tools.ortho.inputs import orientation_block
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return orientation_block(eo, parse_crs(crs) if crs else None, camera, "auto", images)


def _right(block, sc, cam):
    got = sp.measure(block, sc, cam)
    assert got["median_m"] <= MEDIAN_M and got["p90_m"] <= P90_M, got
    return got


def _osfm_cam(sc):
    return {"tool": "opensfm", **sp.opensfm_camera(sc["camera"])}


def test_the_place_is_where_odm_and_the_reference_zone_part(sc):
    """Not a test of the reader: ODM's zone (its first photo's) is 34, the reference's 33."""
    from fotogeo.crs import utm_crs_for
    epsg, off = sp.odm_zone(sc, sc["rtk"])
    lon, lat = sp._t(epsg, 4326).transform(*off)
    assert epsg == 32634 and utm_crs_for(lon, lat).to_epsg() == 32633


@pytest.mark.parametrize("images", ["rtk", "consumer", "bare"])
def test_odm_project_as_odm_leaves_it(sc, tmp_path, images):
    """export_geocoords' poses, topocentric gps_position, exif/, coords.txt, reconstruction.topocentric.json: read
    along ODM's zone-34 grid whatever GPS the images carry (main read it as topocentric: 2.3 m median shift)."""
    eo = sp.opensfm_project(tmp_path, sc, sc["rtk"], odm=True)
    block = _read(eo, sc[images][:2])
    assert "read as grid" in block.frame_reading and "UTM zone 34N" in block.frame_reading
    _right(block, sc, _osfm_cam(sc))
    # ODM's own topocentric copy is read as topocentric
    _right(_read(eo.parent / "reconstruction.topocentric.json", sc[images][:2]), sc, _osfm_cam(sc))


def test_odm_of_2021_reads_its_offset_from_coords_or_is_refused(sc, tmp_path):
    """ODM Feb–Jul 2021 kept OpenSfM's reference (altitude and all) while export_geocoords subtracted coords.txt's
    offset: read with that offset and the altitudes as written; without coords.txt the offset is unknown: refused."""
    eo = sp.opensfm_project(tmp_path / "a", sc, sc["rtk"], odm=True, imposed=False)
    block = _read(eo, sc["consumer"][:2])
    assert "coords.txt" in block.frame_reading
    got = _right(block, sc, _osfm_cam(sc))
    assert got["centre_m"] < 0.02
    eo = sp.opensfm_project(tmp_path / "b", sc, sc["rtk"], odm=True, imposed=False, coords=False)
    with pytest.raises(InputError, match="offset is not known.*coords.txt") as err:
        _read(eo, sc["consumer"][:2])
    assert err.value.option == "sfm_frame"


def test_odm_reconstruction_copied_alone_is_decided_by_rtk_gps(sc, tmp_path):
    """Only opensfm/reconstruction.json + reference_lla.json: the images' RTK GPS decides (main refused it), the shots'
    gps_position with an RTK gps_dop too; a consumer GPS cannot tell: refused naming sfm_frame."""
    eo = sp.opensfm_project(tmp_path / "a", sc, sc["rtk"], odm=True, exif=False, coords=False, topocentric_copy=False)
    _right(_read(eo, sc["rtk"][:2]), sc, _osfm_cam(sc))
    with pytest.raises(InputError, match="sfm_frame") as err:
        _read(eo, sc["consumer"][:2])
    assert err.value.option == "sfm_frame"
    eo = sp.opensfm_project(tmp_path / "b", sc, sc["rtk"], odm=True, exif=False, coords=False, topocentric_copy=False,
                            dop=0.02)
    block = _read(eo, sc["bare"][:2])
    assert "gps_position" in block.frame_reading
    _right(block, sc, _osfm_cam(sc))


def test_opensfm_folder_with_consumer_gps_is_read_topocentric(sc, tmp_path):
    """OpenSfM's own folder (exif/, OpenSfM's default dop, its mean-GPS reference): no ODM mark, so topocentric."""
    eo = sp.opensfm_project(tmp_path, sc, sc["rtk"], odm=False)
    block = _read(eo, sc["consumer"][:2])
    assert "OpenSfM's folder" in block.frame_reading
    _right(block, sc, _osfm_cam(sc))


def test_odm_exif_without_accuracy_is_refused_not_read_topocentric(sc, tmp_path):
    """exif/ beside it with OpenSfM's default dop and images without GPS: nothing decides (main read it as
    topocentric from gps_position: 2.3 m off in silence)."""
    eo = sp.opensfm_project(tmp_path, sc, sc["rtk"], odm=True, coords=False, topocentric_copy=False)
    with pytest.raises(InputError, match="sfm_frame topocentric .OpenSfM. or grid .ODM.") as err:
        _read(eo, sc["bare"][:2])
    assert err.value.option == "sfm_frame" and "\n" not in str(err.value)


def test_opensfm_images_of_another_reconstruction(sc, tmp_path):
    """Two reconstructions: the images given pick the one holding them; images split over both are named."""
    names = sc["names"]
    eo = sp.opensfm_project(tmp_path, sc, sc["rtk"], odm=False, reconstructions=[names[2:], names[:2]])
    block = _read(eo, sc["rtk"][:2])
    assert set(block.shots) == set(names[:2]) and any("reconstruction 1 of 2" in n for n in block.notes)
    _right(block, sc, _osfm_cam(sc))
    with pytest.raises(InputError, match="oriented in another of its 2 reconstructions.*run once per "
                                         "reconstruction, each time with only its images"):
        _read(eo, sc["rtk"][1:3])


def _colmap(sc):
    c = sc["camera"]
    return [c.fx, c.fx, *c.principal_point, -0.06, 0.02, 4e-4, -3e-4]


@pytest.mark.parametrize("kind", ["binary", "ecef", "ecef-binary"])
def test_colmap_binary_and_ecef_models(sc, tmp_path, kind):
    """cameras.bin/images.bin (main refused them) and a model aligned into ECEF (main took ECEF as UTM)."""
    tf = sp.ecef_transform if kind.startswith("ecef") else None
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, binary="binary" in kind,
                             transform=tf)
    block = _read(folder / ("images.bin" if "binary" in kind else "images.txt"), sc["bare"][:2])
    _right(block, sc, {"tool": "colmap", "model": "OPENCV", "params": _colmap(sc)})
    if tf is not None:
        assert all(s.height_reference == "ellipsoid" for s in block.shots.values())


def _resized_copies(sc, folder, size):
    import cv2
    import rasterio
    import rendered_oblique as ro
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for p in sc["rtk"][:2]:
        with rasterio.open(p) as ds:
            img, tags, xmp = ds.read(1), ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
        ro._write(folder / p.name, cv2.resize(img, size, interpolation=cv2.INTER_AREA), tags, xmp)
        out.append(folder / p.name)
    return out


def test_images_resized_after_the_reconstruction_scale_the_model_camera(sc, tmp_path):
    """Images halved after the reconstruction (as ODM's resize): main refused them naming --eo; the interior
    orientation is now scaled by exactly 1/2, with a note, and the orthophoto lands where the truth is."""
    from fotogeo.errors import InputNote
    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.tools.ortho.inputs import image_models
    folder = sp.colmap_model(tmp_path / "m", sc, {1: ("OPENCV", 640, 480, _colmap(sc))})
    small = _resized_copies(sc, tmp_path / "half", (320, 240))
    said = []
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        ims = image_models(small, parse_crs(sp.TRUTH_CRS), eo=folder / "images.txt", said=said)
    assert any(issubclass(w.category, InputNote) and "reduced by exactly 1/2" in str(w.message) for w in seen)
    assert sum("reduced by exactly 1/2" in n for n in said) == 1  # once for the two images of one size
    cam = {"tool": "colmap", "model": "OPENCV", "params": _colmap(sc)}
    g = np.array([[100.0, 80.0], [320.0, 240.0], [600.0, 400.0]])
    for im in ims:
        X = OrientedFrame(sc["camera"], sc["truth"][im.name]).pixel_to_world_at(g, sc["ground"])
        C, R = sp.pose_cv(sc["truth"][im.name])
        px = sp.tool_pixel(cam, (X - C) @ R.T) * 0.5
        assert np.abs(im.model.forward(X) - px).max() < 1e-6


@pytest.mark.parametrize("size", [(320, 200), (336, 240), (600, 450)])
def test_images_cropped_after_the_reconstruction_are_refused_naming_the_model(sc, tmp_path, size):
    """An aspect change, or a reduction that a crop of the same aspect also gives (600x450 = 15/16), is not scaled:
    refused naming --eo, as before."""
    from fotogeo.tools.ortho.inputs import image_models
    folder = sp.colmap_model(tmp_path / "m", sc, {1: ("OPENCV", 640, 480, _colmap(sc))})
    small = _resized_copies(sc, tmp_path / "c", size)
    with warnings.catch_warnings(), pytest.raises(InputError, match=f"camera of --eo .*images.txt' is for images of "
                                                                    f"640x480 .* {size[0]}x{size[1]} .resized after"):
        warnings.simplefilter("ignore")
        image_models(small, parse_crs(sp.TRUTH_CRS), eo=folder / "images.txt")


@pytest.mark.parametrize("size, image, how", [
    ((5472, 3648), (2048, 1365), "reduced to a long side of 2048 px"),  # ODM --resize-to 2048: int(3648·r) = 1365
    ((3648, 5472), (1365, 2048), "reduced to a long side of 2048 px"),  # portrait
    ((4000, 3000), (1333, 1000), "reduced by 1/3"),  # 1333.3 floored
    ((640, 480), (320, 240), "reduced by exactly 1/2"),
    ((2048, 1365), (5472, 3648), "enlarged by 2.67188 x 2.67253"),  # a model made on ODM's reduced copies
    ((5472, 3648), (5000, 3333), None), ((640, 480), (600, 450), None),  # what a crop of the same aspect gives
    ((5472, 3648), (2048, 1367), None), ((2048, 1365), (2048, 1366), None), ((640, 480), (320, 200), None),
    ((1000, 666), (1600, 1066), None)])  # enlarged by 1.6 across, 1.6006 down: not a resize of the image
def test_resizes_are_told_from_crops_by_their_sizes(size, image, how):
    """main took only exact fractions: ODM's 2048 px resize of a DJI 5472x3648 (2048x1365, the height floored) was
    refused. Each axis takes its own factor; a crop's size (any other reduction, an aspect change) is not scaled."""
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.tools.common.checks import camera_for_image, resize_factor
    got = resize_factor(size, *image)
    assert (got and got[2]) == how
    cam = FrameCamera(8.8, (13.2, 8.8), size, (size[0] / 2 + 10.0, size[1] / 2 - 6.0))
    if how is None:
        with pytest.raises(InputError, match=f"is for images of {size[0]}x{size[1]} .*resized after"):
            camera_for_image(cam, *image, "a.JPG", "--eo m/images.txt")
        return
    new, note = camera_for_image(cam, *image, "a.JPG", "--eo m/images.txt")
    sx, sy = image[0] / size[0], image[1] / size[1]
    assert new.principal_point == pytest.approx((cam.principal_point[0] * sx, cam.principal_point[1] * sy))
    assert new.fx == pytest.approx(cam.fx * sx) and new.fy == pytest.approx(cam.fy * sy) and how in note


def test_colmap_model_folder_on_the_command_line(sc, tmp_path):
    """``--eo sparse/0/`` (a COLMAP model's folder): click refused a folder on main; a folder without a model is
    refused naming it and the models found below it."""
    from click.testing import CliRunner

    from fotogeo.cli import main
    folder = sp.colmap_model(tmp_path / "sparse" / "0", sc, {1: ("OPENCV", 640, 480, _colmap(sc))})
    base = ["ortho", *map(str, sc["rtk"][:2]), "--dem", str(sc["dem"]), "--crs", sp.TRUTH_CRS, "--resolution", "2",
            "-q", "--overwrite"]
    run = CliRunner().invoke(main, [*base, "--eo", str(folder) + "/", "-o", str(tmp_path / "out")])
    assert run.exit_code == 0, run.output
    assert len(list((tmp_path / "out").glob("*.tif"))) == 2
    run = CliRunner().invoke(main, [*base, "--eo", str(tmp_path / "sparse"), "-o", str(tmp_path / "out2")])
    assert run.exit_code != 0 and "has no cameras.txt or cameras.bin" in run.output, run.output
    assert "sparse/0" in run.output and "Traceback" not in run.output


def test_colmap_model_in_its_own_frame_is_refused(sc, tmp_path):
    """Not geo-registered, images without GPS: main read COLMAP's frame as UTM coordinates in silence."""
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, transform=sp.arbitrary_transform)
    with pytest.raises(InputError, match="not in WGS 84 / UTM zone 33N .* nor in ECEF.*model_aligner"):
        _read(folder, sc["bare"][:2])


def test_colmap_model_in_its_own_frame_is_aligned_to_rtk_gps(sc, tmp_path):
    """Not geo-registered, every image with RTK GPS (σ 2 cm): aligned as model_aligner does (main refused it), the
    choice said in the reading, the orthophoto within the done-when shift."""
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, transform=sp.arbitrary_transform)
    block = _read(folder, sc["rtk"])
    assert "aligned to the images' own GPS" in block.frame_reading and "expected error" in block.frame_reading
    # DJI RTK altitudes are ellipsoidal: passed through (main left the reference unknown)
    assert {s.height_reference for s in block.shots.values()} == {"ellipsoid"}
    assert "above the ellipsoid" in block.frame_reading
    got = _right(block, sc, {"tool": "colmap", "model": "OPENCV", "params": _colmap(sc)})
    assert got["centre_m"] < 0.1


def test_colmap_own_frame_with_consumer_gps_of_a_small_block_is_refused(sc, tmp_path):
    """8 consumer GPS images (no accuracy tags: σ 5 m, 10 m vertically) over ~70 m: the tilt is not determined
    (±8.0°; 5.6° before the precision was taken about the centroid); refused naming --crs rather than aligned. The
    bench's 16 images are aligned with a warning."""
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, transform=sp.arbitrary_transform)
    with pytest.raises(InputError, match="determines its tilt only to .*model_aligner.*--crs"):
        _read(folder, sc["consumer"])


def test_colmap_own_frame_leaves_out_one_bad_gps_fix(sc, tmp_path):
    """One image's RTK fix 30 m off: left out (and named), the others align the model right."""
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, transform=sp.arbitrary_transform)
    imgs = list(sc["rtk"])
    imgs[3] = sp.shifted_gps(imgs[3], tmp_path / "bad" / imgs[3].name, (30.0, -10.0))
    block = _read(folder, imgs)
    assert f"{imgs[3].stem}'s GPS left out" in block.frame_reading
    _right(block, sc, {"tool": "colmap", "model": "OPENCV", "params": _colmap(sc)})


def test_colmap_own_frame_with_images_without_gps_altitude_is_refused(sc, tmp_path):
    """lat/lon without an altitude: main read the altitude as 0 (images_gps) and put the cameras at Z ≈ 0."""
    from fotogeo.io.sfm_frame import images_gps
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, transform=sp.arbitrary_transform)
    imgs = [sp.without_altitude(p, tmp_path / "noalt" / p.name) for p in sc["rtk"]]
    gps = images_gps(imgs)
    assert len(gps) == len(imgs) and all(g.alt is None and g.height_reference is None for g in gps.values())
    with pytest.raises(InputError, match=f"{len(imgs)} of its {len(imgs)} images with GPS carry latitude and "
                                         f"longitude but no GPS altitude .*model_aligner.*--crs"):
        _read(folder, imgs)


def test_colmap_own_frame_with_two_gps_images_is_refused(sc, tmp_path):
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))}, transform=sp.arbitrary_transform)
    with pytest.raises(InputError, match="model_aligner.*--crs.*at least 3 of its images carrying GPS"):
        _read(folder, sc["rtk"][:2])


def test_colmap_images_txt_without_a_crs_is_read_as_a_model_not_as_eo_lines(sc, tmp_path):
    """ortho without --crs or a projected DEM looked for a fotogeo header in COLMAP's images.txt (a ``.txt``, so
    taken for ``name X Y Z omega phi kappa`` lines) and asked for the CRS of "the exterior orientation"."""
    from fotogeo.tools.ortho.crs_rule import map_crs
    folder = sp.colmap_model(tmp_path, sc, {1: ("OPENCV", 640, 480, _colmap(sc))})
    with pytest.raises(InputError, match=r"COLMAP model .*: COLMAP coordinates have no CRS"):
        map_crs(None, None, folder / "images.txt", sc["bare"][:2], False)


def test_orthority_cameras_without_sensor_size_in_ortho(sc, tmp_path):
    """orthority's brown camera (focal_len normalised, no sensor_size) given as --camera with its GeoJSON: ortho read
    the camera again as fotogeo's YAML and refused it on main."""
    c = sc["camera"]
    cam = {"width": 640, "height": 480, "type": "brown", "focal_len": c.fx / 640, "cx": (c.principal_point[0] - 320) /
           640, "cy": (c.principal_point[1] - 240) / 640, "k1": -0.06, "k2": 0.02, "p1": 4e-4, "p2": -3e-4}
    ext, yml = sp.orthority_files(tmp_path, sc, cam)
    from fotogeo.tools.ortho.inputs import image_models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ims = image_models(sc["rtk"][:2], parse_crs(sp.TRUTH_CRS), camera=yml, eo=ext)
    assert [im.name for im in ims] == [p.stem for p in sc["rtk"][:2]]
    _right(_read(ext, sc["rtk"][:2], yml, None), sc, {"tool": "orthority", **cam})
    from fotogeo.tools.triangulate.sources import block_start  # triangulate --eo EXT --camera YAML alike
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = block_start(sc["rtk"][:2], yml, ext, None, None, None, None, None, None)
    assert start.camera.fx == pytest.approx(c.fx) and start.distortion[0] == pytest.approx(-0.06)


def test_odm_grid_zone_from_coords_and_whole_metres(tmp_path):
    from fotogeo.io.sfm_frame import odm_grid
    off = np.floor(sp._t(4326, 32634).transform(17.9999, 60.0))  # ODM's offset in zone 34, west of 18° E
    lon, lat = sp._t(32634, 4326).transform(*off)
    (tmp_path / "opensfm").mkdir()
    path = tmp_path / "opensfm" / "reconstruction.json"
    assert odm_grid(path, (lat, lon, 0.0))[0][0].to_epsg() == 32634
    assert odm_grid(path, (lat, lon, 12.5))[0][0].to_epsg() == 32633  # not ODM's reference: the reference's zone
    (tmp_path / "odm_georeferencing").mkdir()
    (tmp_path / "odm_georeferencing" / "coords.txt").write_text(f"WGS84 UTM 34N\n{off[0]:.0f} {off[1]:.0f}\n")
    (crs, origin), why, odm = odm_grid(path, (lat, lon, 12.5))
    assert crs.to_epsg() == 32634 and "coords.txt" in why and tuple(origin) == tuple(off) and odm


def test_colmap_names_the_folder_of_an_image_another_flight_shares(sc, tmp_path):
    """images.txt names ``flight1/<name>.tif``; the images given are flight1's and another flight's image of the same
    name 500 m off: the model's shots are checked against flight1's GPS (main dropped the folder and refused the model
    as ambiguous, ``share the name``); a model naming no folder is still refused by name."""
    import shutil
    names = sc["names"][:2]
    own = [shutil.copy(p, (tmp_path / "flight1").mkdir(exist_ok=True) or tmp_path / "flight1" / p.name)
           for p in sc["rtk"][:2]]
    other = sp.shifted_gps(sc["rtk"][0], tmp_path / "flight2" / sc["rtk"][0].name, (500.0, 0.0))
    cams = {1: ("OPENCV", 640, 480, _colmap(sc))}
    folder = sp.colmap_model(tmp_path / "m", sc, cams, shots=names, names={n: f"flight1/{n}.tif" for n in names})
    block = _read(folder / "images.txt", [*own, other])
    assert any("from the images' own GPS of 2 image(s)" in n for n in block.notes), block.notes
    _right(block, sc, {"tool": "colmap", "model": "OPENCV", "params": _colmap(sc)})
    bare = sp.colmap_model(tmp_path / "b", sc, cams, shots=names)
    with pytest.raises(InputError, match="share the name of the project's image"):
        _read(bare / "images.txt", [*own, other])
