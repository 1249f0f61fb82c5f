"""Readers of SfM outputs (issue 20): OpenSfM/ODM, COLMAP, orthority -> ApproximateBlock.

Round trips through fotogeo's own writers, plus hand-written files whose expected values are
worked out by hand here (so that a writer and a reader sharing a sign error cannot pass), a
projection of a ground point through OpenSfM's own equations against fotogeo's, and bad input.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from pyproj import CRS, Transformer

from fotogeo.errors import InputError
from fotogeo.geometry.approx_block import ApproximateBlock, ApproxShot
from fotogeo.geometry.camera import OrientedFrame
from fotogeo.io.colmap import read_colmap, write_colmap
from fotogeo.io.opensfm import opensfm_camera, pixel_camera, read_opensfm, write_opensfm
from fotogeo.io.orthority import (read_orthority, read_orthority_interior, write_orthority_csv,
                                  write_orthority_geojson, write_orthority_interior)
from fotogeo.orientation.bundle_jacobian import pixel_scale, project

UTM35S = CRS.from_epsg(32735)
REF = (-33.9, 25.5, 1000.0)  # lat, lon, alt
C30, S30 = math.cos(math.radians(30)), 0.5


def _en0():
    return np.array(Transformer.from_crs(4326, UTM35S, always_xy=True).transform(REF[1], REF[0]))


@pytest.fixture(scope="module")
def block() -> ApproximateBlock:
    """Six frames near lon 25.5, lat -33.9 (UTM 35S), two of them strongly oblique, κ all round."""
    brown = pixel_camera(4000, 3000, 3200.0, 3200.0, 2010.5, 1490.25,
                         dict(k1=-0.12, k2=0.03, k3=-0.004, p1=2e-4, p2=-3e-4), "synthetic brown")
    pin = pixel_camera(1200, 1600, 1500.0, 1520.0, 601.0, 795.5, {}, "synthetic pinhole")
    e0, n0 = _en0()
    specs = [(0, 0, 0, 0, 0), (150, 20, 10, -5, 90), (300, -40, -30, 20, -170), (-200, 400, 45, 0, 30),
             (80, -300, 0, -40, 179.5), (-350, -250, 5, 3, -60)]
    shots = {f"IMG_{i}": ApproxShot(f"IMG_{i}", "1" if i % 3 else "2", (e0 + dx, n0 + dy, 1200.0 + 7 * i), (o, p, k))
             for i, (dx, dy, o, p, k) in enumerate(specs)}
    return ApproximateBlock({"1": brown, "2": pin}, shots, UTM35S)


def _angle_diff(a, b):
    return np.abs((np.subtract(a, b) + 180.0) % 360.0 - 180.0)


def _check_same(got: ApproximateBlock, want: ApproximateBlock, tol_m: float, tol_deg: float, camera_ids=True):
    assert set(got.shots) == set(want.shots)
    for name, s in want.shots.items():
        g = got.shots[name]
        assert np.max(np.abs(np.subtract(g.position, s.position))) <= tol_m, name
        assert np.max(_angle_diff(g.angles, s.angles)) <= tol_deg, name
        a, b = got.camera_of(name), want.camera_of(name)
        assert a.camera.image_size == b.camera.image_size
        np.testing.assert_allclose([a.camera.fx, a.camera.fy, *a.camera.principal_point],
                                   [b.camera.fx, b.camera.fy, *b.camera.principal_point], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(a.distortion_tuple(), b.distortion_tuple(), rtol=1e-12, atol=1e-15)
        if camera_ids:
            assert g.camera_id == s.camera_id


# -- OpenSfM round trips --------------------------------------------------------------------------
# measured: topocentric 1.1e-8 m and 3e-14°, grid 1.9e-9 m and 0° (ECEF and UTM conversions in float64)
@pytest.mark.parametrize("frame, tol_m, tol_deg", [("topocentric", 1e-6, 1e-9), ("grid", 1e-6, 1e-9)])
def test_opensfm_round_trip_picks_the_frame_from_exif_gps(tmp_path, block, frame, tol_m, tol_deg):
    """The exif/ GPS with an RTK dop (2 cm) decides: the camera centres fit it in one reading only."""
    from dataclasses import replace
    path = tmp_path / "reconstruction.json"
    rtk = replace(block, shots={n: replace(s, sigma_h=0.02) for n, s in block.shots.items()})
    write_opensfm(path, rtk, (REF[0] + 0.001, REF[1] - 0.002, 950.0), frame=frame)
    assert isinstance(json.loads(path.read_text()), list) and (tmp_path / "exif" / "IMG_0.jpg.exif").is_file()
    got = read_opensfm(path)
    _check_same(got, block, tol_m, tol_deg)
    assert got.crs == UTM35S
    note = next(n for n in got.notes if "local frame" in n)
    assert note.startswith(f"OpenSfM local frame read as {frame}:"), got.notes
    assert all(s.height_reference is None for s in got.shots.values())


def test_opensfm_without_exif_or_images_is_refused_naming_sfm_frame(tmp_path, block):
    path = tmp_path / "reconstruction.json"
    write_opensfm(path, block, REF, frame="grid", exif=False)
    with pytest.raises(InputError, match="sfm_frame topocentric .* or grid") as err:
        read_opensfm(path)
    assert err.value.option == "sfm_frame" and "gps_position" in str(err.value)
    assert "too close to tell" in str(err.value)
    # the same file read as ODM's grid offsets gives the block back
    _check_same(read_opensfm(path, frame="grid"), block, 1e-6, 1e-9)


def test_opensfm_cameras_json_overrides_and_other_map_crs(tmp_path, block):
    path = tmp_path / "reconstruction.json"
    write_opensfm(path, block, REF, frame="grid")
    cam = opensfm_camera(block.cameras["1"])
    cam["focal_x"] = cam["focal_y"] = 0.9
    (tmp_path / "cameras.json").write_text(json.dumps({"1": cam}))
    got = read_opensfm(path, tmp_path / "cameras.json", frame="grid")
    assert got.cameras["1"].camera.fx == pytest.approx(0.9 * 4000)
    assert got.cameras["2"].camera.fx == pytest.approx(1500.0)
    # in UTM 34S (outside its zone) the positions are transformed and κ turned by the convergence difference
    utm34 = CRS.from_epsg(32734)
    other = read_opensfm(path, crs="EPSG:32734", frame="grid")
    s, o = block.shots["IMG_3"], other.shots["IMG_3"]
    back = Transformer.from_crs(utm34, UTM35S, always_xy=True).transform(*o.position[:2])
    assert np.allclose(back, s.position[:2], atol=1e-6) and o.position[2] == pytest.approx(s.position[2])
    assert abs(_angle_diff(o.angles[2], s.angles[2])) > 1.0  # ~2.5° of convergence between the zones


# -- a reconstruction.json written by hand ----------------------------------------------------------
def _hand_written(tmp_path, with_gps=False):
    """Three shots with poses worked out by hand (the reference is the origin of the local frame):

    * ``nadir``: at (0, 0, 300), looking down, image top to north: R = diag(1, −1, −1), a half turn
      about x; t = −R·C = (0, 0, 300); PATB ω = φ = κ = 0 in the local frame.
    * ``east``: at (120, −80, 250), looking down, image top to east: camera x = south, y = west, z = down,
      R = [[0, −1, 0], [−1, 0, 0], [0, 0, −1]], a half turn about (1, −1, 0)/√2; t = (−80, 120, 250);
      PATB: camera y (image up) = east, so κ = −90°.
    * ``oblique``: at (−50, 60, 200), tilted 30° from nadir towards north, image top to north: camera
      x = east, y = (0, −cos30, −sin30), z = (0, sin30, −cos30): a rotation of 150° about x; PATB
      R = Rx(30°): ω = 30°, φ = κ = 0; t = −R·C = (50, 60 cos30 + 200 sin30, 200 cos30 − 60 sin30).
    """
    brown = {"projection_type": "brown", "width": 4000, "height": 3000, "focal_x": 0.8, "focal_y": 0.81,
             "c_x": 0.01, "c_y": -0.02, "k1": -0.1, "k2": 0.02, "p1": 0.001, "p2": -0.002, "k3": 0.005}
    persp = {"projection_type": "perspective", "width": 3000, "height": 2000, "focal": 0.75, "k1": 0.0, "k2": 0.0}
    shots = {
        "nadir.JPG": {"rotation": [math.pi, 0.0, 0.0], "translation": [0.0, 0.0, 300.0], "camera": "brown"},
        "east.JPG": {"rotation": [math.pi / math.sqrt(2), -math.pi / math.sqrt(2), 0.0],
                     "translation": [-80.0, 120.0, 250.0], "camera": "persp"},
        "oblique.JPG": {"rotation": [5 * math.pi / 6, 0.0, 0.0],
                        "translation": [50.0, 60 * C30 + 200 * S30, 200 * C30 - 60 * S30], "camera": "brown"},
    }
    if with_gps:
        for s, c in zip(shots.values(), ([0, 0, 300], [120, -80, 250], [-50, 60, 200])):
            s["gps_position"] = c
    rec = [{"cameras": {"brown": brown, "persp": persp}, "shots": shots,
            "reference_lla": {"latitude": REF[0], "longitude": REF[1], "altitude": REF[2]}}]
    (tmp_path / "reconstruction.json").write_text(json.dumps(rec))
    return tmp_path / "reconstruction.json", rec[0]


def test_opensfm_hand_written_grid_reading(tmp_path):
    path, _ = _hand_written(tmp_path)
    got = read_opensfm(path, frame="grid")
    e0, n0 = _en0()
    want = {"nadir": ((0, 0, 300), (0, 0, 0)), "east": ((120, -80, 250), (0, 0, -90)),
            "oblique": ((-50, 60, 200), (30, 0, 0))}
    for name, (local, angles) in want.items():
        s = got.shots[name]
        # grid z is the altitude itself: export_geocoords adds the reference's (ODM's is at 0)
        np.testing.assert_allclose(s.position, (e0 + local[0], n0 + local[1], local[2]), atol=1e-6)
        assert np.max(_angle_diff(s.angles, angles)) < 1e-9, (name, s.angles)
    cam = got.cameras["brown"].camera
    assert cam.fx == pytest.approx(3200.0) and cam.fy == pytest.approx(3240.0)
    assert cam.principal_point == pytest.approx((2000 + 40.0, 1500 - 80.0))
    assert got.cameras["brown"].distortion == pytest.approx(dict(k1=-0.1, k2=0.02, k3=0.005, p1=0.001, p2=-0.002))
    assert got.cameras["persp"].camera.principal_point == (1500.0, 1000.0)


def test_opensfm_hand_written_topocentric_kappa_is_the_grid_convergence(tmp_path):
    path, _ = _hand_written(tmp_path)
    got = read_opensfm(path, frame="topocentric")
    assert got.frame_reading.startswith("OpenSfM local frame read as topocentric") and "as told" in got.frame_reading
    # the nadir camera is straight above the reference: same lon/lat, h = 1300; its image top points
    # to true north, whose grid bearing comes from a finite difference along the meridian
    t = Transformer.from_crs(4326, UTM35S, always_xy=True)
    p0, p1 = np.array(t.transform(REF[1], REF[0])), np.array(t.transform(REF[1], REF[0] + 1e-6))
    dE, dN = p1 - p0
    kappa = math.degrees(math.atan2(-dE, dN))  # PATB: camera y = (−sin κ, cos κ) = true north on the grid
    assert 0.8 < kappa < 0.9  # west of the central meridian 27°E, southern hemisphere
    s = got.shots["nadir"]
    np.testing.assert_allclose(s.position, (*p0, 1300.0), atol=1e-6)
    assert np.max(_angle_diff(s.angles, (0.0, 0.0, kappa))) < 1e-6


def _opensfm_pixel(cam: dict, shot: dict, X) -> np.ndarray:
    """OpenSfM's projection, written out from its documentation (geometry.rst): x_cam = R·X + t,
    Brown distortion on (x/z, y/z), u = f_x·x_d + c_x (normalised), then pixel (centre convention)
    = u·max(w, h) + (w − 1)/2, plus 0.5 for the corner convention."""
    from scipy.spatial.transform import Rotation
    R = Rotation.from_rotvec(shot["rotation"]).as_matrix()
    x, y, z = R @ np.asarray(X, float) + shot["translation"]
    xn, yn = x / z, y / z
    r2 = xn * xn + yn * yn
    g = cam.get
    dr = 1 + g("k1", 0) * r2 + g("k2", 0) * r2 ** 2 + g("k3", 0) * r2 ** 3
    xd = dr * xn + 2 * g("p1", 0) * xn * yn + g("p2", 0) * (r2 + 2 * xn * xn)
    yd = dr * yn + 2 * g("p2", 0) * xn * yn + g("p1", 0) * (r2 + 2 * yn * yn)
    fx, fy = g("focal_x", g("focal")), g("focal_y", g("focal"))
    u, v = fx * xd + g("c_x", 0.0), fy * yd + g("c_y", 0.0)
    m, w, h = max(cam["width"], cam["height"]), cam["width"], cam["height"]
    return np.array([u * m + (w - 1) / 2 + 0.5, v * m + (h - 1) / 2 + 0.5])


def test_opensfm_projection_agrees_with_fotogeo(tmp_path):
    path, rec = _hand_written(tmp_path)
    got = read_opensfm(path, frame="grid")
    e0, n0 = _en0()
    ground = np.array([[30.0, -20.0, 5.0], [-80.0, 140.0, -10.0], [60.0, 90.0, 0.0]])
    to_map = lambda g: np.array([e0 + g[0], n0 + g[1], g[2]])  # noqa: E731 (grid z: the altitude)
    for key, name in (("nadir.JPG", "nadir"), ("oblique.JPG", "oblique"), ("east.JPG", "east")):
        shot, cam_id = rec["shots"][key], rec["shots"][key]["camera"]
        cam = got.cameras[cam_id]
        for g in ground:
            want = _opensfm_pixel(rec["cameras"][cam_id], shot, g)
            R = (got.shots[name].exterior.rotation_cv)[None]
            interior = np.r_[cam.camera.focal_length, cam.camera.principal_point, cam.distortion_tuple()]
            px = project(R, np.array([got.shots[name].position]), to_map(g)[None], np.array([0]), np.array([0]),
                         interior, pixel_scale(cam.camera))[0]
            np.testing.assert_allclose(px, want, atol=1e-6)
            if not any(cam.distortion_tuple()):  # the distortion-free camera through OrientedFrame as well
                frame = OrientedFrame(cam.camera, got.shots[name].exterior)
                np.testing.assert_allclose(frame.world_to_pixel(to_map(g)[None])[0], want, atol=1e-6)


def test_opensfm_topocentric_projection_within_the_map_scale(tmp_path):
    """Read topocentrically, ground points converted the same way project as OpenSfM does once the map's
    scale is taken out of their horizontal offsets from the camera (the UTM scale factor k ≈ 0.99984 and
    the elevation factor R/(R + h) at h ≈ 1000 m: ~0.5 px at these distances): what is left (Earth
    curvature, ~0.05 px) checks the angles' turn by the convergence (0.84° would be ~30 px)."""
    from pyproj import Proj

    from fotogeo.geometry.local_frames import topocentric_to_lonlath
    path, rec = _hand_written(tmp_path)
    got = read_opensfm(path, frame="topocentric")
    ground = np.array([[30.0, -20.0, 5.0], [-80.0, 140.0, -10.0], [200.0, 50.0, 0.0]])
    llh = topocentric_to_lonlath(ground, REF)
    xy = np.column_stack(Transformer.from_crs(4326, UTM35S, always_xy=True).transform(llh[:, 0], llh[:, 1]))
    shot, s = rec["shots"]["east.JPG"], got.shots["east"]
    k = Proj(UTM35S).get_factors(REF[1], REF[0]).meridional_scale * 6371000.0 / (6371000.0 + REF[2])
    xy = s.position[:2] + (xy - s.position[:2]) / k
    frame = OrientedFrame(got.cameras["persp"].camera, s.exterior)
    px = frame.world_to_pixel(np.column_stack([xy, llh[:, 2]]))
    want = np.array([_opensfm_pixel(rec["cameras"]["persp"], shot, g) for g in ground])
    assert np.max(np.abs(px - want)) < 0.1


def test_opensfm_gps_position_without_exif_cannot_decide(tmp_path):
    path, _ = _hand_written(tmp_path, with_gps=True)
    with pytest.raises(InputError, match="sfm_frame"):
        read_opensfm(path)


def test_opensfm_reference_beside_and_several_reconstructions(tmp_path):
    """reference_lla.json beside the file when the reconstruction has none; the reconstruction chosen by index."""
    path, rec = _hand_written(tmp_path)
    ref = rec.pop("reference_lla")
    (tmp_path / "reference_lla.json").write_text(json.dumps(ref))
    small = {"cameras": rec["cameras"], "shots": {"nadir.JPG": rec["shots"]["nadir.JPG"]}}
    path.write_text(json.dumps([rec, small]))
    first, second = read_opensfm(path, frame="grid"), read_opensfm(path, frame="grid", reconstruction=1)
    assert set(first.shots) == {"nadir", "east", "oblique"} and set(second.shots) == {"nadir"}
    assert second.shots["nadir"].position == first.shots["nadir"].position
    assert any("reconstruction 1 of 2" in n for n in second.notes)
    _one_line_error(lambda: read_opensfm(path, reconstruction=2), "holds 2 reconstruction(s)")


# -- OpenSfM bad input -----------------------------------------------------------------------------
def _one_line_error(call, *words):
    with pytest.raises(InputError) as e:
        call()
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in words), msg
    return msg


def test_opensfm_bad_input(tmp_path):
    missing = tmp_path / "nope.json"
    _one_line_error(lambda: read_opensfm(missing), str(missing), "does not exist", "reconstruction.json")
    bad = tmp_path / "bad.json"
    bad.write_text('[{"cameras": {}, "shots": {')
    _one_line_error(lambda: read_opensfm(bad), str(bad), "not valid JSON", "line 1")
    path, rec = _hand_written(tmp_path)
    rec["cameras"]["brown"]["projection_type"] = "fisheye"
    path.write_text(json.dumps([rec]))
    _one_line_error(lambda: read_opensfm(path), str(path), "fisheye", "camera 'brown'", "--camera-lens brown")
    rec["shots"] = {}
    path.write_text(json.dumps([rec]))
    _one_line_error(lambda: read_opensfm(path), str(path), "no shots", "re-run")
    path.write_text(json.dumps([{"cameras": {}, "shots": {"a.jpg": {"rotation": [0, 0, 0], "translation": [0, 0, 0],
                                                                      "camera": "x"}}}]))
    _one_line_error(lambda: read_opensfm(path), str(path), "reference_lla")
    path.write_text(json.dumps({"not": "a list"}))
    _one_line_error(lambda: read_opensfm(path), str(path))


# -- COLMAP ----------------------------------------------------------------------------------------
def test_colmap_round_trip(tmp_path, block):
    write_colmap(tmp_path / "sparse", block)
    got = read_colmap(tmp_path / "sparse", crs="EPSG:32735")
    _check_same(got, block, 1e-6, 1e-9)  # measured: 9e-10 m, 0° (through the quaternion)
    assert "FULL_OPENCV" in (tmp_path / "sparse" / "cameras.txt").read_text()  # k3 ≠ 0


def test_colmap_hand_written(tmp_path):
    """A nadir camera north up: R = diag(1, −1, −1), the quaternion of a half turn about x is
    (w, x, y, z) = (0, 1, 0, 0); C = (500000, 6250000, 1200) so T = −R·C = (−500000, 6250000, 1200).
    A camera looking east (image top east, as in the OpenSfM test): half turn about (1, −1, 0)/√2,
    quaternion (0, 1/√2, −1/√2, 0), κ = −90°. COLMAP's principal point is already corner-convention."""
    d = tmp_path / "model"
    d.mkdir()
    (d / "cameras.txt").write_text("# Camera list\n1 SIMPLE_RADIAL 3072 2304 2559.69 1536.5 1152 -0.0218531\n"
                                   "2 PINHOLE 100 80 90.0 91.0 50.25 40.75\n")
    r = 1 / math.sqrt(2)
    (d / "images.txt").write_text(
        "# Image list with two lines of data per image:\n"
        "1 0 1 0 0 -500000 6250000 1200 1 dir/A.JPG\n"
        "2362.39 248.498 58396 1784.7 268.254 -1\n"
        f"2 0 {r!r} {-r!r} 0 6250000 500000 900 2 B.JPG\n")  # no points line after the last image
    got = read_colmap(d, crs=UTM35S)
    a, b = got.shots["A"], got.shots["B"]
    np.testing.assert_allclose(a.position, (500000, 6250000, 1200), atol=1e-6)
    assert np.max(_angle_diff(a.angles, (0, 0, 0))) < 1e-9
    np.testing.assert_allclose(b.position, (500000, 6250000, 900), atol=1e-6)
    assert np.max(_angle_diff(b.angles, (0, 0, -90))) < 1e-9
    cam = got.cameras["1"]
    assert cam.camera.principal_point == (1536.5, 1152.0) and cam.distortion["k1"] == -0.0218531
    assert (got.cameras["2"].camera.fx, got.cameras["2"].camera.fy) == pytest.approx((90.0, 91.0))


def test_colmap_bad_input(tmp_path, block):
    write_colmap(tmp_path / "m", block)
    _one_line_error(lambda: read_colmap(tmp_path / "m"), "no CRS", "model_aligner")
    _one_line_error(lambda: read_colmap(tmp_path / "m", crs="EPSG:4326"), "geographic")
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "cameras.bin").write_bytes(b"\0")
    _one_line_error(lambda: read_colmap(tmp_path / "bin", crs=UTM35S), "images.txt or images.bin")
    (tmp_path / "bin" / "images.bin").write_bytes(b"\0" * 8)
    _one_line_error(lambda: read_colmap(tmp_path / "bin", crs=UTM35S), "cameras.bin", "ends early", "model_converter")
    (tmp_path / "m" / "cameras.txt").write_text("1 OPENCV_FISHEYE 100 100 50 50 50 50 0 0 0 0\n")
    _one_line_error(lambda: read_colmap(tmp_path / "m", crs=UTM35S), "OPENCV_FISHEYE", "line 1", "cameras.txt")
    (tmp_path / "m" / "cameras.txt").write_text("1 FULL_OPENCV 100 100 50 50 50 50 0 0 0 0 0 0.1 0 0\n")
    _one_line_error(lambda: read_colmap(tmp_path / "m", crs=UTM35S), "k4, k5, k6")


# -- orthority -------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["geojson", "csv-degrees", "csv-radians"])
def test_orthority_round_trip(tmp_path, block, fmt):
    write_orthority_interior(tmp_path / "int.yaml", block.cameras)
    if fmt == "geojson":
        ext = tmp_path / "ext.geojson"
        write_orthority_geojson(ext, block)
        feat = json.loads(ext.read_text())["features"][0]
        assert feat["geometry"]["coordinates"][:2] == pytest.approx([REF[1], REF[0]], abs=1e-6)
    else:
        ext = tmp_path / "ext.csv"
        write_orthority_csv(ext, block, radians=fmt.endswith("radians"))
    got = read_orthority(ext, tmp_path / "int.yaml", radians=fmt.endswith("radians"))
    _check_same(got, block, 1e-6, 1e-9)  # measured: 0 m, 0°
    assert got.crs == UTM35S


def test_orthority_documented_examples(tmp_path):
    """orthority's interior example (docs/file_formats/oty_int.rst, a normalised focal without sensor
    size) and a legacy header-less space-delimited CSV, i.e. fotogeo's exterior_orientation.txt."""
    (tmp_path / "int.yaml").write_text(
        "Pinhole camera:\n    type: pinhole\n    im_size: [150, 200]\n    focal_len: 120.\n"
        "    sensor_size: [75., 100.]\n    cx: -0.01\n    cy: 0.02\n"
        "Brown camera:\n    type: brown\n    im_size: [400, 300]\n    focal_len: 0.8333\n    cx: -0.01\n"
        "    cy: 0.02\n    k1: -0.25\n    k2: 0.2\n    p1: 0.01\n    p2: 0.01\n    k3: -0.1\n")
    cams = read_orthority_interior(tmp_path / "int.yaml")
    pin, brown = cams["Pinhole camera"], cams["Brown camera"]
    assert (pin.camera.fx, pin.camera.fy) == pytest.approx((240.0, 240.0))
    assert pin.camera.principal_point == pytest.approx((75 - 2.0, 100 + 4.0))
    assert brown.camera.fx == pytest.approx(0.8333 * 400) and brown.camera.principal_point == pytest.approx((196, 158))
    assert brown.distortion == dict(k1=-0.25, k2=0.2, k3=-0.1, p1=0.01, p2=0.01)
    (tmp_path / "ext.csv").write_text("a.tif 100.0 200.0 3000.0 1.5 -2.0 -179.0 \n  b.tif 150 250 3010 0 0 90\n")
    (tmp_path / "ext.prj").write_text("EPSG:32735")
    with pytest.raises(InputError, match="names no camera"):
        read_orthority(tmp_path / "ext.csv", tmp_path / "int.yaml")
    (tmp_path / "one.yaml").write_text("c:\n    type: pinhole\n    im_size: [150, 200]\n    focal_len: 0.5\n")
    got = read_orthority(tmp_path / "ext.csv", tmp_path / "one.yaml")
    assert got.shots["a"].position == (100.0, 200.0, 3000.0) and got.shots["a"].angles == (1.5, -2.0, -179.0)
    assert got.shots["b"].camera_id == "c" and got.crs == UTM35S


def test_orthority_bad_input(tmp_path, block):
    write_orthority_interior(tmp_path / "int.yaml", block.cameras)
    for header, words in (("filename,latitude,longitude,altitude,omega,phi,kappa", ("latitude", "x, y, z")),
                          ("filename,x,y,z,roll,pitch,yaw", ("roll", "omega, phi, kappa")),
                          ("filename,x,y,z,omega,phi", ("lacks kappa",))):
        (tmp_path / "e.csv").write_text(header + "\na.jpg,1,2,3,4,5,6\n")
        _one_line_error(lambda: read_orthority(tmp_path / "e.csv", tmp_path / "int.yaml", crs=UTM35S), *words)
    (tmp_path / "e.csv").write_text("filename,x,y,z,omega,phi,kappa,camera\na.jpg,1,2,3,4,5,6,9\n")
    _one_line_error(lambda: read_orthority(tmp_path / "e.csv", tmp_path / "int.yaml"), "no CRS")
    _one_line_error(lambda: read_orthority(tmp_path / "e.csv", tmp_path / "int.yaml", crs=UTM35S), "camera '9'")
    (tmp_path / "f.yaml").write_text("f:\n    type: fisheye\n    im_size: [10, 10]\n    focal_len: 1.0\n")
    _one_line_error(lambda: read_orthority_interior(tmp_path / "f.yaml"), "fisheye", "line 1")


def test_orthority_reads_the_ngi_files_like_fotogeo(data_dir):
    """orthority reads the NGI camera YAML and exterior_orientation.txt (as CSV) unchanged: so does this reader."""
    from fotogeo.io.camera import read_exterior_orientation, read_interior_orientation
    ngi = data_dir / "ngi"
    crs = "+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84"
    got = read_orthority(ngi / "exterior_orientation.txt", ngi / "interior_orientation.yaml", crs=crs)
    eos, (cam,) = read_exterior_orientation(ngi / "exterior_orientation.txt"), read_interior_orientation(
        ngi / "interior_orientation.yaml").values()
    assert set(got.shots) == set(eos)
    for name, eo in eos.items():
        assert got.shots[name].exterior == eo
        assert got.camera_of(name).camera == cam


def _odm_shots(folder):
    """ODM's shots.geojson (filename, focal, width, height, translation, rotation: ODM's opendm/shots.py) in
    ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    props = {"filename": "a.jpg", "focal": 0.8, "width": 800, "height": 600,
             "translation": [271950.1, 5209459.7, 379.5], "rotation": [2.63, -0.1, 0.03]}
    shots = folder / "shots.geojson"
    shots.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": props, "geometry": {"type": "Point", "coordinates": [12.0, 47.0, 379.5]}}]}))
    return shots


@pytest.mark.parametrize("with_camera", [False, True])
def test_odm_shots_geojson_is_refused_naming_the_reconstruction(tmp_path, block, with_camera):
    """ODM's odm_report/shots.geojson (filename, focal, width, height, translation, rotation: ODM's opendm/shots.py)
    given where orthority's exterior parameters are read: refused by name, with or without a camera YAML, naming the
    same project's opensfm/reconstruction.json (not numpy's reshape error, not a request for --camera)."""
    from fotogeo.io.orientation_file import read_orientation_file
    write_orthority_interior(tmp_path / "int.yaml", block.cameras)
    shots = _odm_shots(tmp_path / "proj" / "odm_report")
    rec = tmp_path / "proj" / "opensfm" / "reconstruction.json"
    rec.parent.mkdir()
    rec.write_text("[]")  # named by its path only where it is (test_odm_shots_geojson_without_its_reconstruction)
    want = ("ODM's shots.geojson", str(rec))
    _one_line_error(lambda: read_orientation_file(shots, camera=tmp_path / "int.yaml" if with_camera else None), *want)
    if with_camera:
        _one_line_error(lambda: read_orthority(shots, tmp_path / "int.yaml", crs=UTM35S), *want)


def test_odm_shots_geojson_without_its_reconstruction_names_where_odm_writes_it(tmp_path):
    """shots.geojson alone (downloaded without its project): the refusal named a reconstruction.json beside it that
    is not there; it says where ODM writes one instead."""
    from fotogeo.io.orientation_file import read_orientation_file
    shots = _odm_shots(tmp_path)
    msg = _one_line_error(lambda: read_orientation_file(shots), "ODM's shots.geojson",
                          "the reconstruction ODM writes in the project's folder", "opensfm/reconstruction.json (--eo)")
    assert str(tmp_path / "opensfm") not in msg, msg
