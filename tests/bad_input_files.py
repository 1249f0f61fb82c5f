"""The bad input files of the bad-input matrix (:mod:`test_bad_input`, :mod:`test_qgis_bad_input`), written
beside a small synthetic scene (:func:`fotogeo.tools.demo.tool.make_scene`), and their fingerprints."""
from __future__ import annotations

import hashlib
from pathlib import Path

import geopandas as gpd
import numpy as np
import rasterio
import shapely

HEADER = "mapX,mapY,sourceX,sourceY,enable,dX,dY,residual"
YAML_OK = "cam:\n  type: pinhole\n  im_size: [900, 700]\n  focal_len: 12.0\n  sensor_size: [10.8, 8.4]\n"


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _snapshot(folder: Path) -> dict:
    return {p.name: _sha(p) for p in sorted(folder.iterdir()) if p.is_file()}


def _write_bad_inputs(d: Path, scene) -> None:
    """Bad (and a few good) input files beside the scene, named as the cases use them."""
    rng = np.random.default_rng(1)
    px = rng.uniform(60, 640, (30, 2))
    XY = rng.uniform(0, 1, (30, 2)) * 2000 + [501000, 4416000]
    ids = [f"G{i}" for i in range(30)]
    gpd.GeoDataFrame({"id": ids, "col": px[:, 0], "row": px[:, 1], "z": 800 + rng.normal(0, 10, 30)},
                     geometry=shapely.points(XY), crs="EPSG:32635").to_file(d / "gcps.gpkg", driver="GPKG")
    geoms = list(shapely.points(XY))
    geoms[3] = None
    gpd.GeoDataFrame({"id": ids, "col": px[:, 0], "row": px[:, 1]}, geometry=geoms,
                     crs="EPSG:32635").to_file(d / "null_geom.gpkg", driver="GPKG")
    rows = "\n".join(f"{i},{x:.2f},{y:.2f},{c:.2f},{r:.2f}" for i, (x, y), (c, r) in zip(ids, XY, px))
    (d / "gcps.csv").write_text("id,x,y,col,row\n" + rows + "\n")
    (d / "text_col.csv").write_text("id,x,y,col,row\n" + rows.replace(f"G5,{XY[5, 0]:.2f},{XY[5, 1]:.2f},{px[5, 0]:.2f}",
                                                                     f"G5,{XY[5, 0]:.2f},{XY[5, 1]:.2f},abc") + "\n")
    lines = "\n".join(f"{x:.2f},{y:.2f},{c:.2f},{-r:.2f},1,0,0,0" for (x, y), (c, r) in zip(XY, px))
    (d / "nan_first.points").write_text(f"#CRS: EPSG:32635\n{HEADER}\nnan,1,2,-3,1,0,0,0\n{lines}\n")
    (d / "nan_no_header.points").write_text("nan,1,2,-3,1,0,0,0\n" + lines + "\n")
    (d / "enable_inf.points").write_text(f"#CRS: EPSG:32635\n{HEADER}\n" + lines.replace(",1,0,0,0", ",inf,0,0,0", 1) + "\n")
    (d / "enable_2.points").write_text(f"#CRS: EPSG:32635\n{HEADER}\n" + lines.replace(",1,0,0,0", ",2,0,0,0", 1) + "\n")
    (d / "positive_y.points").write_text(f"#CRS: EPSG:32635\n{HEADER}\n" + lines.replace(",-", ",") + "\n")
    (d / "empty.points").write_text(f"#CRS: EPSG:32635\n{HEADER}\n")
    (d / "bad.yaml").write_text("cam:\n  type pinhole\n")
    (d / "text_size.yaml").write_text(YAML_OK.replace("[900, 700]", "[wide, high]"))
    (d / "inf_focal.yaml").write_text(YAML_OK.replace("12.0", "1e999"))
    (d / "latin1.yaml").write_bytes(YAML_OK.replace("cam", "caméra").encode("latin-1"))
    (d / "not_raster.tif").write_text("this is not a raster\n")
    (d / "truncated.tif").write_bytes(scene.target.read_bytes()[:3000])
    with rasterio.open(d / "complex.tif", "w", driver="GTiff", width=64, height=64, count=1, dtype="complex64") as ds:
        ds.write((np.ones((64, 64)) * (1 + 2j)).astype("complex64"), 1)
    (d / "a_folder.tif").mkdir()
    pts = "id,ref_col,ref_row,col,row\nA,300,300,300,300\nB,nan,350,350,350\nC,400,400,400,400\n"
    (d / "nan_row.csv").write_text(pts)
    (d / "text_row.csv").write_text(pts.replace("B,nan", "B,left"))
    (d / "targets_nan.csv").write_text("id,col,row\nT1,100,100\nT2,,120\n")
    (d / "rpc_folder").mkdir()


def write_round_two_inputs(d: Path, scene) -> None:
    """Issue 24's bad inputs: GCPs true to the scene's camera, DEMs it cannot have seen (5000 m too high, above
    the camera at 4300 m; in feet; a block 3000 m high on a corner), a camera YAML nested 3000 lists deep, empty
    point tables and a one-point table."""
    rng = np.random.default_rng(2)
    px = rng.uniform(60, 640, (30, 2)) * [840 / 640, 1]
    ground = scene.frame.pixel_to_world(px, scene.dem)
    ok = np.isfinite(ground).all(axis=1)
    gpd.GeoDataFrame({"id": [f"T{i}" for i in range(ok.sum())], "col": px[ok, 0], "row": px[ok, 1],
                      "z": ground[ok, 2]}, geometry=shapely.points(ground[ok, :2]),
                     crs="EPSG:32635").to_file(d / "true_gcps.gpkg", driver="GPKG")
    with rasterio.open(d / "dem.tif") as src:
        profile, z = src.profile, src.read(1)
    corner = np.zeros_like(z)
    corner[:, int(z.shape[1] * 0.8):] = 3000.0
    for name, heights in (("dem_high.tif", z + 5000.0), ("dem_feet.tif", z * 3.2808), ("dem_corner.tif", z + corner)):
        with rasterio.open(d / name, "w", **profile) as dst:
            dst.write(heights.astype(profile["dtype"]), 1)
    (d / "camera.yaml").write_text(YAML_OK)
    (d / "deep.yaml").write_text(YAML_OK.replace("[900, 700]", "[" * 3000 + "900, 700" + "]" * 3000))
    (d / "empty_points.csv").write_text("id,ref_col,ref_row,col,row\n")
    (d / "empty_targets.csv").write_text("id,col,row\n")
    (d / "one_point.csv").write_text("id,ref_col,ref_row,col,row\nA,300,300,300,300\n")
