"""Defaults a GIS user expects (issue 11), on tiny synthetic inputs written to a temporary folder.

- the output CRS: the reference's when projected (a tmerc lon_0=25 like the NGI orthophotos),
  the UTM zone of the centre for a geographic reference, 'utm' / 'reference' / any CRS on request;
- the output grid on the reference's pixels (origin and pixel size whole reference pixels);
- COG output; the report's notes; readable error vectors (auto exaggeration, legend, error grid);
- orient --model auto, the result objects, progress and cancel between candidate models.
Tie points are given (``tie_points=``), so no test depends on feature matching.
"""
from __future__ import annotations

import json
import sqlite3

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from pyproj import CRS
from rasterio.transform import from_origin

import fotogeo
from fotogeo.cli import main
from fotogeo.errors import Cancelled, InputError
from fotogeo.io.vector import VISIBLE_FRACTION, auto_exaggeration, fitting_exaggeration
from fotogeo.models import get_model

TMERC25 = "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs"
ORIGIN = (-57129.45, -3723906.81)  # the NGI orthophoto's corner: tmerc lon_0=25, 5 m pixels
SHIFT = np.array([3.0, 2.0])  # target pixel + SHIFT = reference pixel


def _tif(path, crs=None, transform=None, size=80, seed=0):
    img = np.random.default_rng(seed).integers(1, 255, (1, size, size), dtype="uint8")
    kw = {"crs": crs, "transform": transform} if crs else {}
    with rasterio.open(path, "w", driver="GTiff", width=size, height=size, count=1, dtype="uint8", **kw) as ds:
        ds.write(img)
    return path


@pytest.fixture
def scene(tmp_path):
    """A tmerc reference of 5 m pixels, an unreferenced target and exact tie points with noise."""
    ref = _tif(tmp_path / "ref.tif", TMERC25, from_origin(*ORIGIN, 5.0, 5.0))
    tgt = _tif(tmp_path / "tgt.tif")
    g = np.arange(6.0, 75.0, 3.0)
    ref_px = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    noise = np.random.default_rng(3).normal(0, 0.3, ref_px.shape)
    return {"ref": ref, "tgt": tgt, "tie": (ref_px - SHIFT + noise, ref_px), "dir": tmp_path}


def _register(sc, name="out.tif", **kw):
    return fotogeo.register(sc["ref"], sc["tgt"], sc["dir"] / name, tie_points=sc["tie"], model="affine", **kw)


def test_default_crs_is_a_projected_references_and_the_grid_its_pixels(scene):
    r = _register(scene)
    with rasterio.open(r.output) as ds:
        assert CRS.from_wkt(ds.crs.to_wkt()) == CRS.from_proj4(TMERC25)  # not UTM 35S, the old default
        assert ds.res == (5.0, 5.0)
        off = (np.array([ds.transform.c, ds.transform.f]) - ORIGIN) / 5.0
        assert np.allclose(off, np.round(off), atol=1e-9), off  # origin on a reference pixel corner
        assert ds.width >= 75 and ds.height >= 75
    rep = r.report
    assert rep["output_crs_rule"] == "auto: the reference's CRS (it is projected)"
    assert rep["output_grid"]["aligned_to_reference"] is True
    assert any("aligned to the reference's pixels" in line for line in rep["summary"])
    # a coarser whole multiple stays aligned; a resolution of 1.5 reference pixels only at the origin
    r2 = _register(scene, "o2.tif", resolution=10.0)
    r3 = _register(scene, "o3.tif", resolution=7.5)
    assert r2.report["output_grid"]["aligned_to_reference"] and not r3.report["output_grid"]["aligned_to_reference"]
    for r_ in (r2, r3):
        t = r_.report["output_grid"]["transform"]
        off = (np.array([t[2], t[5]]) - ORIGIN) / 5.0
        assert np.allclose(off, np.round(off), atol=1e-9)


def test_crs_utm_reference_and_given(scene):
    utm = _register(scene, "u.tif", dst_crs="utm")
    assert utm.report["output_crs"] == "EPSG:32735"  # lon ~24.4, lat ~-33.6: zone 35S
    assert utm.report["output_crs_rule"] == "utm: the UTM zone of the reference centre"
    assert utm.report["output_grid"]["aligned_to_reference"] is False
    ref = _register(scene, "r.tif", dst_crs="reference")
    assert ref.report["output_crs_rule"] == "reference: the reference's CRS" and ref.crs == CRS.from_proj4(TMERC25)
    given = _register(scene, "g.tif", dst_crs="EPSG:32734")
    assert given.report["output_crs"] == "EPSG:32734" and given.report["output_crs_rule"] == "given"
    # the same ground point, whichever CRS: the three results agree on the map
    from fotogeo.crs import transform_points
    p = [[40.0, 40.0]]
    a = transform_points(utm.crs, CRS.from_proj4(TMERC25), utm.pixel_to_map(p))
    assert np.allclose(a, ref.pixel_to_map(p), atol=0.01)


def test_geographic_reference(tmp_path):
    ref = _tif(tmp_path / "ref.tif", "EPSG:4326", from_origin(27.0, 39.9, 5e-5, 5e-5))
    tgt = _tif(tmp_path / "tgt.tif")
    g = np.arange(6.0, 75.0, 4.0)
    ref_px = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    r = fotogeo.register(ref, tgt, tmp_path / "o.tif", tie_points=(ref_px - SHIFT, ref_px), model="affine")
    assert r.report["output_crs"] == "EPSG:32635" and "not projected" in r.report["output_crs_rule"]
    with pytest.raises(InputError, match="geographic"):
        fotogeo.register(ref, tgt, tmp_path / "o2.tif", tie_points=(ref_px - SHIFT, ref_px), dst_crs="reference")


def test_cog_output(scene):
    r = _register(scene, cog=True)
    with rasterio.open(r.output) as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert ds.read(1).any()
    plain = _register(scene, "plain.tif")
    with rasterio.open(plain.output) as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") != "COG"
    with rasterio.open(r.output) as a, rasterio.open(plain.output) as b:
        assert (a.read() == b.read()).all() and a.transform == b.transform  # same pixels, other layout
    assert not [p for p in scene["dir"].iterdir() if p.name.startswith(".")]  # no temporary left


def test_cli_cog_and_crs_words(scene, tmp_path):
    """--cog and --crs utm on the command line (matching on the random texture itself: target = reference)."""
    ref = _tif(tmp_path / "r.tif", TMERC25, from_origin(*ORIGIN, 5.0, 5.0), size=300, seed=5)
    tgt = _tif(tmp_path / "t.tif", size=300, seed=5)
    out = tmp_path / "c.tif"
    res = CliRunner().invoke(main, ["register", str(ref), str(tgt), "-o", str(out), "--cog", "--crs", "utm", "-q",
                                    "--model", "affine", "--detector", "sift"])
    assert res.exit_code == 0, res.output
    assert "output CRS EPSG:32735 (utm: the UTM zone of the reference centre)" in res.output
    assert "error vectors x" in res.output and "1 mm on the map" in res.output
    with rasterio.open(out) as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG" and ds.crs.to_epsg() == 32735


def test_report_notes_explain_each_number(scene):
    rep = json.loads(_register(scene).report_path.read_text())
    notes = rep["notes"]
    assert {"control", "check", "residual", "output_crs", "output_grid", "exaggeration", "inliers"} <= set(notes)
    assert "matching noise" in notes["check"] and "reference pixels" in notes["control"]
    assert notes["output_crs"].startswith("auto: the reference's CRS")


def _gpkg_description(path, layer):
    with sqlite3.connect(path) as con:
        return con.execute("select description from gpkg_contents where table_name = ?", (layer,)).fetchone()[0]


def test_error_vectors_auto_exaggeration_legend_and_grid(scene):
    r = _register(scene)
    ev = gpd.read_file(r.vectors, layer="error_vectors")
    k = float(ev.exaggeration.iloc[0])
    pts = np.column_stack([ev.geometry.apply(lambda g: g.coords[0][0]), ev.geometry.apply(lambda g: g.coords[0][1])])
    auto = auto_exaggeration(float(np.median(ev["length"])), pts)
    shown = ev["shown"].to_numpy() == 1  # one arrow per cell and role drawn at full extent
    assert 0 < shown.sum() <= len(ev) and k == fitting_exaggeration(auto, ev["length"][shown], pts) and 1 < k <= auto
    assert np.allclose(ev.geometry.length, k * ev["length"])
    diag = np.hypot(*(pts.max(axis=0) - pts.min(axis=0)))
    drawn = k * float(np.median(ev["length"])) / diag  # the 1-2-5 rounding keeps it within a factor 1.6
    assert drawn < VISIBLE_FRACTION * 1.6 and (k < auto or VISIBLE_FRACTION / 1.6 < drawn), drawn
    legend = r.report["exaggeration"]["legend"]
    assert legend.startswith(f"x{k:g}; 1 mm on the map = ") and (ev.legend == legend).all()
    assert legend in _gpkg_description(r.vectors, "error_vectors")
    # the grid: each cell's vector is the mean residual of the tie points in it
    grid = gpd.read_file(r.vectors, layer="error_grid")
    tp = gpd.read_file(r.vectors, layer="tie_points")
    assert len(grid) >= 4 and (grid.n >= 3).all() and grid.n.sum() <= len(tp)
    cell = grid.iloc[0]
    start = np.array(cell.geometry.coords[0])
    assert np.allclose(np.array(cell.geometry.coords[1]) - start, k * np.array([cell.mean_dx, cell.mean_dy]))
    # every tie point of this regular pattern falls in a cell of >= 3: the cells' means average to the mean
    assert grid.n.sum() == len(tp)
    assert np.isclose((grid.n * grid.mean_dx).sum() / grid.n.sum(), tp.dx.mean())
    assert np.isclose((grid.n * grid.mean_dy).sum() / grid.n.sum(), tp.dy.mean())
    # a number given is used as is
    given = _register(scene, "k10.tif", exaggeration=10)
    ev10 = gpd.read_file(given.vectors, layer="error_vectors")
    assert (ev10.exaggeration == 10).all() and np.allclose(ev10.geometry.length, 10 * ev10["length"])
    assert given.report["exaggeration"]["chosen"] == "given"
    with pytest.raises(InputError, match="exaggeration"):
        _register(scene, "bad.tif", exaggeration="large")


def _gcps(path, mapping, n=30, noise=0.2, seed=1, checks=10):
    """A GCP CSV: pixels uniform over 80 x 80, ground = ``mapping``(pixel), pixel noise ``noise``."""
    rng = np.random.default_rng(seed)
    px = rng.uniform(2, 78, (n, 2))
    XY = mapping(px)
    seen = px + rng.normal(0, noise, px.shape)
    role = ["check" if i < checks else "control" for i in range(n)]
    rows = "".join(f"P{i},{c:.5f},{r:.5f},{X:.4f},{Y:.4f},{ro}\n" for i, ((c, r), (X, Y), ro)
                   in enumerate(zip(seen, XY, role)))
    path.write_text("id,col,row,x,y,role\n" + rows)
    return path


def _affine(px):
    return np.column_stack([500000 + 10 * px[:, 0] + 2 * px[:, 1], 4400000 - 12 * px[:, 1] + 0.5 * px[:, 0]])


def _perspective(px):
    w = 1 + 0.004 * px[:, 0] + 0.003 * px[:, 1]
    return np.column_stack([500000 + 10 * px[:, 0] / w, 4400000 - 10 * px[:, 1] / w])


@pytest.mark.parametrize("mapping, expected", [(_affine, "affine"), (_perspective, "projective")])
def test_orient_auto_chooses_the_simplest_adequate_model(scene, mapping, expected):
    gcps = _gcps(scene["dir"] / "g.csv", mapping)
    messages = []
    o = fotogeo.orient(scene["tgt"], gcps, model="auto", crs="EPSG:32635",
                       progress=lambda f, m: messages.append(m) or True)
    sel = o["model_selection"]
    assert o.model_name == sel["chosen"] == expected and o.model.name == expected
    names = [c["model"] for c in sel["candidates"]]
    assert names[:2] == ["similarity", "affine"] and "poly2" in names and "dlt" not in names  # no heights
    best = min(c["check_rmse_px"] for c in sel["candidates"] if c.get("check_rmse_px") is not None)
    chosen = next(c for c in sel["candidates"] if c["model"] == expected)
    assert chosen["check_rmse_px"] <= 1.05 * best and sel["compared"] == "check_rmse_px"
    simpler = [c for c in sel["candidates"] if c["n_params"] < chosen["n_params"]]
    assert simpler and all(c["check_rmse_px"] > 1.05 * best for c in simpler)
    assert sum("fitting candidate model" in m for m in messages) == len(names)
    assert o["notes"]["model_selection"].startswith("auto: simplest of")


def test_orient_auto_without_check_points_uses_leave_one_out(scene):
    gcps = _gcps(scene["dir"] / "g.csv", _affine, checks=0)
    o = fotogeo.orient(scene["tgt"], gcps, model="auto", crs="EPSG:32635")
    assert o["model_selection"]["compared"] == "loo_median_px" and o.model_name == "affine"


def test_orient_auto_cancel_between_candidates(scene):
    gcps = _gcps(scene["dir"] / "g.csv", _affine)
    seen = []

    def stop_at_third(f, m):
        seen.append(m)
        return sum("fitting candidate model" in x for x in seen) < 3
    with pytest.raises(Cancelled, match="candidate model"):
        fotogeo.orient(scene["tgt"], gcps, model="auto", crs="EPSG:32635", report=scene["dir"] / "r.json",
                       progress=stop_at_third)
    assert not (scene["dir"] / "r.json").exists()


def test_cli_orient_auto(scene):
    gcps = _gcps(scene["dir"] / "g.csv", _affine)
    res = CliRunner().invoke(main, ["orient", str(scene["tgt"]), str(gcps), "--model", "auto", "--crs", "EPSG:32635",
                                    "-q", "--vectors", str(scene["dir"] / "v.gpkg")])
    assert res.exit_code == 0, res.output
    assert "model affine:" in res.output and "auto chose affine: simplest of" in res.output
    assert "error vectors x" in res.output


def test_orientation_result_object(scene):
    from fotogeo.worker import to_json
    gcps = _gcps(scene["dir"] / "g.csv", _affine)
    o = fotogeo.orient(scene["tgt"], gcps, model="affine", crs="EPSG:32635", report=scene["dir"] / "r.json")
    assert isinstance(o, fotogeo.Orientation) and o.outputs == {"report": scene["dir"] / "r.json"}
    assert o["check"]["n"] == 10 and o.get("blunder") is None and "control" in o and o.model_name == "affine"
    with pytest.raises(Exception):
        o.report = {}  # frozen
    assert to_json(o) == json.loads(json.dumps(to_json(o))) and to_json(o)["model_name"] == "affine"
    assert json.loads((scene["dir"] / "r.json").read_text())["check"] == json.loads(json.dumps(to_json(o)["check"]))
    # one direction for the user: map_to_pixel is the model (ground -> pixel), pixel_to_map its inverse
    XY = _affine(np.array([[20.0, 30.0]]))
    assert np.allclose(o.map_to_pixel(XY), o.model.forward(XY), atol=1e-9)
    assert np.allclose(o.pixel_to_map(o.map_to_pixel(XY)), XY, atol=1e-6)
    assert np.allclose(o.map_to_pixel(XY), [[20.0, 30.0]], atol=0.3)


def test_registration_result_directions(scene):
    r = _register(scene)
    assert isinstance(r, fotogeo.Registration) and r.georeference.direction == "image-to-ground"
    px = np.array([[10.0, 20.0], [50.5, 60.5]])
    XY = r.pixel_to_map(px)
    assert np.allclose(XY, r.model.forward(px))  # 2-D: the model maps pixel -> map
    assert np.allclose(r.map_to_pixel(XY), px, atol=1e-6)
    expect = np.array(ORIGIN) + (px + SHIFT) * [5.0, -5.0]
    assert np.allclose(XY, expect, atol=1.0)  # 0.3 px noise on the tie points: well within a 5 m pixel


def test_same_exaggeration_for_every_model_and_plot(scene):
    gcps = _gcps(scene["dir"] / "g.csv", _perspective)
    a = fotogeo.orient(scene["tgt"], gcps, model="affine", crs="EPSG:32635", vectors=scene["dir"] / "a.gpkg",
                       plot=scene["dir"] / "a.png")
    p = fotogeo.orient(scene["tgt"], gcps, model="projective", crs="EPSG:32635", vectors=scene["dir"] / "p.gpkg")
    assert a["check"]["rms_xy_px"] > 3 * p["check"]["rms_xy_px"]  # different residuals ...
    assert a["exaggeration"]["factor"] == p["exaggeration"]["factor"] > 1  # ... drawn at the same scale
    ev = gpd.read_file(scene["dir"] / "a.gpkg", layer="error_vectors")
    assert (ev.exaggeration == a["exaggeration"]["factor"]).all() and (ev.legend == a["exaggeration"]["legend"]).all()
    import cv2
    img = cv2.imread(str(scene["dir"] / "a.png"))
    assert img is not None and img.shape[1] >= 80
    # the scale bar: a white box in the bottom-left corner with a black bar 20 px above the bottom
    h = img.shape[0]
    assert (img[h - 46, 10:14] == 255).all() and (img[h - 20, 16:20] < 60).all()


def test_terrain_candidates_report_progress_and_cancel():
    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
    from fotogeo.orientation.terrain import fit_terrain
    rng = np.random.default_rng(0)
    cam = FrameCamera(12.0, (10.8, 8.4), (900, 700))
    frame = OrientedFrame(cam, ExteriorOrientation(1000.0, 2000.0, 3500.0, 3.0, -2.0, 160.0), "t")
    XYZ = np.column_stack([rng.uniform(-1000, 3000, 3000), rng.uniform(0, 4000, 3000), rng.uniform(-30, 30, 3000)])
    px = frame.world_to_pixel(XYZ)
    ok = np.isfinite(px).all(axis=1) & (px[:, 0] > 0) & (px[:, 0] < 900) & (px[:, 1] > 0) & (px[:, 1] < 700)
    XYZ, px = XYZ[ok][:300], px[ok][:300] + rng.normal(0, 0.2, (min(300, ok.sum()), 2))
    assert len(px) == 300
    seen = []
    fit = fit_terrain(px, XYZ, model="auto", camera=cam, threshold_m=30.0, min_sigma_m=3.0,
                      progress=lambda f, m: seen.append((f, m)) or True)
    cands = [m for _, m in seen if m.startswith("fitting candidate model")]
    assert cands == [f"fitting candidate model {c['model']} ({i + 1}/{len(fit.candidates)})"
                     for i, c in enumerate(fit.candidates)] and len(cands) == 5
    assert [f for f, _ in seen] == sorted(f for f, _ in seen)  # monotonic
    assert get_model(fit.model.name).src_dims == 3
    with pytest.raises(Cancelled, match="fitting candidate model"):
        fit_terrain(px, XYZ, model="auto", camera=cam, threshold_m=30.0, min_sigma_m=3.0,
                    progress=lambda f, m: "(2/" not in m)
