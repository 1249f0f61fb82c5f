"""The triangulate tool and command on a small synthetic block written to files."""
from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest
import rasterio
import rasterio.errors
from click.testing import CliRunner

from fotogeo.errors import FotogeoError, InputError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.io.block import write_exterior_orientation
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.tools.triangulate import FILES, triangulate

CAMERA = FrameCamera(3.0, (2.0, 3.0), (200, 300))
CAMERA_YAML = """test-camera:
    type: pinhole
    im_size: [200, 300]
    focal_len: 3.0
    sensor_size: [2.0, 3.0]
"""


def write_block(folder, sb, *, n_gcps=None, image_size=(200, 300)):
    """Frames (blank GeoTIFFs of the camera's size), camera, EO, tie-point CSV and gcp_list.txt."""
    b = sb.block
    frames = []
    for name in b.frames:
        path = folder / f"{name}.tif"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)  # frames have no georeference
            with rasterio.open(path, "w", driver="GTiff", width=image_size[0], height=image_size[1], count=1,
                               dtype="uint8") as ds:
                ds.write(np.zeros((1, image_size[1], image_size[0]), np.uint8))
        frames.append(path)
    (folder / "camera.yaml").write_text(CAMERA_YAML)
    write_exterior_orientation(folder / "eo.txt", b.frames, b.eo)
    tie = b.role[b.obs_point] == "tie"
    rows = ["frame,point,col,row"] + [f"{b.frames[f]}.tif,{b.point_ids[p]},{c:.4f},{r:.4f}" for f, p, (c, r) in
                                     zip(b.obs_frame[tie], b.obs_point[tie], b.obs_pixel[tie])]
    (folder / "tie.csv").write_text("\n".join(rows) + "\n")
    known = np.flatnonzero(~tie)
    if n_gcps is not None:
        ctrl = [p for p in dict.fromkeys(b.obs_point[known]) if b.role[p] == "control"][:n_gcps]
        known = known[np.isin(b.obs_point[known], ctrl) | (b.role[b.obs_point[known]] == "check")]
    lines = ["EPSG:32635"]
    for o in known:
        p = b.obs_point[o]
        X, Y, Z = b.point_xyz[p]
        c, r = b.obs_pixel[o] - 0.5  # OpenSfM pixels: centre of the top-left pixel at (0, 0)
        lines.append(f"{X:.4f} {Y:.4f} {Z:.4f} {c:.4f} {r:.4f} {b.frames[b.obs_frame[o]]}.JPG {b.point_ids[p]}")
    (folder / "gcp_list.txt").write_text("\n".join(lines) + "\n")
    checks = ",".join(sorted({b.point_ids[p] for p in b.obs_point[known] if b.role[p] == "check"}))
    return frames, checks


@pytest.fixture(scope="module")
def small_block():
    return simulate_block(seed=6, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=50.0, margin=3.0,
                          n_check=8)


def test_triangulate_writes_the_adjusted_block(tmp_path, small_block):
    frames, checks = write_block(tmp_path, small_block)
    out = tmp_path / "out"
    out.mkdir()
    rep = triangulate(frames, tmp_path / "camera.yaml", tmp_path / "eo.txt", tmp_path / "tie.csv", out,
                      gcps=tmp_path / "gcp_list.txt", check_points=checks, control_sigma_xy=0.02,
                      control_sigma_z=0.03, image_sigma=0.3)
    assert sorted(p.name for p in out.iterdir()) == sorted(FILES)
    gsd = small_block.gsd
    assert rep["statistics"]["check"]["n"] >= 5
    assert rep["statistics"]["check"]["rmse_planimetric_m"] < 0.5 * gsd
    assert rep["statistics"]["check"]["rmse_z_m"] < 1.5 * gsd
    eo = read_exterior_orientation(out / "exterior_orientation.txt")
    true = dict(zip(small_block.block.frames, small_block.true_eo))
    for name, e in eo.items():
        assert np.hypot(e.X - true[name].X, e.Y - true[name].Y) < 10 * gsd
    import pyogrio
    layers = {name for name, _ in pyogrio.list_layers(out / "block.gpkg")}
    assert layers == {"tie_points", "control", "frames", "residuals", "footprints"}
    feet = pyogrio.read_dataframe(out / "block.gpkg", layer="footprints")
    assert list(feet["name"]) == list(small_block.block.frames) and feet["on_terrain"].all()
    for name, poly in zip(feet["name"], feet.geometry):  # each outline holds its projection centre (near-nadir)
        import shapely
        assert poly.contains(shapely.Point(true[name].X, true[name].Y))
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 3 and "Control layout" in page
    ctrl = pyogrio.read_dataframe(out / "block.gpkg", layer="control")
    assert set(ctrl["role"]) == {"control", "check"}
    assert json.loads((out / "report.json").read_text())["statistics"]["n_frames"] == 10


def test_triangulate_command(tmp_path, small_block):
    from fotogeo.cli import main
    frames, checks = write_block(tmp_path, small_block)
    out = tmp_path / "out"
    out.mkdir()
    res = CliRunner().invoke(main, ["triangulate", *map(str, frames), "--camera", str(tmp_path / "camera.yaml"),
                                    "--eo", str(tmp_path / "eo.txt"), "--observations", str(tmp_path / "tie.csv"),
                                    "--gcps", str(tmp_path / "gcp_list.txt"), "--check-points", checks,
                                    "--image-sigma", "0.3", "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    assert "check points (n=" in res.output
    assert (out / "exterior_orientation.txt").exists()


def test_fewer_than_three_gcps_is_refused_and_nothing_written(tmp_path, small_block):
    frames, checks = write_block(tmp_path, small_block, n_gcps=2)
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(InputError, match="2 control point.*at least 3"):
        triangulate(frames, tmp_path / "camera.yaml", tmp_path / "eo.txt", tmp_path / "tie.csv", out,
                    gcps=tmp_path / "gcp_list.txt", check_points=checks)
    assert not any(out.iterdir())


def test_a_camera_for_another_image_size_is_refused(tmp_path, small_block):
    frames, _ = write_block(tmp_path, small_block, image_size=(100, 150))
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(FotogeoError, match="200x300"):
        triangulate(frames, tmp_path / "camera.yaml", tmp_path / "eo.txt", tmp_path / "tie.csv", out,
                    gcps=tmp_path / "gcp_list.txt")
    assert not any(out.iterdir())


def test_block_file_readers_name_the_bad_line_and_field(tmp_path):
    from fotogeo.errors import VectorError
    from fotogeo.io.block import read_gcp_list, read_image_observations
    bad = tmp_path / "gcp_list.txt"
    bad.write_text("EPSG:32635\n500000 4420000 800 10 20 a.JPG g1\n500010 4420000 oops 10 20 b.JPG g2\n")
    with pytest.raises(InputError, match="line 3"):
        read_gcp_list(bad)
    good = tmp_path / "good.txt"
    good.write_text("EPSG:32635\n500000 4420000 800 10 20 images/a.JPG g1\n")
    g = read_gcp_list(good)
    assert g.crs == "EPSG:32635" and list(g.frame) == ["a"] and g.pixel.tolist() == [[10.5, 20.5]]
    table = tmp_path / "obs.csv"
    table.write_text("frame,point,col\na.tif,1,10\n")
    with pytest.raises(VectorError, match="row"):
        read_image_observations(table)


def test_triangulate_matches_rendered_frames(tmp_path):
    """No observation table: the overlapping frames of a rendered block are matched (SURF pairs along
    and across the strips, epipolar RANSAC, multi-ray tracks) and the block adjusted."""
    from fotogeo.orientation.block_render import render_block
    cam = FrameCamera(6.0, (4.0, 6.0), (400, 600))
    sb = simulate_block(seed=1, strips=2, frames_per_strip=4, camera=cam, point_spacing=80.0, blunder_fraction=0.0,
                        margin=5.0)
    images, _ = render_block(sb)
    frames, checks = write_block(tmp_path, sb, image_size=(400, 600))
    for path, img in zip(frames, images):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(path, "r+") as ds:
                ds.write(img[None])
    (tmp_path / "camera.yaml").write_text(CAMERA_YAML.replace("[200, 300]", "[400, 600]").replace(
        "3.0\n", "6.0\n").replace("[2.0, 3.0]", "[4.0, 6.0]"))
    out = tmp_path / "out"
    out.mkdir()
    rep = triangulate(frames, tmp_path / "camera.yaml", tmp_path / "eo.txt", None, out,
                      gcps=tmp_path / "gcp_list.txt", check_points=checks, image_sigma=0.3)
    pairs = [tuple(p["pair"]) for p in rep["matching"]["pairs"] if p["inliers"] >= 20]
    assert (0, 1) in pairs and any(i < 4 <= j for i, j in pairs)  # along and across the strips
    assert rep["matching"]["tracks"] > 500  # Gruber thinning: 3x3 regions x 25 tracks per frame
    st = rep["statistics"]
    assert st["image_rms_px"] < 0.3
    assert st["check"]["rmse_planimetric_m"] < 1.0 * sb.gsd and st["check"]["rmse_z_m"] < 2.0 * sb.gsd


def test_a_frame_that_overlaps_no_other_is_named(tmp_path, small_block):
    from fotogeo.errors import MatchingError
    from fotogeo.tools.triangulate.match import block_tie_points
    b = small_block.block
    eos = list(b.eo)
    eos[3] = dataclasses.replace(eos[3], X=eos[3].X + 30000.0)
    frames, _ = write_block(tmp_path, small_block)
    with pytest.raises(MatchingError, match=f"{b.frames[3]}.tif.*overlap no other frame") as err:
        block_tie_points(frames, CAMERA, eos, 0.0)
    assert "orientation file" not in str(err.value)  # none was given: the caller's advice names what was


def test_self_calibration_writes_the_adjusted_camera(tmp_path, small_block):
    from fotogeo.io.camera import read_interior_orientation
    frames, checks = write_block(tmp_path, small_block)
    out = tmp_path / "out"
    out.mkdir()
    rep = triangulate(frames, tmp_path / "camera.yaml", tmp_path / "eo.txt", tmp_path / "tie.csv", out,
                      gcps=tmp_path / "gcp_list.txt", check_points=checks, image_sigma=0.3,
                      self_calibration=("ppx", "ppy"), eo_sigma_position=5.0)
    assert (out / "camera.yaml").exists()
    cam = next(iter(read_interior_orientation(out / "camera.yaml").values()))  # pinhole: no distortion estimated
    assert cam.principal_point == pytest.approx(tuple(rep["camera"]["principal_point"]), abs=1e-9)
    assert cam.focal_length == 3.0


def test_the_dask_options_reach_the_pair_matching(tmp_path, small_block, monkeypatch):
    """--scheduler / --workers (register-batch's options) go to the tie-point matching; without them it runs in
    this process (client, scheduler and workers None)."""
    from fotogeo.cli import main
    from fotogeo.errors import MatchingError
    from fotogeo.tools.triangulate import match
    seen = []

    def stop(*a, **k):
        seen.append({n: k[n] for n in ("client", "scheduler", "workers") if n in k})
        raise MatchingError("stopped after the options were seen")
    monkeypatch.setattr(match, "block_tie_points", stop)
    frames, checks = write_block(tmp_path, small_block)
    common = ["triangulate", *map(str, frames), "--camera", str(tmp_path / "camera.yaml"), "--eo",
              str(tmp_path / "eo.txt"), "--gcps", str(tmp_path / "gcp_list.txt"), "-q"]
    for extra in (["--scheduler", "tcp://127.0.0.1:8786", "--workers", "2"], []):
        res = CliRunner().invoke(main, [*common, *extra, "-o", str(tmp_path / f"out{len(extra)}")])
        assert res.exit_code != 0 and "stopped after the options were seen" in res.output, res.output
    assert seen == [{"scheduler": "tcp://127.0.0.1:8786", "workers": 2}, {"scheduler": None, "workers": None}]
