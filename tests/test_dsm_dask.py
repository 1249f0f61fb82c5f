"""fotogeo dsm's output tiles as Dask tasks (``workers``/``scheduler``, the cluster of triangulate and mosaic):
the same DSM, report counters and point cloud as in this process, for frame and RPC pairs."""
from __future__ import annotations

import pickle

import numpy as np
import pytest
import rasterio

from rendered_pair import CRS, render, render_rpc

distributed = pytest.importorskip("distributed", reason="Dask (fotogeo[batch]) is not installed")


@pytest.fixture(scope="module")
def scheduler():
    """A local cluster of two worker processes (one thread each), its address given as ``scheduler``: one
    cluster for the module's runs (``workers=N`` starts the same kind of cluster per run)."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def _bands(path):
    with rasterio.open(path) as ds:
        return ds.read().astype(np.float64)


def _points(path):
    import laspy
    las = laspy.read(path)
    return np.column_stack([las.x, las.y, las.z])


def _both(sc, tmp_path, monkeypatch, scheduler, tile_cells: int):
    """The DSM in this process and as tasks on the cluster at ``scheduler``, tiles of ``tile_cells`` cells."""
    from fotogeo.tools.dsm import dsm, frames, matching
    monkeypatch.setattr(frames, "SPARSE_SIDE", 200)  # the sparse check runs in this process either way
    monkeypatch.setattr(matching, "TILE_CELLS", tile_cells)  # the tiling too: the tasks get their windows
    runs = {}
    for label, address in (("here", None), ("dask", scheduler)):
        runs[label] = dsm(sc["images"], tmp_path / f"{label}.tif", camera=sc.get("camera"), eo=sc.get("eo"),
                          rpc="camera" not in sc, crs=CRS, scheduler=address,
                          point_cloud=tmp_path / f"{label}.las")
    return runs["here"], runs["dask"]


def _same(here, dask, tmp_path):
    assert dask["grid"] == here["grid"] and min(here["grid"]["width"], here["grid"]["height"]) > 64
    a, b = _bands(tmp_path / "here.tif"), _bands(tmp_path / "dask.tif")
    assert a.shape == b.shape and (a[0] > -32767).mean() > 0.5
    assert np.array_equal(a[0] > -32767, b[0] > -32767) and np.allclose(a, b, atol=1e-4)
    assert dask["completeness"] == here["completeness"] and dask["points_written"] == here["points_written"] > 0
    assert np.allclose(_points(tmp_path / "here.las"), _points(tmp_path / "dask.las"), atol=2e-3)
    for ph, pd in zip(here["pairs"], dask["pairs"]):  # the tasks' counters, merged, are the in-process ones
        for key in ("match_density", "points", "disparity_ranges_px", "ray_miss_px"):
            assert pd.get(key) == ph.get(key), key
    assert not list(tmp_path.glob(".*points*"))  # the tasks' point files are gone


def test_frame_pair_tiles_on_dask_give_the_same_dsm(tmp_path, monkeypatch, scheduler):
    sc = render(tmp_path, 300, seed=5)
    _same(*_both(sc, tmp_path, monkeypatch, scheduler, 64), tmp_path)  # 2 x 3 tiles


def test_rpc_pair_tiles_on_dask_give_the_same_dsm(tmp_path, monkeypatch, scheduler):
    sc = render_rpc(tmp_path, 200, seed=6)
    # 2 x 2 tiles (each matches its left pixels in locally epipolar tiles of 512 pixels: here the whole image)
    _same(*_both(sc, tmp_path, monkeypatch, scheduler, 64), tmp_path)


def test_a_frame_view_pickles_with_the_standard_pickle(tmp_path):
    """What a task is sent for a frame pair pickles without cloudpickle (Dask would fall back to it and hide a
    closure): the view's rays and projection survive the round trip."""
    from fotogeo.tools.dsm.frames import frame_view
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models
    sc = render(tmp_path, 120, seed=1)
    crs = map_crs(CRS, None, sc["eo"], sc["images"], False, sc["camera"])[0]
    view = frame_view(image_models(sc["images"], crs, camera=sc["camera"], eo=sc["eo"])[0])
    back = pickle.loads(pickle.dumps(view))
    px = np.array([[10.0, 20.0], [60.0, 90.0]])
    ground = view.centre + 200.0 * view.rays(px)
    assert np.allclose(back.rays(px), view.rays(px)) and np.allclose(back.forward(ground), view.forward(ground))
    assert np.allclose(view.forward(ground), px, atol=1e-6)
