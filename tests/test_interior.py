"""``fotogeo interior``: fiducial marks of rendered film scans with known truth (film border, marks of two
camera layouts, a scan affinity, rotation by 90° steps plus a few degrees, scanner noise) found to ≤ 0.1 px,
the pixel → photo transform, the standard frame, and the refusals: marks cut off, too few marks, a report of
another layout, mixed scan resolutions."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.errors import InputError
from fotogeo.io.camera import load_camera
from fotogeo.io.interior_json import read_interior
from fotogeo.matching.targets import measure_target
from fotogeo.tools.interior.tool import interior
from film_scans import CORNERS, RC_LIKE, RMK_LIKE, render_scan, report_yaml

PIXEL_UM = 150.0
#: an asymmetric layout (RMK_LIKE and one more mark): its rotation can be told from the marks
ASYMMETRIC = {**RMK_LIKE, "5": (-100.0, 113.0)}


def write_scan(path: Path, scan, dpi=None):
    with rasterio.open(path, "w", driver="GTiff", width=scan.image.shape[1], height=scan.image.shape[0], count=1,
                       dtype="uint8") as ds:
        ds.write(scan.image[None])
        if dpi:
            ds.update_tags(TIFFTAG_XRESOLUTION=str(dpi), TIFFTAG_YRESOLUTION=str(dpi), TIFFTAG_RESOLUTIONUNIT="2")
    return path


def setup(tmp_path, layout, kind="x", name="scan", report_layout=None, **render):
    scan = render_scan(layout, kind=kind, **render)
    path = write_scan(tmp_path / f"{name}.tif", scan)
    cal = tmp_path / f"{name}_cal.yaml"
    cal.write_text(report_yaml(report_layout or layout, kind=kind))
    return scan, path, cal


@pytest.mark.parametrize("layout,kind,k90,theta", [(RC_LIKE, "x", 0, 2.0), (RMK_LIKE, "cross", 2, -1.5),
                                                  (RC_LIKE, "dot", 3, 0.7), (CORNERS, "corner", 1, -2.5)])
def test_marks_and_transform_recovered(tmp_path, layout, kind, k90, theta):
    scan, path, cal = setup(tmp_path, layout, kind, k90=k90, theta=theta, seed=k90)
    rec = interior(path, cal, tmp_path / "io.json", scan_pixel_um=PIXEL_UM, rotation=str(90 * k90))[0]
    err = [np.hypot(f["col"] - scan.marks[f["id"]][0], f["row"] - scan.marks[f["id"]][1]) for f in rec["fiducials"]]
    assert len(err) == len(layout) and max(err) <= 0.1, err
    assert rec["rms_px"] <= 0.2 and rec["missing"] == []
    assert rec["rotation_deg"] == pytest.approx((90 * k90 + theta) % 360, abs=0.05)
    # the transform against the truth over the whole frame: photo mm of the scan corners, in scan pixels
    io = read_interior(tmp_path / "io.json")
    Ai = np.linalg.inv(np.vstack([scan.A, [0, 0, 1]]))
    corners = np.array([[0, 0], [1600, 0], [0, 1600], [1600, 1600]], float)
    truth = (np.column_stack([corners, np.ones(4)]) @ Ai.T)[:, :2]
    assert np.abs(io.to_photo(corners) - truth).max() / (PIXEL_UM / 1000) < 0.1
    assert np.array(json.loads((tmp_path / "io.json").read_text())["pixel_to_photo"]).shape == (2, 3)


def test_rotation_found_when_the_layout_tells_it(tmp_path):
    scan, path, cal = setup(tmp_path, ASYMMETRIC, "cross", k90=2, theta=1.0)
    rec = interior(path, cal, tmp_path / "io.json", scan_pixel_um=PIXEL_UM)[0]
    assert rec["rotation_deg"] == pytest.approx(181.0, abs=0.05) and rec["warnings"] == []



@pytest.mark.parametrize("k90", [0, 2])
def test_a_mirror_image_scan_is_refused_not_fitted_mirrored(tmp_path, k90):
    """Film scanned through its base: the scan is the mirror image of the photo. The four marks on the axes
    map onto themselves under the mirror, so a fit under a rotation used to succeed (exit 0, "rotation
    ambiguous") with every photo coordinate mirrored; the asymmetric fifth mark tells the mirror. Fails on main."""
    scan = render_scan(ASYMMETRIC, kind="cross", k90=k90, theta=1.0, seed=1)
    flipped = dataclasses.replace(scan, image=scan.image[:, ::-1].copy())
    path = write_scan(tmp_path / "flipped.tif", flipped)
    (tmp_path / "cal.yaml").write_text(report_yaml(ASYMMETRIC, kind="cross"))
    with pytest.raises(InputError, match=r"mirror image .* 5 of 5 fiducial marks, unflipped 4; flip the"):
        interior(path, tmp_path / "cal.yaml", tmp_path / "io.json", scan_pixel_um=PIXEL_UM)
    assert not (tmp_path / "io.json").exists()
    # the same scan unflipped: all five marks, no refusal
    interior(write_scan(tmp_path / "scan.tif", scan), tmp_path / "cal.yaml", tmp_path / "io.json",
             scan_pixel_um=PIXEL_UM)

def test_a_symmetric_layout_says_its_rotation_is_ambiguous(tmp_path):
    _, path, cal = setup(tmp_path, RMK_LIKE, "cross", k90=1, theta=0.5)
    rec = interior(path, cal, tmp_path / "io.json", scan_pixel_um=PIXEL_UM)[0]
    assert any("rotation ambiguous" in w and "give rotation" in w for w in rec["warnings"])


def test_projective_model_and_resolution_tags(tmp_path):
    scan = render_scan(RC_LIKE, k90=0, theta=1.0)
    path = write_scan(tmp_path / "scan.tif", scan, dpi=25.4 / (PIXEL_UM / 1000))
    (tmp_path / "cal.yaml").write_text(report_yaml(RC_LIKE))
    rec = interior(path, tmp_path / "cal.yaml", tmp_path / "io.json", model="projective", rotation="0")[0]
    assert rec["model"] == "projective" and np.array(rec["pixel_to_photo"]).shape == (3, 3)
    assert rec["scan_pixel_um"] == pytest.approx(150.0, rel=3e-3) and rec["rms_px"] <= 0.2


def test_standard_frame_and_its_camera(tmp_path):
    scan, path, cal = setup(tmp_path, RC_LIKE, "x", k90=0, theta=2.0)
    cal.write_text(report_yaml(RC_LIKE, frame_mm=(236, 236)))
    rec = interior(path, cal, tmp_path / "io.json", scan_pixel_um=PIXEL_UM, rotation="0", resample=True,
                   resample_pixel_um=200.0)[0]
    sf = rec["standard_frame"]
    cam = load_camera(sf["camera"])
    with rasterio.open(sf["image"]) as ds:
        frame = ds.read(1).astype(float)
    assert cam.image_size == (frame.shape[1], frame.shape[0]) and cam.focal_length == 153.0
    q = 0.2
    pp = (0.01, -0.02)
    for fid in ("1", "3", "6"):  # each mark where the standard frame puts its photo coordinates
        x, y = RC_LIKE[fid]
        want = np.array([(x - pp[0]) / q + frame.shape[1] / 2, (pp[1] - y) / q + frame.shape[0] / 2])
        got = measure_target(frame, want, half_window=10).xy
        assert np.hypot(*(got - want)) < 0.2, (fid, got, want)


def test_marks_cut_off_are_named_and_too_few_refused(tmp_path):
    _, path, cal = setup(tmp_path, RC_LIKE, "x", missing=("6",), k90=0, theta=1.0)
    rec = interior(path, cal, tmp_path / "io.json", scan_pixel_um=PIXEL_UM, rotation="0")[0]
    assert [m["id"] for m in rec["missing"]] == ["6"] and "not found: 6" in rec["warnings"][0]
    _, path, cal = setup(tmp_path, RC_LIKE, "x", name="cut", missing=("2", "3", "5", "6", "7"), k90=0, theta=1.0)
    with pytest.raises(InputError, match=r"3 of 8 fiducial marks found \(1, 4, 8\), at least 4 needed; not found: 2"):
        interior(path, cal, tmp_path / "cut.json", scan_pixel_um=PIXEL_UM, rotation="0")
    assert not (tmp_path / "cut.json").exists()


def test_a_report_of_another_layout_is_refused(tmp_path):
    wrong = {**RC_LIKE, "3": (107.0, -106.0)}  # one mark 1 mm off: a damaged mark or another camera
    _, path, cal = setup(tmp_path, RC_LIKE, "x", report_layout=wrong, k90=0, theta=1.0)
    with pytest.raises(InputError, match=r"mark\(s\) .*3 \(3\.\d+ px\).* do not fit the camera report's layout"):
        interior(path, cal, tmp_path / "io.json", scan_pixel_um=PIXEL_UM, rotation="0")
    other = {k: (x * 100 / 113, y * 100 / 113) for k, (x, y) in RMK_LIKE.items()}  # marks at 100 mm
    _, path, cal = setup(tmp_path, RC_LIKE, "x", name="rmk", report_layout=other, k90=0, theta=1.0)
    with pytest.raises(InputError, match=r"0 of 4 fiducial marks found \(none\)"):
        interior(path, cal, tmp_path / "rmk.json", scan_pixel_um=PIXEL_UM, rotation="0")
    assert not list(tmp_path.glob("*.json"))


def test_mixed_scan_resolutions_are_refused(tmp_path):
    a = write_scan(tmp_path / "a.tif", render_scan(RMK_LIKE, kind="cross"), dpi=25.4 / 0.15)
    b = write_scan(tmp_path / "b.tif", render_scan(RMK_LIKE, kind="cross", pixel_mm=0.16), dpi=25.4 / 0.16)
    (tmp_path / "cal.yaml").write_text(report_yaml(RMK_LIKE, kind="cross"))
    with pytest.raises(InputError, match=r"different pixel sizes \(a.tif 150.\d+ µm, b.tif 160.\d+ µm\)"):
        interior([a, b], tmp_path / "cal.yaml", tmp_path / "out", rotation="0")
    assert not list((tmp_path / "out").glob("*.json"))


def test_command_line_one_scan_and_a_bad_report(tmp_path):
    _, path, cal = setup(tmp_path, RMK_LIKE, "cross", k90=0, theta=1.0)
    r = CliRunner().invoke(main, ["interior", str(path), "--camera-report", str(cal), "-o", str(tmp_path / "o.json"),
                                  "--scan-pixel-um", "150", "--rotation", "0", "-q"])
    assert r.exit_code == 0, r.output
    assert "4 marks, affine RMS" in r.output and (tmp_path / "o.json").exists()
    (tmp_path / "bad.yaml").write_text("focal_mm: 153\nmark: star\nfiducials_mm:\n  1: [0, 1]\n")
    r = CliRunner().invoke(main, ["interior", str(path), "--camera-report", str(tmp_path / "bad.yaml"), "-o",
                                  str(tmp_path / "b.json"), "--scan-pixel-um", "150"])
    assert r.exit_code == 1 and "mark must be one of x, cross, dot, corner; got 'star'" in r.output  # a file's value: failed run
    assert not (tmp_path / "b.json").exists()


def test_a_scan_without_resolution_tags_names_the_option_once(tmp_path):
    """The fix names the option in the caller's words only: on main the line read 'scan_pixel_um /
    --scan-pixel-um' on the command line and 'scan_pixel_um / “Scan pixel size in µm …”' in QGIS."""
    _, path, cal = setup(tmp_path, RMK_LIKE, "cross", k90=0, theta=1.0)
    with pytest.raises(InputError, match="carries no resolution tags") as err:
        interior(path, cal, tmp_path / "o.json")
    assert err.value.option == "scan_pixel_um"
    r = CliRunner().invoke(main, ["interior", str(path), "--camera-report", str(cal), "-o", str(tmp_path / "o.json")])
    assert r.exit_code == 2 and "give its pixel size: --scan-pixel-um (e.g. 21" in r.output
    assert "scan_pixel_um" not in r.output and not (tmp_path / "o.json").exists()


def test_more_fiducials_asked_than_the_report_has_is_an_option_error(tmp_path):
    """On main: '5 of 5 fiducial marks found (…), at least 9 needed; not found: .' after measuring the scan."""
    _, path, cal = setup(tmp_path, RMK_LIKE, "cross", k90=0, theta=1.0)
    r = CliRunner().invoke(main, ["interior", str(path), "--camera-report", str(cal), "-o", str(tmp_path / "o.json"),
                                  "--scan-pixel-um", "150", "--min-fiducials", "9"])
    assert r.exit_code == 2 and "--min-fiducials 9 asks for more marks than the 4 of the camera report" in r.output
    assert not (tmp_path / "o.json").exists()


def test_several_scans_into_a_json_name_are_refused(tmp_path):
    """On main 'interior a.tif b.tif -o two.json' made a folder named two.json holding a.json and b.json."""
    _, a, cal = setup(tmp_path, RMK_LIKE, "cross", name="a", k90=0, theta=1.0)
    _, b, _ = setup(tmp_path, RMK_LIKE, "cross", name="b", k90=0, theta=1.0)
    with pytest.raises(InputError, match="names a JSON file, but 2 scans need a folder"):
        interior([a, b], cal, tmp_path / "two.json", scan_pixel_um=PIXEL_UM, rotation="0")
    assert not (tmp_path / "two.json").exists()


def test_quiet_hides_the_warnings_the_json_keeps_them(tmp_path):
    """A wrong --scan-pixel-um (160 for 150 µm) warns; with -q the line is gone from stderr (on main
    ``interior -q`` printed it) and stays in the scan's JSON record."""
    _, path, cal = setup(tmp_path, ASYMMETRIC, "cross", k90=0, theta=1.0)
    args = ["interior", str(path), "--camera-report", str(cal), "-o", str(tmp_path / "o.json"),
            "--scan-pixel-um", "160", "--rotation", "0"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0 and "Warning: the marks give a scan pixel of 150" in r.stderr
    r = CliRunner().invoke(main, [*args, "--overwrite", "-q"])
    assert r.exit_code == 0 and r.stderr == "" and "5 marks" in r.stdout
    assert "scan pixel of 150" in json.loads((tmp_path / "o.json").read_text())["warnings"][0]


def test_a_rotation_the_marks_contradict_is_refused(tmp_path):
    """A scan turned 90° with --rotation 0: on main the marks found at 0° (4 of 5) were fitted and the run ended
    with 'fiducial mark(s) not found: 5' — photo coordinates turned by 90°. Now refused naming --rotation and
    the rotation the marks show; a layout that looks the same turned (RMK_LIKE) keeps the rotation given."""
    _, path, cal = setup(tmp_path, ASYMMETRIC, "cross", k90=1, theta=1.0)
    r = CliRunner().invoke(main, ["interior", str(path), "--camera-report", str(cal), "-o", str(tmp_path / "o.json"),
                                  "--scan-pixel-um", "150", "--rotation", "0", "-q"])  # -q keeps the error
    assert r.exit_code == 2 and r.stderr.count("\n") == 1, r.output
    assert ("Error: --rotation 0° contradicts the fiducial marks of scan" in r.stderr
            and "turned by 90° the report's layout finds 5 of 5 marks, at 0° 4; give 90 (or auto)" in r.stderr)
    assert not (tmp_path / "o.json").exists()
    rec = interior(path, cal, tmp_path / "o.json", scan_pixel_um=PIXEL_UM, rotation="90")[0]
    assert rec["rotation_deg"] == pytest.approx(91.0, abs=0.05) and rec["warnings"] == []
    _, path, cal = setup(tmp_path, RMK_LIKE, "cross", name="sym", k90=1, theta=1.0)
    rec = interior(path, cal, tmp_path / "sym.json", scan_pixel_um=PIXEL_UM, rotation="180")[0]
    assert rec["rotation_deg"] == pytest.approx(181.0, abs=0.1) and rec["warnings"] == []
