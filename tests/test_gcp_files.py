"""The GCP picker's gcp_list.txt tools (fotogeo.tools.gcp.files): fotogeo's own reader and writer, JSON rows."""
from __future__ import annotations

import pytest

from fotogeo.errors import InputError
from fotogeo.io.block import read_gcp_list
from fotogeo.tools.gcp.files import read_image_gcps, write_image_gcps

TMERC = "+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs"
ROWS = [{"id": "a", "col": 10.5, "row": 20.25, "x": -55000.125, "y": -3727000.5, "z": 512.25, "role": "control"},
        {"id": "b", "col": 0.0, "row": 639.75, "x": -54000.0, "y": -3726000.0, "z": 480.0, "role": "check"}]


def test_rows_round_trip_through_gcp_list_in_a_crs_without_epsg(tmp_path):
    out = tmp_path / "gcp_list.txt"
    assert write_image_gcps(ROWS, crs=TMERC, image="/x/frame_0182.tif", output=out) == {"count": 2, "output": str(out)}
    first, line = out.read_text().splitlines()[:2]
    assert "+proj=tmerc" in first and line.split()[3:6] == ["10.0", "19.75", "frame_0182.tif"]  # OpenSfM centres
    back = read_image_gcps(out, image="frame_0182")
    assert [(r["id"], r["col"], r["row"], r["x"], r["y"], r["z"]) for r in back["gcps"]] == \
        [(r["id"], r["col"], r["row"], r["x"], r["y"], r["z"]) for r in ROWS]
    assert "Transverse Mercator" in back["crs"] or "TRANSVERSE" in back["crs"].upper()
    assert read_gcp_list(out).name.tolist() == ["a", "b"]  # what triangulate --gcps reads


def test_odm_utm_line_is_read_as_the_zone(tmp_path):
    p = tmp_path / "gcp_list.txt"
    p.write_text("WGS84 UTM 35S\n500000 6000000 100 99.5 49.5 img.JPG g1\n600000 6000000 100 9.5 9.5 other.JPG g2\n")
    got = read_image_gcps(p, image="img.jpg".replace("jpg", "JPG"))
    assert [r["id"] for r in got["gcps"]] == ["g1"] and (got["gcps"][0]["col"], got["gcps"][0]["row"]) == (100.0, 50.0)
    assert "UTM zone 35S" in got["crs"]
    assert read_gcp_list(p).crs == "EPSG:32735"


def test_bad_gcp_lists_are_one_line_errors(tmp_path):
    p = tmp_path / "gcp_list.txt"
    p.write_text("EPSG:32735\n500000 6000000 100 99.5 49.5 img.JPG g1\n")
    with pytest.raises(InputError, match="no measurement on image 'frame'.*names img.*open that image"):
        read_image_gcps(p, image="frame.tif")
    with pytest.raises(InputError, match="GCP.*b have no height.*needs Z"):
        write_image_gcps([ROWS[0], dict(ROWS[1], z=None)], crs="EPSG:32735", image="f.tif", output=tmp_path / "o.txt")
    with pytest.raises(InputError, match="'my point' cannot be written; rename it without spaces"):
        write_image_gcps([dict(ROWS[0], id="my point")], crs="EPSG:32735", image="f.tif", output=tmp_path / "o.txt")
    assert not (tmp_path / "o.txt").exists()
