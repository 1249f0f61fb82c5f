"""fotogeo triangulate: camera with distortion read back, control tables in any CRS, check-point hold-out,
approximate orientation by resection, orthorectified frames."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.io.block import read_gcp_list
from fotogeo.io.camera import read_camera_with_distortion, read_exterior_orientation
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.tools.triangulate import triangulate

from test_triangulate import CAMERA, write_block


@pytest.fixture(scope="module")
def small_block():
    """test_triangulate's 2 x 5 block (9 control, 8 check points)."""
    return simulate_block(seed=6, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=50.0, margin=3.0,
                          n_check=8)


@pytest.fixture(scope="module")
def dense_control():
    """A 2 x 5 block with enough control for every frame to be resected (≥ 4 GCPs per frame)."""
    return simulate_block(seed=6, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=50.0, margin=3.0,
                          n_control=9, n_check=40, blunder_fraction=0.0)


def _run(tmp_path, **kw):
    out = tmp_path / "out"
    out.mkdir(exist_ok=True)
    args = {"image_sigma": 0.3, **kw}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return triangulate(args.pop("frames"), args.pop("camera", tmp_path / "camera.yaml"),
                           args.pop("eo", tmp_path / "eo.txt"), tmp_path / "tie.csv", out, **args), out


def test_self_calibrated_camera_is_a_valid_camera_of_the_next_run(tmp_path):
    sb = simulate_block(seed=3, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=40.0, margin=3.0,
                        n_check=8, true_distortion=(-0.04, 0.0, 0.0, 0.0, 0.0), blunder_fraction=0.0)
    frames, checks = write_block(tmp_path, sb)
    rep, out = _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_points=checks,
                    self_calibration=("k1",), eo_sigma_position=5.0)
    cam, dist = read_camera_with_distortion(out / "camera.yaml")
    assert "type: brown" in (out / "camera.yaml").read_text()
    assert dist["k1"] == pytest.approx(rep["camera"]["k1"], rel=1e-12) and dist["k1"] == pytest.approx(-0.04, abs=0.01)
    out2 = tmp_path / "out2"
    out2.mkdir()
    rep2 = triangulate(frames, out / "camera.yaml", tmp_path / "eo.txt", tmp_path / "tie.csv", out2,
                       gcps=tmp_path / "gcp_list.txt", check_points=checks, image_sigma=0.3)
    assert rep2["camera"]["k1"] == dist["k1"]  # read back and held fixed
    assert rep2["statistics"]["image_rms_px"] < 0.45  # the distortion is modelled: residuals at the noise level
    pinhole = tmp_path / "pinhole.yaml"
    pinhole.write_text((out / "camera.yaml").read_text().replace("brown", "pinhole"))
    with pytest.raises(InputError, match="distortion terms need type: brown"):
        read_camera_with_distortion(pinhole)


def _control_layer(tmp_path, crs_out="EPSG:4326"):
    """The block's gcp_list.txt as a point layer in another CRS, one row per (point, frame), roles in a field."""
    import geopandas as gpd
    from pyproj import Transformer
    g = read_gcp_list(tmp_path / "gcp_list.txt")
    lon, lat = Transformer.from_crs("EPSG:32635", crs_out, always_xy=True).transform(g.ground[:, 0], g.ground[:, 1])
    df = gpd.GeoDataFrame({"id": g.name.astype(str), "frame": [f + ".tif" for f in g.frame], "col": g.pixel[:, 0],
                           "row": g.pixel[:, 1], "z": g.ground[:, 2]},
                          geometry=gpd.points_from_xy(lon, lat), crs=crs_out)
    return g, df


def test_control_as_a_layer_in_another_crs_with_roles(tmp_path, small_block):
    frames, checks = write_block(tmp_path, small_block)
    ref, _ = _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_points=checks)
    g, df = _control_layer(tmp_path)
    df["role"] = np.where(np.isin(df["id"], checks.split(",")), "check", "control")
    df.to_file(tmp_path / "gcps.gpkg", layer="gcps", engine="pyogrio")
    rep, out = _run(tmp_path, frames=frames, gcps=tmp_path / "gcps.gpkg", crs="EPSG:32635", overwrite=True)
    for role in ("control", "check"):
        assert rep["statistics"][role]["n"] == ref["statistics"][role]["n"]
        assert rep["statistics"][role]["rmse_planimetric_m"] == pytest.approx(ref["statistics"][role]["rmse_planimetric_m"],
                                                                              abs=2e-3)
    csv = tmp_path / "gcps.csv"
    df.assign(lon=df.geometry.x, lat=df.geometry.y).drop(columns="geometry").to_csv(csv, index=False)
    rep_csv, _ = _run(tmp_path, frames=frames, gcps=csv, crs="EPSG:32635", gcp_crs="EPSG:4326", overwrite=True)
    assert rep_csv["statistics"]["check"] == pytest.approx(rep["statistics"]["check"], abs=1e-6)
    with pytest.raises(InputError, match="map CRS of the block"):  # a geographic map CRS: degrees are no metres
        _run(tmp_path, frames=frames, gcps=tmp_path / "gcps.gpkg", overwrite=True)
    df.loc[df.index[0], "role"] = "check" if df.loc[df.index[0], "role"] == "control" else "control"
    df.to_file(tmp_path / "mixed.gpkg", layer="gcps", engine="pyogrio")
    with pytest.raises(InputError, match=f"point\\(s\\) {df.loc[df.index[0], 'id']} have both roles"):
        _run(tmp_path, frames=frames, gcps=tmp_path / "mixed.gpkg", crs="EPSG:32635", overwrite=True)


def test_check_fraction_holds_out_a_seeded_spread_share(tmp_path, small_block):
    frames, _ = write_block(tmp_path, small_block)
    names, rays = np.unique(read_gcp_list(tmp_path / "gcp_list.txt").name.astype(str), return_counts=True)
    n_gcp = int(np.count_nonzero(rays >= 2))  # the candidates: a check point is intersected from its own rays
    reps = [_run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_fraction=0.3, seed=s,
                 overwrite=True)[0] for s in (1, 1, 2)]
    n_check = [r["statistics"]["check"]["n"] for r in reps]
    assert n_check[0] == round(0.3 * n_gcp) and n_check[0] == n_check[1]
    _, out = _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_fraction=0.3, seed=1,
                  overwrite=True)
    import pyogrio
    ctrl = pyogrio.read_dataframe(out / "block.gpkg", layer="control")
    held_out = set(ctrl["id"][ctrl["role"] == "check"])
    assert len(held_out) == n_check[0] and sorted(held_out) == reps[0]["check_points"]
    g = read_gcp_list(tmp_path / "gcp_list.txt")
    span = np.ptp(g.ground[np.isin(g.name, list(held_out)), :2], axis=0) / np.ptp(g.ground[:, :2], axis=0)
    assert (span > 0.5).all(), span  # spread over the block, not bunched in one corner
    assert n_check[2] == n_check[0] and reps[2]["statistics"]["check"] != reps[0]["statistics"]["check"]
    with pytest.raises(InputError, match="check_fraction 0.9"):
        _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_fraction=0.9, overwrite=True)


def test_without_eo_every_frame_is_resected_from_its_control(tmp_path, dense_control):
    frames, _ = write_block(tmp_path, dense_control)  # every GCP (the simulation's 40 check points too) is control
    rep, out = _run(tmp_path, frames=frames, eo=None, gcps=tmp_path / "gcp_list.txt", check_fraction=0.0)
    assert rep["resected_frames"] == list(dense_control.block.frames)
    gsd = dense_control.gsd
    assert rep["statistics"]["image_rms_px"] < 0.4 and rep["statistics"]["control"]["n"] >= 40
    eo = read_exterior_orientation(out / "exterior_orientation.txt")
    for name, true in zip(dense_control.block.frames, dense_control.true_eo):
        assert np.hypot(eo[name].X - true.X, eo[name].Y - true.Y) < 10 * gsd


def test_command_without_eo_and_with_a_hold_out(tmp_path, dense_control):
    from click.testing import CliRunner

    from fotogeo.cli import main
    frames, _ = write_block(tmp_path, dense_control)
    (tmp_path / "out").mkdir()
    res = CliRunner().invoke(main, ["triangulate", *map(str, frames), "--camera", str(tmp_path / "camera.yaml"),
                                    "--observations", str(tmp_path / "tie.csv"), "--gcps",
                                    str(tmp_path / "gcp_list.txt"), "--check-fraction", "0.2", "--seed", "4",
                                    "--image-sigma", "0.3", "-o", str(tmp_path / "out"), "-q"])
    assert res.exit_code == 0, res.output
    assert "resected from their GCPs (no --eo line): s1_01" in res.output and "check points (n=" in res.output
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["eo"] is None and rep["statistics"]["check"]["rmse_planimetric_m"] < 0.5 * dense_control.gsd


def test_frames_without_eo_and_too_few_gcps_are_named(tmp_path, small_block):
    frames, checks = write_block(tmp_path, small_block)
    g = read_gcp_list(tmp_path / "gcp_list.txt")
    counts = {f: len(set(g.name[(g.frame == f) & ~np.isin(g.name, checks.split(","))])) for f in small_block.block.frames}
    few = sorted(f for f, c in counts.items() if c < 4)
    assert few, "the fixture should have frames with fewer than 4 GCPs"
    lines = (tmp_path / "eo.txt").read_text().splitlines()
    (tmp_path / "eo_part.txt").write_text("\n".join(ln for ln in lines if ln.split()[0] not in few) + "\n")
    with pytest.raises(InputError, match=f"frame\\(s\\) {few[0]} \\({counts[few[0]]}\\).*fewer than 4 control"):
        _run(tmp_path, frames=frames, eo=tmp_path / "eo_part.txt", gcps=tmp_path / "gcp_list.txt",
             check_points=checks)
    assert not any((tmp_path / "out").iterdir())
    with pytest.raises(InputError, match="--eo.*--gcps"):
        _run(tmp_path, frames=frames, eo=None)


def _write_dem(path, sb, cell=5.0):
    """The simulated terrain as a GeoTIFF DEM (EPSG:32635) covering the block with a margin."""
    from rasterio.transform import from_origin
    lo, hi = sb.true_xyz[:, :2].min(axis=0) - 800.0, sb.true_xyz[:, :2].max(axis=0) + 800.0
    w, h = int((hi[0] - lo[0]) / cell), int((hi[1] - lo[1]) / cell)
    gx, gy = np.meshgrid(lo[0] + (np.arange(w) + 0.5) * cell, hi[1] - (np.arange(h) + 0.5) * cell)
    z = sb.surface(np.column_stack([gx.ravel(), gy.ravel()])).reshape(h, w).astype(np.float32)
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="float32", crs="EPSG:32635",
                       transform=from_origin(lo[0], hi[1], cell, cell)) as ds:
        ds.write(z[None])
    return path


def test_orthorectify_puts_each_frame_on_the_ground(tmp_path, small_block):
    """Frames whose pixel value is its column (mod 200): in each orthophoto, the value at a control
    point's ground position is the column where the frame measured it (± the noise)."""
    frames, checks = write_block(tmp_path, small_block)
    cols = np.tile(np.arange(200, dtype=np.uint8), (300, 1))
    for path in frames:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with rasterio.open(path, "r+") as ds:
                ds.write(cols[None])
    rep, out = _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_points=checks,
                    orthorectify=True, dem=_write_dem(tmp_path / "dem.tif", small_block))
    g = read_gcp_list(tmp_path / "gcp_list.txt")
    tested = 0
    for name in small_block.block.frames:
        with rasterio.open(out / f"{name}_ortho.tif") as ds:
            assert ds.crs.to_epsg() == 32635
            img = ds.read(1)
            for xyz, px in zip(g.ground[g.frame == name], g.pixel[g.frame == name]):
                r, c = ds.index(xyz[0], xyz[1])
                if 2 < px[0] < 198 and 0 <= r < ds.height and 0 <= c < ds.width:
                    assert abs(int(img[r, c]) - int(px[0])) <= 2, (name, xyz, px)
                    tested += 1
    assert tested >= 10
    assert json.loads((out / "report.json").read_text())["orthorectified"][small_block.block.frames[0]]["width"] > 0


def test_reference_adds_automatic_control(tmp_path, small_block, monkeypatch):
    """--reference: the frames, their approximate orientation, the DEM and the map CRS go to
    automatic_control; its points join the surveyed control with their own σ; no DEM is refused."""
    import fotogeo.tools.triangulate.control as tc
    from fotogeo.io.block import GcpList
    frames, checks = write_block(tmp_path, small_block)
    b = small_block.block
    seen = {}

    def fake(frames_, names, camera, eos, reference, dem, crs, **kw):  # the simulation's tie points, as "found"
        seen.update(names=list(names), eos=eos, reference=reference, dem=dem, crs=crs.to_epsg())
        tie = np.flatnonzero(b.role[b.obs_point] == "tie")
        pick = tie[np.isin(b.obs_point[tie], np.unique(b.obs_point[tie])[:30])]
        return GcpList("EPSG:32635", np.array([f"auto{p}" for p in b.obs_point[pick]], dtype=object),
                       small_block.true_xyz[b.obs_point[pick]], b.obs_pixel[pick],
                       np.array([b.frames[f] for f in b.obs_frame[pick]], dtype=object))
    monkeypatch.setattr(tc, "automatic_control", fake)
    rep, out = _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", check_points=checks,
                    reference=[tmp_path / "ortho.tif"], dem=_write_dem(tmp_path / "dem.tif", small_block),
                    reference_sigma_xy=0.4)
    assert seen["names"] == list(b.frames) and seen["crs"] == 32635 and seen["reference"] == [tmp_path / "ortho.tif"]
    assert [e.X for e in seen["eos"]] == pytest.approx([e.X for e in b.eo])
    assert rep["automatic_control"] == 30 and rep["statistics"]["control"]["n"] >= 30
    import pyogrio
    ctrl = pyogrio.read_dataframe(out / "block.gpkg", layer="control")
    assert ctrl["id"].str.startswith("auto").sum() == 30
    with pytest.raises(InputError, match="needs the DEM"):
        _run(tmp_path, frames=frames, gcps=tmp_path / "gcp_list.txt", reference=[tmp_path / "ortho.tif"],
             overwrite=True)


def test_the_map_crs_comes_from_what_carries_one(tmp_path):
    """No --crs needed (issue 20): the GCPs' CRS, else a projected reference's, else a projected DEM's, else the
    UTM zone of the GPS; ``--crs auto`` is no CRS given; a geographic one is refused by its flag."""
    from pyproj import CRS
    from rasterio.transform import from_origin

    from fotogeo.tools.triangulate.sources import map_crs_rule

    def raster(name, crs):
        with rasterio.open(tmp_path / name, "w", driver="GTiff", width=32, height=32, count=1, dtype="uint8", crs=crs,
                           transform=from_origin(500000, 4420000, 10, 10)) as ds:
            ds.write(np.zeros((1, 32, 32), np.uint8))
        return tmp_path / name
    ref_geo, ref_utm, dem = raster("ref_geo.tif", "EPSG:4326"), raster("ref.tif", "EPSG:32635"), raster("dem.tif",
                                                                                                        "EPSG:32634")
    gps = CRS.from_epsg(32654)
    assert map_crs_rule(None, None, [ref_utm], dem, gps) == (CRS.from_epsg(32635), "the reference orthophoto's CRS "
                                                                                   "(--reference)")
    assert map_crs_rule("auto", None, [ref_geo], dem, gps) == (CRS.from_epsg(32634), "the DEM's CRS (--dem)")
    assert map_crs_rule(None, None, [ref_geo], None, gps) == (gps, "the UTM zone of the images' GPS positions")
    assert map_crs_rule(None, "gcps.txt", [ref_utm], dem, gps) == (None, "the ground control's CRS (--gcps)")
    assert map_crs_rule("EPSG:32633", None, [ref_utm], dem, gps)[1] == "given (--crs)"
    assert map_crs_rule(None, None, None, None, None) == (None, "")
