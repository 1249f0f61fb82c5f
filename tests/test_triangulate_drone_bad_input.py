"""fotogeo triangulate on the real eBee JPEGs (../shared/data/drone_snowpeak) made wrong one fact at a time (issue 20,
"Bad input"): copies in tmp_path whose EXIF/XMP bytes are edited (:mod:`jpeg_metadata`; the pixels stay the
camera's). Each refusal is one ``Error:`` line naming the frame(s) or the option and the fix, exit code 1 or 2, no
traceback, and no output folder (nothing half-written)."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.io.exif_block import read_exif_block
from jpeg_metadata import copy_frames, rename_ifd0_tag, replace_exif_text, write_xmp, xmp_of
from test_bad_input import assert_one_line_error

pytestmark = [pytest.mark.data]

STRIP = ["IMG_2280", "IMG_2281", "IMG_2282"]  # three consecutive frames of one strip
GPS_INFO, PRIVATE_TAG = 0x8825, 0xC7FF  # the IFD0 pointer to the GPS IFD, renamed: the file has no GPS


@pytest.fixture(scope="module")
def snowpeak(data_dir):
    src = data_dir / "drone_snowpeak"
    if not (src / "img").is_dir():
        pytest.skip(f"real test data not found at {src} (an older ../shared/data without drone_snowpeak)")
    return src


def _run(frames, out, *extra):
    return CliRunner().invoke(main, ["triangulate", *map(str, frames), "-o", str(out), "-q", *extra],
                              terminal_width=200)


def _refused(result, out, *expected, report: bool = False):
    """One line with ``expected``; nothing written — or, for a refusal after matching (``report``), report.json
    alone (the pairs tried)."""
    assert_one_line_error(result, expected[0])
    error = next(line for line in result.stderr.splitlines() if line.startswith("Error:"))
    for text in expected[1:]:
        assert text in error, (text, error)
    if report:
        assert sorted(p.name for p in out.iterdir()) == ["report.json"] and "pair(s) tried" in error
        return error
    assert not out.exists(), sorted(out.iterdir())
    return error


def test_a_frame_without_gps_is_named_with_every_way_to_start_it(snowpeak, tmp_path):
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    rename_ifd0_tag(frames[1], GPS_INFO, PRIVATE_TAG)
    error = _refused(_run(frames, tmp_path / "out"), tmp_path / "out", "frame(s) IMG_2281 carry no GPS position in the EXIF/XMP",
                     "--geoinfo", "--eo", "--gcps", "--reference", "--dem")
    assert "IMG_2280" not in error and "IMG_2282" not in error
    # the flight's geoinfo.txt is such a start: the frame gets its position from it
    block = read_exif_block(frames, geoinfo=snowpeak / "snowpea1_geoinfo.txt")
    assert block.shots["IMG_2281"].position is not None and block.shots["IMG_2281"].height_reference == "ellipsoid"


def test_mixed_cameras_are_named_grouped_by_camera(snowpeak, tmp_path):
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    replace_exif_text(frames[2], "IXUS 125 HS", "IXUS 130 HS")
    _refused(_run(frames, tmp_path / "out"), tmp_path / "out", "the frames come from 2 cameras",
             "Canon IXUS 125 HS 4608x3456 4.3mm: IMG_2280, IMG_2281", "Canon IXUS 130 HS 4608x3456 4.3mm: IMG_2282",
             "--camera")


@pytest.mark.parametrize("crs, why", [("EPSG:32633", "outside its area of use (12..18°E"),  # UTM 33N: Europe
                                      ("EPSG:32653", "outside its area of use (132..138°E"),  # the next zone west
                                      ("EPSG:3857", "where its scale is 1.26")])  # world-wide, 26 % too large here
def test_gps_contradicting_the_crs_is_refused_with_the_gps_zone(snowpeak, tmp_path, crs, why):
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    _refused(_run(frames, tmp_path / "out", "--crs", crs), tmp_path / "out", f"--crs {crs} does not suit the images",
             why, "give EPSG:32654 (WGS 84 / UTM zone 54N) or leave --crs out")


def test_a_geographic_crs_is_refused_with_the_gps_zone(snowpeak, tmp_path):
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    _refused(_run(frames, tmp_path / "out", "--crs", "EPSG:4326"), tmp_path / "out",
             "--crs EPSG:4326 is geographic", "EPSG:32654")


def test_ellipsoidal_and_geoid_heights_are_never_mixed(snowpeak, tmp_path):
    """A geoinfo.txt with mean-sea-level heights only (altitude_amsl) for one frame: its height is above the
    geoid, the others' EXIF GPSAltitude (senseFly) above the ellipsoid — about 40 m apart here."""
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    lines = (snowpeak / "snowpea1_geoinfo.txt").read_text().splitlines()
    cols = lines[1].split("\t")
    keep = [cols.index(c) for c in ("fileName", "latitude", "longitude", "altitude_amsl")]
    row = next(ln for ln in lines if ln.startswith("IMG_2281.JPG")).split("\t")
    geo = tmp_path / "amsl_geoinfo.txt"
    geo.write_text("\n".join([lines[0], "\t".join(cols[i] for i in keep), "\t".join(row[i] for i in keep)]) + "\n")
    _refused(_run(frames, tmp_path / "out", "--geoinfo", str(geo)), tmp_path / "out",
             "'IMG_2280' has an ellipsoidal height (senseFly EXIF GPSAltitude)",
             "'IMG_2281' a geoid (sea-level) height (geoinfo altitude_amsl)", "altitude_wgs84")
    # one reference for all, stated: the real geoinfo's ellipsoidal heights
    block = read_exif_block(frames, geoinfo=snowpeak / "snowpea1_geoinfo.txt")
    assert any(n.startswith("height reference: ellipsoid (geoinfo: ellipsoid heights)") for n in block.notes)


def test_a_geoinfo_of_another_flight_is_refused(snowpeak, tmp_path):
    """--geoinfo naming none of the frames (another flight's, or renamed images) is refused, never ignored."""
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    geo = tmp_path / "other_geoinfo.txt"
    geo.write_text((snowpeak / "snowpea1_geoinfo.txt").read_text().replace("IMG_2", "DSC_2"))
    _refused(_run(frames, tmp_path / "out", "--geoinfo", str(geo)), tmp_path / "out",
             "other_geoinfo.txt' lists none of the images (IMG_2280, IMG_2281, IMG_2282; it lists DSC_2166",
             "give the geoinfo.txt of this flight")


@pytest.mark.slow
def test_a_corrupt_xmp_packet_is_warned_once_and_its_frame_refused(snowpeak, tmp_path):
    """IMG_2281's XMP cut: its attitude and GPS accuracy are lost (one warning naming the file), it starts level
    with κ from the flight direction, and the two others cannot hold its attitude: refused by name."""
    frames = copy_frames(snowpeak / "img", STRIP, tmp_path / "img")
    write_xmp(frames[1], xmp_of(frames[1]).replace("</rdf:Description>", "</rdf:Descr", 1))
    result = _run(frames, tmp_path / "out", "--undetermined", "fail", "--json")  # -q hides it, --json keeps it
    _refused(result, tmp_path / "out", "does not determine frame(s) IMG_2281", "--undetermined drop", report=True)
    warned = [line for line in json.loads(result.stdout)["warnings"] if "XMP" in line]
    assert len(warned) == 1 and warned[0].startswith("Warning: image") and "IMG_2281.JPG" in warned[0], result.stderr
    assert "--geoinfo" in warned[0]
    # the refusal says what the unreadable packet cost the frame
    assert "IMG_2281: its XMP packet is not valid XML" in result.output and "attitude" in result.output.split(
        "IMG_2281: its XMP")[1], result.output


def test_a_frame_whose_colour_interpretation_gdal_cannot_read_has_every_band_as_data(snowpeak, tmp_path):
    """GDAL raises reading the colour interpretation of a JPEG whose XMP packet is cut: the one raster reader
    (``open_raster``) catches that error of GDAL's and takes every band as data."""
    from rasterio._err import CPLE_BaseError

    from fotogeo.io.raster import open_raster, ropen
    (frame,) = copy_frames(snowpeak / "img", ["IMG_2281"], tmp_path / "img")
    write_xmp(frame, xmp_of(frame).replace("</rdf:Description>", "</rdf:Descr", 1))
    with pytest.raises(CPLE_BaseError), ropen(frame) as ds:
        ds.colorinterp  # noqa: B018 - the failure the reader guards against
    assert open_raster(frame, "frame").data_bands == (0, 1, 2)
