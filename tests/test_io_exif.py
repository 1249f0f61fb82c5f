"""Drone image metadata -> ApproximateBlock (fotogeo.io.exif, fotogeo.io.geoinfo): the real senseFly
eBee images of ../shared/data/drone_snowpeak, and small synthetic JPEG/TIFF files written by GDAL
with EXIF items and an XMP packet (DJI-like, Parrot-like, corrupt)."""
from __future__ import annotations

import math
import shutil
import struct
import warnings

import numpy as np
import pytest
import rasterio.shutil

from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.geometry.attitude import enu_rotation_from_patb, rotation_from_ypr
from fotogeo.io.exif import read_image_metadata
from fotogeo.io.exif_block import read_exif_block
from fotogeo.io.geoinfo import read_geoinfo
from fotogeo.io.raster import ropen

FOCAL_PX = 4.3 * 18963 / 25.4  # EXIF FocalLength (mm) x FocalPlaneXResolution (px/inch) / 25.4

# -- synthetic files --------------------------------------------------------------------------


def xmp_packet(body: str, ns: str = "xmlns:drone-dji='http://www.dji.com/drone-dji/1.0/'") -> str:
    return ("<?xpacket begin='\ufeff' id='W5M0MpCehiHzreSzNTczkc9d'?>\n<x:xmpmeta xmlns:x='adobe:ns:meta/'>"
            "<rdf:RDF xmlns:rdf='http://www.w3.org/1999/02/22-rdf-syntax-ns#'>"
            f"<rdf:Description rdf:about='' {ns}{body}</rdf:Description></rdf:RDF></x:xmpmeta>\n<?xpacket end='w'?>")


def write_image(path, tags: dict, xmp: str | None = None, size=(64, 48)):
    """A small RGB image carrying EXIF_* items and an XMP packet, as GTiff (metadata items and the
    xml:XMP domain) or JPEG (GDAL writes the EXIF segment; the XMP APP1 segment is added here,
    since GDAL's JPEG driver does not write one)."""
    w, h = size
    tif = path.with_suffix(".tif") if path.suffix.lower() != ".tif" else path
    with ropen(tif, "w", driver="GTiff", width=w, height=h, count=3, dtype="uint8") as d:
        d.write(np.full((3, h, w), 90, np.uint8))
        d.update_tags(**tags)
        if xmp is not None and tif == path:
            head, tail = xmp.split("=", 1)  # rasterio writes "key=value": the packet itself
            d.update_tags(ns="xml:XMP", **{head: tail})
    if tif == path:
        return path
    rasterio.shutil.copy(tif, path, driver="JPEG")
    tif.unlink()
    for aux in path.parent.glob(path.name + ".aux.xml"):
        aux.unlink()  # read the JPEG's own EXIF, not GDAL's sidecar copy
    if xmp is not None:
        data = path.read_bytes()
        payload = b"http://ns.adobe.com/xap/1.0/\x00" + xmp.encode()
        path.write_bytes(data[:2] + b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload + data[2:])
    return path


DJI_TAGS = {"EXIF_Make": "DJI", "EXIF_Model": "FC6310R", "EXIF_GPSLatitude": "(33) (51) (18)",
            "EXIF_GPSLatitudeRef": "S", "EXIF_GPSLongitude": "(151) (12) (36)", "EXIF_GPSLongitudeRef": "E",
            "EXIF_GPSAltitude": "(130.5)", "EXIF_GPSAltitudeRef": "0x00", "EXIF_FocalLength": "(8.8)",
            "EXIF_FocalLengthIn35mmFilm": "24"}
DJI_XMP = xmp_packet(" drone-dji:AbsoluteAltitude='+130.52' drone-dji:RelativeAltitude='+100.10'"
                     " drone-dji:GimbalRollDegree='+0.00' drone-dji:GimbalYawDegree='-90.00'"
                     " drone-dji:GimbalPitchDegree='-60.00' drone-dji:FlightYawDegree='-88.5'>"
                     "<drone-dji:RtkFlag>50</drone-dji:RtkFlag><drone-dji:RtkStdLon>0.012</drone-dji:RtkStdLon>"
                     "<drone-dji:RtkStdLat>0.016</drone-dji:RtkStdLat><drone-dji:RtkStdHgt>0.03</drone-dji:RtkStdHgt>"
                     "<drone-dji:DewarpData>2018-09-06;40.5,40.1,2.25,-1.5,-0.263,0.107,0.0000371,-0.000327,"
                     "-0.0301</drone-dji:DewarpData>")


@pytest.mark.parametrize("suffix", [".jpg", ".tif"])
def test_dji_like_image(tmp_path, suffix):
    path = write_image(tmp_path / f"DJI_0001{suffix}", DJI_TAGS, DJI_XMP)
    m = read_image_metadata(path)
    assert m.lat == pytest.approx(-(33 + 51 / 60 + 18 / 3600)) and m.lon == pytest.approx(151.21)
    assert (m.altitude, m.altitude_tag) == (130.52, "drone-dji:AbsoluteAltitude")
    assert m.x("drone-dji:GimbalYawDegree") == -90.0 and m.xs("drone-dji:RtkFlag") == "50"
    b = read_exif_block([path])
    assert b.crs.to_epsg() == 32756  # UTM 56S
    shot = b.shots["DJI_0001"]
    assert shot.height_reference == "ellipsoid" and "gimbal" in shot.source
    assert shot.sigma_h == pytest.approx(math.sqrt((0.012 ** 2 + 0.016 ** 2) / 2)) and shot.sigma_v == 0.03
    R = enu_rotation_from_patb(shot.angles, m.lon, m.lat, b.crs)
    np.testing.assert_allclose(R, rotation_from_ypr(-90, -60, 0), atol=1e-9)
    cam = b.camera_of("DJI_0001")
    assert cam.source == "drone-dji:DewarpData"
    assert (cam.camera.fx, cam.camera.fy) == pytest.approx((40.5, 40.1))
    assert cam.camera.principal_point == pytest.approx((32 + 2.25, 24 - 1.5))
    assert cam.distortion_tuple() == pytest.approx((-0.263, 0.107, -0.0301, 0.0000371, -0.000327))
    assert list(b.cameras) == ["DJI FC6310R 64x48 8.8mm"]


def test_corrupt_xmp_warns_and_keeps_the_exif(tmp_path):
    path = write_image(tmp_path / "bad.jpg", DJI_TAGS, DJI_XMP.replace("</rdf:Description>", "</rdf:Descr"))
    with pytest.warns(FotogeoWarning, match=r"bad\.jpg.*XMP.*ignored"):
        m = read_image_metadata(path)
    assert m.xmp == {} and m.altitude == 130.5 and m.altitude_tag == "EXIF GPSAltitude"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        b = read_exif_block([path])
    shot = b.shots["bad"]
    assert shot.angles is None and shot.height_reference is None  # DJI without RTK tags: barometric


def test_exif_only_image_refs_units_and_35mm(tmp_path):
    tags = {"EXIF_Make": "ACME", "EXIF_Model": "Cam 1", "EXIF_GPSLatitude": "(10) (30) (0)",
            "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": "(70) (15) (0)", "EXIF_GPSLongitudeRef": "W",
            "EXIF_GPSAltitude": "(12.5)", "EXIF_GPSAltitudeRef": "0x01", "EXIF_FocalLengthIn35mmFilm": "24",
            "EXIF_FocalLength": "(5)", "EXIF_GPSImgDirection": "(45)"}
    m = read_image_metadata(write_image(tmp_path / "a.jpg", tags))
    assert (m.lon, m.lat, m.altitude) == pytest.approx((-70.25, 10.5, -12.5))
    assert m.gps_img_direction == 45.0 and m.focal_plane_ppmm is None
    b = read_exif_block([m.path])
    assert b.cameras["ACME Cam 1 64x48 5mm"].camera.fx == pytest.approx(24 * math.hypot(64, 48) / 43.2666, rel=1e-5)
    assert b.shots["a"].angles is None and b.shots["a"].height_reference is None
    assert any("height reference: unknown" in n for n in b.notes)
    # focal plane resolution in centimetres: 5 mm x 1000 px/cm / 10 = 500 px
    tags.update(EXIF_FocalPlaneXResolution="(1000)", EXIF_FocalPlaneYResolution="(1000)",
                EXIF_FocalPlaneResolutionUnit="3")
    # ... which contradicts the 35 mm equivalent (44 px): named, not arbitrated — by the frame the focal plane
    # resolution describes over the sensor the 35 mm equivalent implies (9.01 mm diagonal at 100 px/mm)
    with pytest.raises(InputError, match=r"FocalPlaneXResolution/YResolution \(100\.0, 100\.0 px/mm\) over the sensor "
                                         r"that FocalLength 5 mm and FocalLengthIn35mmFilm 24 mm imply describe a "
                                         r"721x541 frame but the file is 64x48"):
        read_exif_block([write_image(tmp_path / "c.tif", tags)])
    tags.pop("EXIF_FocalLengthIn35mmFilm")
    b = read_exif_block([write_image(tmp_path / "b.tif", tags)])
    assert next(iter(b.cameras.values())).camera.fx == pytest.approx(500.0)


def test_parrot_and_pix4d_camera_tags(tmp_path):
    base = {**DJI_TAGS, "EXIF_Make": "Parrot", "EXIF_Model": "Anafi", "EXIF_FocalPlaneXResolution": "(200)",
            "EXIF_FocalPlaneResolutionUnit": "4"}
    base.pop("EXIF_FocalLengthIn35mmFilm")  # 24 mm on a 64 x 48 file would contradict the 1760 px (refused)
    parrot = xmp_packet("><drone-parrot:CameraYawDegree>30</drone-parrot:CameraYawDegree>"
                        "<drone-parrot:CameraPitchDegree>-90</drone-parrot:CameraPitchDegree>"
                        "<drone-parrot:CameraRollDegree>0</drone-parrot:CameraRollDegree>",
                        "xmlns:drone-parrot='http://www.parrot.com/drone-parrot/1.0/'")
    pix4d = xmp_packet("><Camera:Yaw>30</Camera:Yaw><Camera:Pitch>0</Camera:Pitch><Camera:Roll>0</Camera:Roll>"
                       "<Camera:PerspectiveFocalLength>4.0</Camera:PerspectiveFocalLength>",
                       "xmlns:Camera='http://pix4d.com/camera/1.0/'")
    b = read_exif_block([write_image(tmp_path / "p.jpg", base, parrot),
                         write_image(tmp_path / "q.jpg", {**base, "EXIF_Model": "Sequoia"}, pix4d)])
    assert sorted(b.cameras) == ["Parrot Anafi 64x48 8.8mm", "Parrot Sequoia 64x48 8.8mm"]  # grouped by id
    assert b.cameras["Parrot Sequoia 64x48 8.8mm"].camera.fx == pytest.approx(800.0)  # 4.0 mm x 200 px/mm
    assert b.cameras["Parrot Anafi 64x48 8.8mm"].camera.fx == pytest.approx(8.8 * 200)
    # both say: nadir, image top at 30°: the same PATB angles
    np.testing.assert_allclose(b.shots["p"].angles, b.shots["q"].angles, atol=1e-9)
    assert "gimbal" in b.shots["p"].source and "aircraft body" in b.shots["q"].source


def test_images_without_gps_keep_no_position(tmp_path):
    a = write_image(tmp_path / "a.jpg", DJI_TAGS)
    b = write_image(tmp_path / "nogps.jpg", {"EXIF_Make": "DJI", "EXIF_FocalLength": "(8.8)",
                                             "EXIF_FocalLengthIn35mmFilm": "24"})
    blk = read_exif_block([a, b])
    assert blk.shots["nogps"].position is None and blk.shots["a"].position is not None
    assert any("without a GPS position: nogps" in n and "--eo or --gcps" in n for n in blk.notes)
    with pytest.raises(InputError, match="same name"):
        read_exif_block([a, a])


def test_crs_far_from_the_gps_is_refused(tmp_path):
    path = write_image(tmp_path / "a.jpg", DJI_TAGS)  # 151.21 E, 33.86 S: UTM 56S
    with pytest.raises(InputError, match=r"--crs EPSG:32655 .*EPSG:32756"):
        read_exif_block([path], crs="EPSG:32655")  # the neighbouring zone: outside its area of use
    with pytest.raises(InputError, match=r"--crs .*more than 10° from its central meridian 25.*EPSG:32756"):
        read_exif_block([path], crs="+proj=tmerc +lon_0=25 +ellps=WGS84 +units=m")  # no area of use
    with pytest.raises(InputError, match=r"--crs EPSG:3857 .*scale is 1.2"):
        read_exif_block([path], crs="EPSG:3857")  # Web Mercator: covers the world, but 20 % too large here
    with pytest.raises(InputError, match="--crs EPSG:4326 is geographic"):
        read_exif_block([path], crs="EPSG:4326")
    assert read_exif_block([path], crs="EPSG:28356").crs.to_epsg() == 28356  # GDA94 / MGA 56


def test_geoinfo_parsing_and_mixed_height_references(tmp_path):
    geo = tmp_path / "geoinfo.txt"
    geo.write_text("#Rev: sensefly/geoinfo/2\nfileName\tlatitude\tlongitude\taltitude_amsl\theading\tpitch\troll\n"
                   "a.JPG\t-33.855\t151.21\t110.0\t90\t0\t0\t\n")
    rec = read_geoinfo(geo)["a"]
    assert rec.height() == (110.0, "geoid") and rec.attitude == (90.0, 0.0, 0.0)
    b = read_exif_block([write_image(tmp_path / "a.jpg", {**DJI_TAGS, "EXIF_Make": "ACME"})], geoinfo=geo)
    assert b.shots["a"].position[2] == 110.0 and b.shots["a"].height_reference == "geoid"
    rtk = write_image(tmp_path / "r.jpg", DJI_TAGS, DJI_XMP)  # DJI RTK: ellipsoidal
    with pytest.raises(InputError, match=r"'r' has an ellipsoidal height \(DJI drone-dji:AbsoluteAltitude\) but 'a' "
                                         r"a geoid \(sea-level\) height \(geoinfo altitude_amsl\)"), \
            pytest.warns(FotogeoWarning, match="no line for 1 image"):  # r is not in the geoinfo
        read_exif_block([tmp_path / "a.jpg", rtk], geoinfo=geo)
    plain = write_image(tmp_path / "p.jpg", {**DJI_TAGS, "EXIF_Make": "ACME"})  # no vendor rule: unknown
    with pytest.warns(FotogeoWarning, match=r"ellipsoid but those of p \(ACME EXIF GPSAltitude\) have an unknown"):
        b = read_exif_block([plain, rtk])
    assert b.shots["p"].height_reference is None and any("reference is unknown" in n for n in b.notes)
    with pytest.raises(InputError, match=r"geoinfo.txt' lists none of the images \(r; it lists a …\); give the geoinfo"):
        read_exif_block([rtk], geoinfo=geo)  # another flight's file: refused, not ignored in silence
    with pytest.warns(FotogeoWarning, match=r"geoinfo.txt' has no line for 1 image\(s\) \(r\): their own EXIF/XMP"), \
            pytest.warns(FotogeoWarning, match="geoid but those of r .* unknown reference"):
        read_exif_block([tmp_path / "a.jpg", write_image(tmp_path / "r.jpg", {**DJI_TAGS, "EXIF_Make": "ACME"})],
                        geoinfo=geo)
    geo.write_text("fileName\tlatitude\n")
    with pytest.raises(InputError, match="geoinfo.txt.* lacks longitude"):
        read_geoinfo(geo)
    geo.write_text("fileName\tlatitude\tlongitude\taltitude_wgs84\na.JPG\t-33.8\tx\t100\n")
    with pytest.raises(InputError, match="line 2: longitude 'x' is not a number"):
        read_geoinfo(geo)


# -- the real senseFly eBee flight ------------------------------------------------------------


@pytest.fixture(scope="module")
def snowpeak(data_dir, tmp_path_factory):
    src = data_dir / "drone_snowpeak"
    if not src.is_dir():
        pytest.skip(f"real test data not found at {src} (an older ../shared/data without drone_snowpeak)")
    dst = tmp_path_factory.mktemp("snowpeak")  # copies: GDAL may write .aux.xml sidecars
    for p in sorted((src / "img").glob("*.JPG")):
        shutil.copy(p, dst / p.name)
    shutil.copy(src / "snowpea1_geoinfo.txt", dst)
    return dst


def test_snowpeak_positions_camera_and_crs(snowpeak):
    paths = sorted(snowpeak.glob("*.JPG"))
    m = read_image_metadata(snowpeak / "IMG_2280.JPG")
    assert (m.make, m.model, m.width, m.height) == ("Canon", "Canon IXUS 125 HS", 4608, 3456)
    assert (m.lat, m.lon, m.altitude) == pytest.approx((37 + 32 / 60 + 41.5838 / 3600, 139 + 2 / 60 + 46.9817 / 3600,
                                                        262.075))
    b = read_exif_block(paths)
    assert b.crs.to_epsg() == 32654 and "UTM zone of the mean GPS position" in b.notes[0]
    (cid, cam), = b.cameras.items()
    assert cid == "Canon IXUS 125 HS 4608x3456 4.3mm"
    assert cam.camera.fx == pytest.approx(FOCAL_PX) and cam.camera.fx == pytest.approx(3210.27, abs=0.01)
    assert len(b.shots) == 8 and all(s.position and s.angles for s in b.shots.values())
    assert {s.height_reference for s in b.shots.values()} == {"ellipsoid"}
    assert b.shots["IMG_2280"].sigma_h == pytest.approx(5.825) and b.shots["IMG_2280"].sigma_v == pytest.approx(5.59)
    # consecutive frames of one strip are about 41 m apart, heading 308°
    p0, p1 = (np.array(b.shots[n].position) for n in ("IMG_2280", "IMG_2281"))
    assert np.hypot(*(p1 - p0)[:2]) == pytest.approx(41.2, abs=0.5)


def test_snowpeak_geoinfo_attitude_and_positions(snowpeak):
    geo = read_geoinfo(snowpeak / "snowpea1_geoinfo.txt")
    assert len(geo) == 140 and geo["IMG_2280"].attitude == pytest.approx((307.8600158691, 11.5980081558, -0.4017916322))
    paths = sorted(snowpeak.glob("*.JPG"))
    exif, gi = read_exif_block(paths), read_exif_block(paths, geoinfo=geo)
    for n, s in gi.shots.items():
        assert s.source.startswith("position: geoinfo; angles: geoinfo")
        np.testing.assert_allclose(s.position, exif.shots[n].position, atol=0.01)  # EXIF = geoinfo's wgs84
        np.testing.assert_allclose(s.angles, exif.shots[n].angles, atol=1e-6)  # XMP = geoinfo's attitude


def _shift(a, b, dec=8):
    """Median image shift (col, row, full-resolution px) of the ground from frame a to frame b, and
    the matched points of a (SIFT on images decimated by ``dec``)."""
    import cv2
    from rasterio.enums import Resampling

    def grey(p):
        with ropen(p) as s:
            arr = s.read(out_shape=(3, s.height // dec, s.width // dec), resampling=Resampling.average)
        return cv2.cvtColor(np.moveaxis(arr, 0, -1), cv2.COLOR_RGB2GRAY)
    sift = cv2.SIFT_create(4000)
    (ka, da), (kb, db) = (sift.detectAndCompute(grey(p), None) for p in (a, b))
    good = [m for m, n in cv2.BFMatcher().knnMatch(da, db, k=2) if m.distance < 0.75 * n.distance]
    pa = np.array([ka[g.queryIdx].pt for g in good]) * dec + dec / 2
    pb = np.array([kb[g.trainIdx].pt for g in good]) * dec + dec / 2
    inl = cv2.findHomography(pa, pb, cv2.RANSAC, 30.0)[1].ravel().astype(bool)
    return np.median(pb[inl] - pa[inl], axis=0), pa[inl]


@pytest.mark.parametrize("a, b", [("IMG_2280", "IMG_2281"), ("IMG_2281", "IMG_2282")])
def test_snowpeak_image_top_points_along_the_flight(snowpeak, a, b):
    """senseFly's camera convention checked on the images: the ground moves towards the image
    bottom between consecutive frames of a strip (image top = flight direction), in the direction a
    nadir camera turned by the heading predicts (the autopilot's pitch and roll, up to 12° here,
    are left out: they are not the camera's exact attitude)."""
    from fotogeo.geometry.attitude import patb_in_map, rotation_from_body_ypr
    from fotogeo.geometry.camera import ExteriorOrientation, OrientedFrame
    blk = read_exif_block(sorted(snowpeak.glob("*.JPG")))
    measured, pts = _shift(snowpeak / f"{a}.JPG", snowpeak / f"{b}.JPG")
    assert measured[1] > 800 and abs(measured[0]) < 0.3 * measured[1]  # along +row: ~960 px

    def predicted(turn):
        frames = []
        for n in (a, b):
            m = read_image_metadata(snowpeak / f"{n}.JPG")
            angles = patb_in_map(rotation_from_body_ypr(m.x("sensefly:Yaw") + turn, 0, 0), m.lon, m.lat, blk.crs)
            frames.append(OrientedFrame(blk.camera_of(n).camera, ExteriorOrientation(*blk.shots[n].position, *angles)))
        ground = frames[0].pixel_to_world_at(pts, blk.shots[a].position[2] - 137.0)  # ~137 m above ground
        p = np.median(frames[1].world_to_pixel(ground) - pts, axis=0)
        cross = p[0] * measured[1] - p[1] * measured[0]  # numpy 2 np.cross takes 3-vectors only
        return abs(math.degrees(math.atan2(cross, p @ measured)))
    # measured: 0.4° and 24° off; the image top backwards: 162° and 175° off
    assert predicted(0.0) < 35 and predicted(180.0) > 145
