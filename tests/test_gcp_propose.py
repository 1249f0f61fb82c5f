"""GCP proposals (fotogeo.tools.gcp.propose): the NGI frame 0182 against its orthophoto, through the
worker as the QGIS dock runs it; accepted candidates give a DLT whose check RMS is below 1 px."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from pyproj import CRS

from fotogeo.tools.gcp.propose import grid_shape, image_cells, spread_best

ROOT = Path(__file__).resolve().parents[1]
FRAME = "3324c_2015_1004_05_0182"


def test_spread_best_takes_one_per_cell_before_a_second():
    rng = np.random.default_rng(0)
    xy = np.vstack([rng.uniform(0, 50, (40, 2)), [[70, 20], [20, 70], [70, 70]]])  # 40 in one quarter
    score = rng.uniform(0, 1, len(xy))
    pick = spread_best(xy, score, 100, 100, 4)
    assert sorted(image_cells(xy[pick], 100, 100, 4).tolist()) == [0, 1, 2, 3]
    quarter0 = np.flatnonzero(image_cells(xy, 100, 100, 4) == 0)
    assert pick[image_cells(xy[pick], 100, 100, 4) == 0][0] == quarter0[np.argmax(score[quarter0])]
    assert len(spread_best(xy, score, 100, 100, 100)) == len(xy)
    assert len(spread_best(xy, score, 100, 100, 10)) == 10


def run_worker(request: dict, timeout=600) -> dict:
    proc = subprocess.run([sys.executable, "-m", "fotogeo.worker"], input=json.dumps(request) + "\n",
                          capture_output=True, text=True, cwd=ROOT, timeout=timeout)
    return json.loads(proc.stdout.splitlines()[-1])


def test_proposals_on_the_ngi_frame_give_a_dlt_below_one_pixel(data_dir):
    from fotogeo.crs import transform_points
    from fotogeo.io.raster import read_dem
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.tools.gcp.fit import fit_gcps
    ngi = data_dir / "ngi"
    image, dem = ngi / "frames" / f"{FRAME}_RGB.tif", ngi / "dem.tif"
    answer = run_worker({"tool": "propose_gcps", "args": [str(image), str(ngi / "ortho" / "ngi_rgb_byte_1.tif")],
                         "kwargs": {"count": 30, "dem": str(dem)}})
    assert answer["type"] == "result", answer
    out = answer["result"]
    cands = out["candidates"]
    assert len(cands) == 30 and out["model"] == "dlt" and out["consistent"] > 1000
    assert out["lsm"]["refined"] >= 25 and all(0 < c["score"] <= 1 for c in cands)
    px = np.array([[c["col"], c["row"]] for c in cands])
    nx, ny = grid_shape(640, 1152, 9)
    assert len(set(image_cells(px, 640, 1152, 9).tolist())) == nx * ny  # spread over the whole frame
    accepted = [c for c in cands if c["score"] >= 0.1]
    gcps = [{"id": f"c{k}", "col": c["col"], "row": c["row"], "x": c["x"], "y": c["y"], "z": None,
             "role": "control" if k % 2 == 0 else "check"} for k, c in enumerate(accepted)]
    fit = fit_gcps(gcps, "dlt", crs=out["crs"], image=str(image), dem=str(dem))
    assert fit["ok"] and fit["rms"]["n_check"] >= 12 and fit["rms"]["check_px"] < 1.0
    # against the frame's true geometry (camera + exterior orientation + DEM), not only self-consistency
    frame, d = load_ngi_frame(ngi, FRAME), read_dem(dem)
    XY = transform_points(CRS.from_wkt(out["crs"]), CRS.from_wkt(d.crs.to_wkt()), [[c["x"], c["y"]] for c in cands])
    true_px = frame.world_to_pixel(np.column_stack([XY, d.heights(XY)]))
    assert np.median(np.hypot(*(true_px - px).T)) < 1.0


def test_bad_input(tmp_path, data_dir):
    from fotogeo.errors import InputError
    from fotogeo.tools.gcp.propose import propose_gcps
    plain = tmp_path / "plain.tif"
    with rasterio.open(plain, "w", driver="GTiff", width=64, height=64, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 64, 64), np.uint8))
    frame = data_dir / "ngi" / "frames" / f"{FRAME}_RGB.tif"
    with pytest.raises(InputError, match="has no georeference"):
        propose_gcps(frame, plain)
    with pytest.raises(InputError, match="count 0 must be"):
        propose_gcps(frame, plain, count=0)
    with pytest.raises(InputError, match="ratio"):
        propose_gcps(frame, plain, ratio=7)


def test_proposals_without_a_dem_use_the_planar_robust_fit(data_dir):
    from fotogeo.crs import transform_points
    from fotogeo.io.raster import read_dem
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.tools.gcp.propose import propose_gcps
    ngi = data_dir / "ngi"
    out = propose_gcps(ngi / "frames" / f"{FRAME}_RGB.tif", ngi / "ortho" / "ngi_rgb_byte_1.tif", count=12)
    assert out["model"] == "projective" and len(out["candidates"]) == 12 and "z" not in out["candidates"][0]
    frame, d = load_ngi_frame(ngi, FRAME), read_dem(ngi / "dem.tif")
    XY = transform_points(CRS.from_wkt(out["crs"]), CRS.from_wkt(d.crs.to_wkt()),
                          [[c["x"], c["y"]] for c in out["candidates"]])
    true_px = frame.world_to_pixel(np.column_stack([XY, d.heights(XY)]))
    px = np.array([[c["col"], c["row"]] for c in out["candidates"]])
    assert np.median(np.hypot(*(true_px - px).T)) < 1.0
