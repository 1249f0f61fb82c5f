"""An SfM file's local frame is decided by evidence or refused by name; SfM files that disagree with the images'
own GPS are refused (fotogeo.io.sfm_frame).

A rendered oblique drone block at 69.6° N, 2.9° east of UTM 33N's central meridian — where ODM's grid offsets and
OpenSfM's topocentric frame part most (the meridian convergence is 2.7° there) — with a DJI RTK fix (σ 2 cm) in
every frame's EXIF/XMP. Its true orientation is written as ODM would (grid offsets from UTM(reference_lla), each
shot's ``gps_position`` the image's GPS in the topocentric frame, as export_geocoords leaves it), with and without
OpenSfM's ``exif/`` folder (the RTK σ as its dop), and read
with and without the images; a copy of the images without accuracy tags (a consumer receiver, σ 2 m) and one
without any GPS are the cases where nothing decides.
"""
from __future__ import annotations

import json
import shutil
import warnings

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from pyproj import CRS, Transformer

import rendered_oblique as ro
from cli_output import not_progress
from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.geometry.approx_block import ApproxCamera, ApproximateBlock, ApproxShot
from fotogeo.geometry.local_frames import LocalFrame
from fotogeo.io.colmap import write_colmap
from fotogeo.io.opensfm import write_opensfm
from fotogeo.io.orientation_file import read_orientation_file
from fotogeo.io.orthority import write_orthority_csv, write_orthority_interior
from fotogeo.io.sfm_frame import separation

LAT, LON = 69.6, 17.9
UTM33 = CRS.from_epsg(32633)
ORIGIN = tuple(Transformer.from_crs(4326, UTM33, always_xy=True).transform(LON, LAT))


def _retag(src, dst, *, rtk: bool = True, gps: bool = True, shift=(0.0, 0.0)):
    """A copy of the rendered frame ``src`` with its RTK tags and/or its GPS position dropped."""
    with rasterio.open(src) as ds:
        img, tags, xmp = ds.read(1), ds.tags(), ds.tags(ns="xml:XMP")
    if not gps:
        tags = {k: v for k, v in tags.items() if not k.startswith("EXIF_GPS")}
    if not rtk:
        xmp = {k: _drop_rtk(v) for k, v in xmp.items()}  # the packet is the one item of the xml:XMP domain
    ro._write(dst, img, tags, next(iter(xmp.values())))
    return dst


def _drop_rtk(packet: str) -> str:
    import re
    return re.sub(r" drone-dji:Rtk\w+='[^']*'", "", packet)


@pytest.fixture(scope="module")
def odm(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("odm_high_lat")
    blk = ro.oblique_block(tmp / "render", seed=5, per_strip=3, place=(UTM33.to_string(), ORIGIN), rtk=0.02)
    paths = blk["gimbal"]
    consumer, bare = tmp / "consumer", tmp / "bare"
    consumer.mkdir()
    bare.mkdir()
    # the consumer copy: its GPS 2 m off (as a receiver without RTK), no accuracy tags
    rng = np.random.default_rng(1)
    cons = []
    for p in paths:
        with rasterio.open(p) as ds:
            img, tags, xmp = ds.read(1), ds.tags(), ds.tags(ns="xml:XMP")
        name = p.stem
        e = blk["truth"][name]
        gps_xyz = np.array([e.X, e.Y, e.Z]) + np.r_[rng.normal(0, 2.0, 2), 0.0]
        t2, x2 = ro._tags(gps_xyz, (0.0, -60.0, 0.0), False, UTM33.to_string())
        tags.update({k: v for k, v in t2.items() if k.startswith("EXIF_GPS")})
        ro._write(consumer / p.name, img, tags, _drop_rtk(next(iter(xmp.values()))))
        cons.append(consumer / p.name)
    nogps = [_retag(p, bare / p.name, gps=False) for p in paths]
    dist = dict(zip(("k1", "k2", "p1", "p2", "k3"), ro.DEWARP))
    shots = {n: ApproxShot(n, "cam", (e.X, e.Y, e.Z), (e.omega, e.phi, e.kappa)) for n, e in blk["truth"].items()}
    truth = ApproximateBlock({"cam": ApproxCamera(blk["camera"], dist)}, shots, UTM33)
    ref = (LAT, LON, 300.0)
    return dict(blk=blk, rtk=paths, consumer=cons, bare=nogps, truth=truth, ref=ref, tmp=tmp)


def _image_gps(paths):
    from fotogeo.io.sfm_frame import images_gps
    g = images_gps(paths)
    return {n: (f.lon, f.lat, f.alt) for n, f in g.items()}


def _odm_file(folder, odm, *, frame="grid", exif=False, gps_position=True, images=None):
    """The truth as ODM writes it: the poses as local offsets in ``frame`` (export_geocoords' grid), each shot's
    gps_position the image's GPS in the topocentric frame (as OpenSfM wrote it before that export) and, with
    ``exif``, OpenSfM's exif/ with the image's GPS and its RTK σ as dop (ODM's exif overrides)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "reconstruction.json"
    write_opensfm(path, odm["truth"], odm["ref"], frame=frame, exif=exif, extension=".tif")
    rec = json.loads(path.read_text())
    gps = _image_gps(images or odm["rtk"])
    fr = LocalFrame("topocentric", odm["ref"], UTM33)
    for key, shot in rec[0]["shots"].items():
        if gps_position:
            shot["gps_position"] = fr.from_lonlath(np.array([gps[key[:-4]]]))[0].tolist()
            shot["gps_dop"] = 2.0
        else:
            shot.pop("gps_position")
        if exif:
            e = folder / "exif" / f"{key}.exif"
            e.write_text(json.dumps({"gps": {**json.loads(e.read_text())["gps"], "dop": 0.02}}))
    path.write_text(json.dumps(rec))
    return path


def _read(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return read_orientation_file(path, **kw)


def _assert_truth(got, odm, tol_m=1e-4, tol_deg=1e-6):
    for n, e in odm["blk"]["truth"].items():
        s = got.shots[n]
        assert np.max(np.abs(np.subtract(s.position, (e.X, e.Y, e.Z)))) < tol_m, n
        assert np.max(np.abs((np.subtract(s.angles, (e.omega, e.phi, e.kappa)) + 180) % 360 - 180)) < tol_deg, n


def test_the_place_is_where_the_readings_part(odm):
    """Not a test of the reader: that this block is a case where the wrong reading costs metres and degrees."""
    local = LocalFrame("grid", odm["ref"], UTM33).from_map(
        np.array([s.position for s in odm["truth"].shots.values()]))[0]
    metres, degrees = separation(odm["ref"], UTM33, local)
    assert metres > 1.0 and degrees > 2.5


@pytest.mark.parametrize("exif", [False, True])
def test_odm_grid_offsets_read_from_the_images_gps(odm, tmp_path, exif):
    path = _odm_file(tmp_path / "opensfm", odm, exif=exif)
    got = _read(path, images=odm["rtk"])
    assert "read as grid" in got.frame_reading and "images' own EXIF GPS" in got.frame_reading
    _assert_truth(got, odm)
    assert any("from the images' own GPS" in n for n in got.notes)


def test_odm_grid_offsets_read_from_the_exif_folder_without_images(odm, tmp_path):
    path = _odm_file(tmp_path / "opensfm", odm, exif=True)
    got = _read(path)
    assert "read as grid" in got.frame_reading and "exif/<image>.exif" in got.frame_reading
    _assert_truth(got, odm)


def test_odm_file_alone_is_refused_naming_the_option(odm, tmp_path):
    path = _odm_file(tmp_path / "opensfm", odm)
    with pytest.raises(InputError, match="sfm_frame topocentric .OpenSfM. or grid .ODM.") as err:
        _read(path)
    assert err.value.option == "sfm_frame" and "\n" not in str(err.value)
    with pytest.raises(InputError, match="sfm_frame"):  # images without GPS are no evidence
        _read(path, images=odm["bare"])
    _assert_truth(_read(path, sfm_frame="grid", images=odm["bare"]), odm)


def test_centres_decide_without_gps_position_when_the_gps_is_rtk(odm, tmp_path):
    path = _odm_file(tmp_path / "opensfm", odm, gps_position=False)
    got = _read(path, images=odm["rtk"])
    assert "read as grid" in got.frame_reading and "camera centres" in got.frame_reading
    _assert_truth(got, odm)


def test_consumer_gps_cannot_tell_the_readings_apart(odm, tmp_path):
    path = _odm_file(tmp_path / "opensfm", odm, gps_position=False, images=odm["consumer"])
    with pytest.raises(InputError, match="too close to tell.*sfm_frame") as err:
        _read(path, images=odm["consumer"])
    assert err.value.option == "sfm_frame"


def test_opensfm_topocentric_file_is_read_as_topocentric(odm, tmp_path):
    path = _odm_file(tmp_path / "opensfm", odm, frame="topocentric")
    got = _read(path, images=odm["rtk"])
    assert "read as topocentric" in got.frame_reading
    _assert_truth(got, odm)


def test_a_frame_told_wrong_is_refused_by_the_images_gps(odm, tmp_path):
    path = _odm_file(tmp_path / "opensfm", odm)
    with pytest.raises(InputError, match="from the images' own GPS, more than 3 x") as err:
        _read(path, sfm_frame="topocentric", images=odm["rtk"])
    assert err.value.option == "sfm_frame"


def _shifted(odm, dx):
    shots = {n: ApproxShot(n, s.camera_id, (s.position[0] + dx, *s.position[1:]), s.angles)
             for n, s in odm["truth"].shots.items()}
    return ApproximateBlock(odm["truth"].cameras, shots, UTM33)


@pytest.mark.parametrize("fmt", ["colmap", "orthority"])
def test_colmap_and_orthority_files_must_agree_with_the_images_gps(odm, tmp_path, fmt):
    cam = tmp_path / "camera.yaml"

    def write(block, folder):
        if fmt == "colmap":
            write_colmap(folder, block, extension=".tif")
            return folder
        folder.mkdir()
        write_orthority_interior(cam, block.cameras)
        write_orthority_csv(folder / "ext.csv", block, extension=".tif")
        return folder / "ext.csv"

    good = write(odm["truth"], tmp_path / "good")
    got = _read(good, crs=UTM33, camera=cam, images=odm["rtk"])
    assert any("from the images' own GPS" in n for n in got.notes)
    bad = write(_shifted(odm, 0.4), tmp_path / "bad")  # 0.4 m east: 20 x the RTK σ
    with pytest.raises(InputError, match="orientation file .* 0.4. m RMS .* from the images' own GPS"):
        _read(bad, crs=UTM33, camera=cam, images=odm["rtk"])
    # the same file against a consumer receiver's GPS (σ 5 m) is within its σ
    _read(bad, crs=UTM33, camera=cam, images=odm["consumer"])


def test_ortho_cli_says_the_reading_and_refuses_without_evidence(odm, tmp_path):
    from fotogeo.cli import main
    from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
    path = _odm_file(tmp_path / "opensfm", odm)
    ortho_dem, dem = ro.write_reference(odm["blk"], tmp_path / "ref")
    frames = odm["rtk"][:2]
    run = CliRunner().invoke(main, ["ortho", *map(str, frames), "--eo", str(path), "--dem", str(dem), "--resolution",
                                    "0.2", "-o", str(tmp_path / "sfm")])  # no -q: it hides the notes
    assert run.exit_code == 0, run.output
    first = not_progress(run.stderr)[0]
    assert first.startswith("Note: orientation file") and "read as grid" in first, run.stderr
    # the same orthophotos as from the true orientation written as fotogeo's own files (one pixel size: the
    # GSD of each run would differ in its last digits and snap the grids apart)
    names = [p.stem for p in frames]
    write_exterior_orientation(tmp_path / "eo.txt", names, [odm["blk"]["truth"][n] for n in names])
    write_interior_orientation(tmp_path / "cam.yaml", "cam", odm["blk"]["camera"],
                               dict(zip(("k1", "k2", "p1", "p2", "k3"), ro.DEWARP)))
    run = CliRunner().invoke(main, ["ortho", *map(str, frames), "--eo", str(tmp_path / "eo.txt"), "--camera",
                                    str(tmp_path / "cam.yaml"), "--dem", str(dem), "--crs", "EPSG:32633",
                                    "--resolution", "0.2", "-o", str(tmp_path / "txt"), "-q"])
    assert run.exit_code == 0, run.output
    for n in names:
        with rasterio.open(tmp_path / "sfm" / f"{n}_ortho.tif") as a, \
                rasterio.open(tmp_path / "txt" / f"{n}_ortho.tif") as b:
            assert a.transform.almost_equals(b.transform, 1e-6) and a.shape == b.shape
            diff = np.abs(a.read(1).astype(int) - b.read(1).astype(int))
            assert np.mean(diff > 0) < 0.001
    # the images without GPS: nothing decides
    bare = odm["bare"][:2]
    run = CliRunner().invoke(main, ["ortho", *map(str, bare), "--eo", str(path), "--dem", str(dem), "-o",
                                    str(tmp_path / "bare"), "-q"])
    assert run.exit_code != 0 and "--sfm-frame topocentric (OpenSfM) or grid (ODM)" in run.output
    assert not (tmp_path / "bare").exists()
    run = CliRunner().invoke(main, ["ortho", *map(str, bare), "--eo", str(path), "--dem", str(dem), "--sfm-frame",
                                    "grid", "-o", str(tmp_path / "bare"), "-q", "--json"])  # -q: the note in --json
    assert run.exit_code == 0, run.output
    assert "read as grid (ODM's offsets along the UTM grid), as told" in " ".join(json.loads(run.stdout)["warnings"])


def test_triangulate_refuses_an_undecided_sfm_start(odm, tmp_path):
    from fotogeo.tools.triangulate import triangulate
    path = _odm_file(tmp_path / "opensfm", odm)
    with pytest.raises(InputError, match="sfm_frame") as err:
        triangulate(odm["bare"], None, path, None, tmp_path / "out")
    assert err.value.option == "sfm_frame"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("altitude", [0.0, 500.0])
def test_the_readings_are_compared_horizontally(altitude):
    """A small block near a reference 500 m up: the grid reading takes z as the altitude, the topocentric one adds
    the reference's, so the 3-D distance was the reference altitude (500 m apart, refused naming ``sfm_frame``)
    where the readings agree to a millimetre."""
    local = np.array([[3.0, -2.0, 40.0], [-4.0, 5.0, 41.0]])
    metres, degrees = separation((15.0, 45.0, altitude), UTM33, local)
    assert metres < 0.01 and degrees < 1e-3
