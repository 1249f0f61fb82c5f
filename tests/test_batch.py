"""Batch co-registration on Dask (issue 15): scene pairs made from Landsat RGB by known warps, every
result checked against its warp; a failing scene isolated; resume; a scheduler address (Dask
processes started here); a worker killed mid-batch; the command line; Dask missing. Issue 19: a
time series of one area with ``--local``, each date's own smooth distortion removed by its field."""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

distributed = pytest.importorskip("distributed", reason="Dask is the 'batch' extra: pip install -e '.[batch]'")

import coreg_scenes as cs  # noqa: E402
from batch_scenes import make_scene, make_unmatchable, model_error_px  # noqa: E402
from fotogeo.errors import InputError  # noqa: E402
from fotogeo.io.manifest import read_csv  # noqa: E402
from fotogeo.tools.register.batch import register_batch  # noqa: E402

SIZE = 320
OPTIONS = {"detector": "sift", "max_keypoints": 2000, "dst_crs": "EPSG:32618"}


@pytest.fixture(scope="module")
def scenes(data_dir, tmp_path_factory):
    """(reference, {path: H}, unmatchable path): four warped scenes of Landsat RGB and one of noise."""
    ref = data_dir / "landsat_rgb" / "RGB.byte.tif"
    folder = tmp_path_factory.mktemp("scenes")
    warps = dict(make_scene(ref, folder, k, SIZE) for k in range(4))
    return ref, warps, make_unmatchable(folder)


@pytest.fixture(scope="module")
def thread_client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c, \
            distributed.Client(c) as client:
        yield client


def _check_all(ref, warps, outdir, rows):
    """Every scene registered, its model within 0.5 reference px of the known warp everywhere."""
    by_target = {r["target"]: r for r in rows}
    for path, H in warps.items():
        row = by_target[str(path.resolve())]
        assert row["status"] == "ok", row
        assert row["inliers"] >= 50 and row["check_rmse_px"] < 1.0 and row["seconds"] is not None
        assert model_error_px(outdir / f"{path.stem}.json", ref, H, SIZE) < 0.5
        assert (outdir / f"{path.stem}.tif").is_file() and (outdir / f"{path.stem}.gpkg").is_file()


def test_batch_checks_every_scene_and_isolates_a_failure(scenes, thread_client, tmp_path):
    import geopandas as gpd
    ref, warps, noise = scenes
    seen = []
    r = register_batch(ref, [*warps, noise], tmp_path / "out", client=thread_client, progress=lambda f, m: seen.append(f)
                       or True, **OPTIONS)
    assert (r.ok, r.failed, r.skipped) == (4, 1, 0)
    rows = read_csv(r.manifest_csv)
    _check_all(ref, warps, tmp_path / "out", rows)
    failed = [x for x in rows if x["status"] == "failed"]
    assert [x["scene"] for x in failed] == ["noise"] and "\n" not in failed[0]["error"] and failed[0]["error"]
    assert r.failures == {"noise": failed[0]["error"]}
    layer = gpd.read_file(r.manifest_gpkg, layer="scenes")
    assert len(layer) == 5 and layer.crs.to_epsg() == 4326
    ok = layer[layer.status == "ok"]
    assert ok.geometry.notna().all() and ok.geometry.is_valid.all()
    # the footprints lie on the reference (Landsat RGB: about 77-79 W, 23-26 N... in lon/lat)
    with __import__("rasterio").open(ref) as ds:
        from pyproj import Transformer
        lon, lat = Transformer.from_crs(ds.crs, "EPSG:4326", always_xy=True).transform(
            (ds.bounds.left + ds.bounds.right) / 2, (ds.bounds.top + ds.bounds.bottom) / 2)
    assert all(abs(g.centroid.x - lon) < 1 and abs(g.centroid.y - lat) < 1 for g in ok.geometry)
    assert seen[-1] == 1.0 and seen == sorted(seen)


def test_resume_skips_finished_scenes(scenes, thread_client, tmp_path):
    ref, warps, noise = scenes
    out = tmp_path / "out"
    first = list(warps)[:2]
    register_batch(ref, first, out, client=thread_client, **OPTIONS)
    stamps = {p.stem: (out / f"{p.stem}.tif").stat().st_mtime_ns for p in first}
    (out / f"{first[1].stem}.json").unlink()  # an incomplete scene is registered again
    r = register_batch(ref, [*warps, noise], out, client=thread_client, **OPTIONS)
    assert (r.ok, r.failed, r.skipped) == (3, 1, 1)
    assert (out / f"{first[0].stem}.tif").stat().st_mtime_ns == stamps[first[0].stem]
    assert (out / f"{first[1].stem}.tif").stat().st_mtime_ns != stamps[first[1].stem]
    _check_all(ref, warps, out, read_csv(r.manifest_csv))
    # a crash between the outputs and the manifest: the report proves the scene done
    (out / "manifest.csv").unlink()
    r = register_batch(ref, list(warps), out, client=thread_client, **OPTIONS)
    assert (r.ok, r.failed, r.skipped) == (0, 0, 4)
    r = register_batch(ref, first[:1], out, client=thread_client, resume=False, **OPTIONS)
    assert (r.ok, r.skipped) == (1, 0)


def test_bad_batches_are_refused_before_any_work(scenes, tmp_path):
    ref, warps, _ = scenes
    with pytest.raises(InputError, match="no file matches"):
        register_batch(ref, str(tmp_path / "nothing*.tif"), tmp_path / "o", client=object())
    with pytest.raises(InputError, match="ratio"):
        register_batch(ref, list(warps), tmp_path / "o", client=object(), ratio=7)
    with pytest.raises(InputError, match="replace an input"):
        register_batch(ref, list(warps), next(iter(warps)).parent, client=object())


def test_dask_missing_gives_one_clear_line(scenes, tmp_path, monkeypatch):
    ref, warps, _ = scenes
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(InputError, match=r"pip install 'fotogeo\[batch\]'"):
        register_batch(ref, list(warps)[:1], tmp_path / "o")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _worker_pids(client) -> dict:
    return client.run(os.getpid)


def test_scheduler_address_and_a_killed_worker(scenes, tmp_path):
    """`dask scheduler` + `dask worker` processes started here; the command line points at them with
    --scheduler and a list file; one worker is killed while it runs a scene: the batch completes
    and that scene is registered by a worker again (Dask retries the tasks of a lost worker)."""
    from click.testing import CliRunner
    from fotogeo.cli import main
    ref, warps, _ = scenes
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    procs = [subprocess.Popen([*dask, "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers", "2",
                                       "--nthreads", "1", "--no-dashboard"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with distributed.Client(address, timeout="30s") as watcher:
            watcher.wait_for_workers(2, timeout=60)
            listing = tmp_path / "targets.txt"
            listing.write_text("".join(f"{p}\n" for p in warps) * 1, encoding="utf-8")
            killed = {}
            finished = threading.Event()

            def kill_a_busy_worker():
                deadline = time.monotonic() + 60
                while time.monotonic() < deadline and not killed and not finished.is_set():
                    busy = {w: keys for w, keys in watcher.processing().items() if keys}
                    if busy:
                        pids = _worker_pids(watcher)
                        worker, keys = next(iter(busy.items()))
                        time.sleep(0.3)  # inside the scene, not at its start
                        killed.update(worker=worker, keys=list(keys))
                        os.kill(pids[worker], signal.SIGKILL)
                    time.sleep(0.05)

            killer = threading.Thread(target=kill_a_busy_worker, daemon=True)
            killer.start()
            result = CliRunner().invoke(main, ["register-batch", str(ref), str(listing), "-o", str(tmp_path / "out"),
                                               "--scheduler", address, "-q", "--detector", "sift",
                                               "--max-keypoints", "2000", "--crs", "EPSG:32618"])
            finished.set()
            killer.join(timeout=5)
        assert result.exit_code == 0, result.output
        assert "4 registered, 0 done before, 0 failed" in result.output
        assert killed, "no worker was busy to be killed"
        rows = read_csv(tmp_path / "out" / "manifest.csv")
        _check_all(ref, warps, tmp_path / "out", rows)
        killed_scenes = {k.split("-")[2] for k in map(str, killed["keys"])}
        assert killed_scenes and all(r["status"] == "ok" for r in rows if r["scene"] in killed_scenes)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_local_process_cluster(scenes, tmp_path):
    """The default route: a local cluster of worker processes (here two), made and closed by the batch."""
    ref, warps, _ = scenes
    r = register_batch(ref, list(warps)[:2], tmp_path / "out", workers=2, **OPTIONS)
    assert (r.ok, r.failed) == (2, 0)
    rows = read_csv(r.manifest_csv)
    _check_all(ref, dict(list(warps.items())[:2]), tmp_path / "out", rows)
    assert len({row["worker"] for row in rows}) >= 1 and all(str(os.getpid()) not in row["worker"] for row in rows)


LOCAL = ["--local", "--local-grid-spacing", "32", "--local-window", "64", "--resampling", "cubic"]


@pytest.fixture(scope="module")
def dates(data_dir, tmp_path_factory):
    """(reference, {date: E}): three dates of one area, each under its own sinusoidal distortion."""
    return cs.time_series(tmp_path_factory.mktemp("dates"), 3)


def _check_local(ref, targets, outdir, rows):
    """Every date registered with its own field (``<scene>_field.tif``, layer ``local_windows``): the
    distortion it had (median >= 1 px) is gone (median < 0.12 px, CE90 < 0.3 px, as for ``register``)."""
    import pyogrio
    assert {r["target"]: r["status"] for r in rows} == {str(p.resolve()): "ok" for p in targets}
    for path in targets:
        assert (outdir / f"{path.stem}_field.tif").is_file()
        assert "local_windows" in {n for n, _ in pyogrio.list_layers(outdir / f"{path.stem}.gpkg")}
        before, after = cs.misregistration(ref, path), cs.misregistration(ref, outdir / f"{path.stem}.tif")
        assert before["median"] > 1.0, before
        assert after["median"] < 0.12 and after["ce90"] < 0.3, (path.stem, before, after)


def test_time_series_local_field_on_the_default_local_cluster(dates, tmp_path):
    """``register-batch --local`` from the command line, on the cluster of worker processes it makes."""
    from click.testing import CliRunner
    from fotogeo.cli import main
    ref, targets = dates
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["register-batch", str(ref), str(next(iter(targets)).parent / "date_*.tif"),
                                       "-o", str(out), "--workers", "2", "-q", *LOCAL])
    assert result.exit_code == 0, result.output
    _check_local(ref, targets, out, read_csv(out / "manifest.csv"))


def test_time_series_local_field_on_a_given_client(dates, thread_client, tmp_path):
    """The Python API on a client given; a date registered before without ``local`` (no field) is
    registered again, one with its field is skipped; a target named like another's field is refused."""
    ref, targets = dates
    paths = list(targets)
    r = register_batch(ref, paths[:1], tmp_path / "out", client=thread_client, resampling="cubic")
    assert (r.ok, r.failed) == (1, 0), r.failures
    opts = dict(local=True, local_grid_spacing=32, local_window=64, resampling="cubic")
    r = register_batch(ref, paths, tmp_path / "out", client=thread_client, **opts)
    assert (r.ok, r.failed, r.skipped) == (3, 0, 0), r.failures
    _check_local(ref, targets, tmp_path / "out", read_csv(r.manifest_csv))
    r = register_batch(ref, paths, tmp_path / "out", client=thread_client, **opts)
    assert (r.ok, r.skipped) == (0, 3)
    twin = tmp_path / f"{paths[0].stem}_field.tif"
    twin.write_bytes(paths[0].read_bytes())
    with pytest.raises(InputError, match="two scenes would write"):
        register_batch(ref, [paths[0], twin], tmp_path / "o2", client=thread_client, **opts)


def test_manifest_names_the_2d_model():
    """A 2-D registration's report stores the model as Model.to_dict() ({"model": "projective", ...}): the manifest's
    model column was empty for every such scene (register-batch on NGI tile 1, 2 scenes ok)."""
    from fotogeo.tools.register.batch import scene_row
    row = scene_row("s", "t.tif", {"model": {"model": "projective", "params": [1.0] * 9}}, "o.tif")
    assert row["model"] == "projective"
    assert scene_row("s", "t.tif", {"terrain": {"chosen": "dlt"}, "model": {"model": "dlt"}}, "o.tif")["model"] == "dlt"


def test_a_nir_only_scene_of_a_batch_is_matched_again_on_the_reference_bands(data_dir, thread_client, tmp_path):
    """Issue 32's band sets in a batch: an RGB reference and a NIR-only target (s2, r45_s1.2_p, the case of
    tests/test_register_band_sets.py) registered by register_batch go through the same band re-match as
    ``register`` (fotogeo.tools.register.bands.rematch, called by find_tie_points for every scene): the scene's
    report names it and the fit is sub-pixel. Without the re-match the PCA fusions keep 11 SURF inliers and the
    scene fails."""
    import json

    import numpy as np
    import rasterio
    from fotogeo.models import model_from_dict
    from known_warps import known_warp_bands
    ref, tgt, grid, truth = known_warp_bands(data_dir, "s2", "r45_s1.2_p", "ref3_tgtN", tmp_path)
    r = register_batch(ref, [tgt], tmp_path / "out", client=thread_client, seed=0)
    assert (r.ok, r.failed) == (1, 0), r.failures
    report = json.loads((tmp_path / "out" / f"{tgt.stem}.json").read_text(encoding="utf-8"))
    again = report["bands_rematched"]
    assert again["kept"] and again["combined"] == "reference" and again["inliers_after"] > 10 * again["inliers_before"]
    with rasterio.open(ref) as ds:
        px = abs(ds.transform.a)
    err = np.hypot(*(model_from_dict(report["model"]).forward(grid) - truth).T)
    assert np.sqrt(np.mean(err ** 2)) / px <= 0.05
