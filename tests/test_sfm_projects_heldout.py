"""Third-party SfM projects as users copy and export them, held out from the readers (issue 32): another place
(33° S on the UTM 18/19 edge: southern and western hemispheres), a portrait sensor with another lens, image names
that differ from the files by case or by Windows separators, ODM's ``cameras.json`` as the camera. Read right
(orthophoto shift ≤ 0.05 m median, ≤ 0.10 m p90) or refused by name; the full table:
``benchmarks/sfm_projects_bench.py`` (``S:`` rows for the second place).
"""
from __future__ import annotations

import json
import shutil
import warnings

import pytest

import sfm_projects as sp
from fotogeo.crs import parse_crs
from fotogeo.errors import FotogeoWarning, InputError

MEDIAN_M, P90_M = 0.05, 0.10


@pytest.fixture(scope="module")
def south(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sp.scene(tmp_path_factory.mktemp("sfm_south"), per_strip=2, place=sp.SOUTH)


def _read(eo, images, sc, camera=None):
    from fotogeo.tools.ortho.inputs import orientation_block
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return orientation_block(eo, parse_crs(sc["crs"]), camera, "auto", images)


def _ortho_block(eo, images, sc, camera=None, said=None):
    """What ``ortho`` makes of ``eo`` for ``images``: ``{frame key of the file: AdjustedFrame}``; what it said of
    the reading is appended to ``said``."""
    from fotogeo.tools.ortho.inputs import image_models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return {im.name: im.model for im in image_models(images, parse_crs(sc["crs"]), camera=camera, eo=eo,
                                                         said=said)}


def _right(block, sc, cam, keys=None):
    got = sp.measure(block, sc, cam, keys=keys)
    assert got and got["median_m"] <= MEDIAN_M and got["p90_m"] <= P90_M, got
    return got


def _colmap(sc):
    c = sc["camera"]
    k1, k2, p1, p2, _ = sc["dewarp"]
    return [c.fx, c.fx, *c.principal_point, k1, k2, p1, p2]


def test_the_second_place_is_south_west_and_portrait(south):
    """Not a test of the readers: the block lies at 33° S, 72° W, in portrait frames."""
    lon, lat, _ = sp.gps_of(south["rtk"][0])
    assert lat < -32.9 and lon < -71.9 and south["camera"].image_size[1] > south["camera"].image_size[0]


def test_odm_project_in_the_southern_hemisphere(south, tmp_path):
    """ODM's UTM 19S grid (coords.txt 'WGS 84 UTM 19S'), a portrait brown camera normalised by its height."""
    eo = sp.opensfm_project(tmp_path, south, south["rtk"], odm=True)
    block = _read(eo, south["bare"][:2], south)
    assert "read as grid" in block.frame_reading and "UTM zone 19S" in block.frame_reading
    _right(block, south, {"tool": "opensfm", **sp.opensfm_camera(south["camera"], south["dewarp"])})


@pytest.mark.parametrize("binary", [False, True])
def test_colmap_ecef_and_orthority_in_the_south(south, tmp_path, binary):
    """COLMAP aligned into ECEF (south of the equator, west of Greenwich) and orthority's portrait camera."""
    folder = sp.colmap_model(tmp_path / "c", south, {1: ("OPENCV", 480, 640, _colmap(south))}, binary=binary,
                             transform=lambda C, R: sp.ecef_transform(C, R, south["crs"]))
    _right(_read(folder, south["bare"][:2], south), south, {"tool": "colmap", "model": "OPENCV",
                                                            "params": _colmap(south)})
    c, (w, h) = south["camera"], south["size"]
    cam = {"width": w, "height": h, "type": "brown", "focal_len": c.fx / h, "cx": (c.principal_point[0] - w / 2) / h,
           "cy": (c.principal_point[1] - h / 2) / h, "k1": south["dewarp"][0], "k2": south["dewarp"][1]}
    ext, yml = sp.orthority_files(tmp_path / "o", south, cam, fmt="json" if binary else "geojson")
    _right(_read(ext, south["rtk"][:2], south, yml), south, {"tool": "orthority", **cam})


def _renamed(sc, folder, rename):
    folder.mkdir(parents=True, exist_ok=True)
    return [shutil.copy(p, folder / (rename(p.stem) + p.suffix)) for p in sc["rtk"][:2]]


WINDOWS = {"windows": "flight1\\{}.JPG", "case": "{}.jpg", "dotted": "C:\\flight.1\\{}"}


@pytest.mark.parametrize("naming", ["windows", "case", "dotted"])
def test_colmap_names_of_another_system(south, tmp_path, naming):
    """A model naming its images 'flight1\\\\DJI_101.JPG' (Windows), 'dji_101.jpg' (another case) or
    'C:\\\\flight.1\\\\DJI_101' (a dotted folder, no extension: main keyed it 'C:\\\\flight') for the files DJI_101.tif:
    main found no orientation for DJI_101 and refused; ortho reads them and says how it matched."""
    def project(n):
        return WINDOWS[naming].format(n.lower() if naming == "case" else n)
    folder = sp.colmap_model(tmp_path, south, {1: ("OPENCV", 480, 640, _colmap(south))},
                             names={n: project(n) for n in south["names"]})
    said = []
    frames = _ortho_block(folder, south["rtk"][:2], south, said=said)
    assert set(frames) == {p.stem for p in south["rtk"][:2]}
    assert "otherwise than the files" in " ".join(said)
    block = _read(folder, south["rtk"][:2], south)
    keys = {n: project(n).removesuffix(".jpg").removesuffix(".JPG") for n in south["names"]}
    _right(block, south, {"tool": "colmap", "model": "OPENCV", "params": _colmap(south)}, keys)


def test_two_files_never_share_one_shot(south, tmp_path):
    """Two image files differing by case ('DJI_101.tif', 'dji_101.tif') and a project naming one shot 'DJI_101':
    main rectified both with DJI_101's pose (only a note); dji_101 is refused, naming the image whose shot it is."""
    folder = sp.colmap_model(tmp_path / "m", south, {1: ("OPENCV", 480, 640, _colmap(south))})
    first = south["rtk"][0]
    images = [first, shutil.copy(first, tmp_path / (first.stem.lower() + first.suffix))]
    with pytest.raises(InputError, match=rf"no orientation for the image\(s\) {first.stem.lower()} \('{first.stem}' "
                                         rf"is the image {first.stem}'s\)"):
        _ortho_block(folder, images, south)


def test_a_name_in_two_windows_folders_is_refused_naming_both(south, tmp_path):
    """DJI restarts its numbering per folder: a project with 'f1\\\\DJI_101.JPG' and 'f2\\\\DJI_101.JPG' cannot tell
    which is the file DJI_101.tif; the refusal names both (main: 'no orientation for DJI_101' alone)."""
    n0, n1 = south["names"][:2]
    folder = sp.colmap_model(tmp_path, south, {1: ("OPENCV", 480, 640, _colmap(south))},
                             names={n0: f"f1\\{n0}.JPG", n1: f"f2\\{n0}.JPG"})
    with pytest.raises(InputError, match=r"could be any of 'f1\\\\.*', 'f2\\\\.*'"):
        _ortho_block(folder, south["rtk"][:1], south)


def test_match_keys_claims_a_key_once():
    """Reviewer's cases: a key is taken at most once, exact names first; two claimants leave it unmatched."""
    from fotogeo.io.block import frame_key, match_keys
    from fotogeo.io.sfm_frame import gps_for
    assert match_keys(["DJI_1", "dji_1"], ["DJI_1", "DJI_2"]) == {"DJI_1": "DJI_1"}  # main: both to DJI_1
    assert match_keys(["DJI_1", "Dji_1"], ["dji_1"]) == {}
    from fotogeo.io.block import unmatched_reasons
    assert unmatched_reasons(["DJI_1", "Dji_1"], ["dji_1"]) == {n: "'dji_1' claimed by DJI_1 and Dji_1"
                                                                for n in ("DJI_1", "Dji_1")}
    assert match_keys(["DJI_1"], ["f1\\DJI_1", "DJI_1"]) == {"DJI_1": "DJI_1"}
    assert gps_for({"DJI_1": "A", "dji_1": "B"}, ["DJI_1"]) == gps_for({"dji_1": "B", "DJI_1": "A"}, ["DJI_1"]) \
        == {"DJI_1": "A"}  # main: the later image's GPS
    assert frame_key("C:\\flight.1\\DJI_1") == "C:\\flight.1\\DJI_1" and frame_key("/a/b.c/x.y.tif") == "x.y"
    assert frame_key("back\\slash.tif") == "back\\slash"


def test_odm_names_in_another_case_still_take_the_images_gps_as_evidence(south, tmp_path):
    """ODM's reconstruction.json copied alone, naming 'dji_101.jpg': the RTK GPS of DJI_101.tif decides the grid
    reading (main matched no image to a shot, so nothing decided: refused naming sfm_frame)."""
    eo = sp.opensfm_project(tmp_path, south, south["rtk"], odm=True, exif=False, coords=False, topocentric_copy=False,
                            names={n: f"{n.lower()}.jpg" for n in south["names"]})
    block = _read(eo, south["rtk"][:2], south)
    assert "read as grid" in block.frame_reading and "EXIF GPS" in block.frame_reading
    _right(block, south, {"tool": "opensfm", **sp.opensfm_camera(south["camera"], south["dewarp"])},
           {n: n.lower() for n in south["names"]})


def test_odm_cameras_json_as_the_camera(south, tmp_path):
    """ODM's cameras.json given as --camera was read as orthority's YAML and refused for a missing im_size; it is
    OpenSfM's camera dicts; several cameras are refused by name (each image's is in the reconstruction)."""
    from fotogeo.io.camera import read_camera_with_distortion
    eo = sp.opensfm_project(tmp_path, south, south["rtk"], odm=True)
    cams = json.loads(eo.read_text())[0]["cameras"]
    (tmp_path / "cameras.json").write_text(json.dumps(cams, indent=4))
    cam, dist = read_camera_with_distortion(tmp_path / "cameras.json")
    c = south["camera"]
    assert cam.fx == pytest.approx(c.fx) and cam.principal_point == pytest.approx(c.principal_point)
    assert dist["k1"] == pytest.approx(south["dewarp"][0]) and dist["k3"] == pytest.approx(south["dewarp"][4])
    frames = _ortho_block(eo, south["rtk"][:2], south, tmp_path / "cameras.json")
    assert set(frames) == {p.stem for p in south["rtk"][:2]}
    two = dict(cams, other=next(iter(cams.values())))
    (tmp_path / "two.json").write_text(json.dumps(two))
    with pytest.raises(InputError, match=r"cameras.json with 2 cameras; give it without --camera"):
        read_camera_with_distortion(tmp_path / "two.json")


def test_frame_keys_across_systems():
    from fotogeo.io.block import match_keys
    assert match_keys(["DJI 0001", "back\\slash"], ["a\\b\\DJI 0001", "back\\slash", "slash"]) == {
        "DJI 0001": "a\\b\\DJI 0001", "back\\slash": "back\\slash"}  # a Linux name with a backslash is kept
    assert match_keys(["DJI_0001"], ["f\\dji_0001"]) == {"DJI_0001": "f\\dji_0001"}
    assert match_keys(["DJI_1", "DJI_2", "X"], ["dji_1", "DJI_2", "x", "X2"]) == {"DJI_1": "dji_1", "DJI_2": "DJI_2",
                                                                              "X": "x"}
    assert match_keys(["A"], ["a", "a2", "A2"]) == {"A": "a"}
    assert match_keys(["A"], ["a", "á"]) == {"A": "a"} and match_keys(["Ab"], ["ab", "AB"]) == {}  # ambiguous: none
