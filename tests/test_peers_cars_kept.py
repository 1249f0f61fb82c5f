"""benchmarks/peers_cars.finished_run: a CARS run kept in its folder (``dsm_bench.py --cars-dir``) is reused only
when it finished, with the CPU of its ``time.txt`` and the wall time and peak memory its ``run.json`` kept."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from peers_cars import finished_run  # noqa: E402

TIME_V = "\tUser time (seconds): 136.05\n\tSystem time (seconds): 6.17\n" \
         "\tMaximum resident set size (kbytes): 1124868\n\tExit status: {}\n"


def _dsm(path: Path):
    path.parent.mkdir(parents=True)
    h = np.full((4, 5), 538.0, np.float32)
    h[0, 0] = -32768
    with rasterio.open(path, "w", driver="GTiff", width=5, height=4, count=1, dtype="float32", nodata=-32768,
                       crs="EPSG:32631", transform=from_origin(600000, 4900000, 0.5, 0.5)) as ds:
        ds.write(h[None])


def test_a_kept_run_is_reused_only_when_finished(tmp_path):
    assert finished_run(tmp_path) is None  # nothing ran: the benchmark runs CARS
    (tmp_path / "time.txt").write_text("\tUser time (seconds): 3.0\n")  # killed before /usr/bin/time's summary
    assert finished_run(tmp_path) is None
    (tmp_path / "time.txt").write_text(TIME_V.format(1))
    assert "error" in finished_run(tmp_path)  # CARS failed: never read as a run
    (tmp_path / "time.txt").write_text(TIME_V.format(0))
    assert "error" in finished_run(tmp_path)  # no DSM
    _dsm(tmp_path / "out" / "dsm" / "dsm.tif")
    (tmp_path / "run.json").write_text(json.dumps({"exit_code": 0, "wall_s": 1514.7, "peak_rss_mib": 2900}))
    r = finished_run(tmp_path)
    assert r["cpu_s"] == 142.2 and r["max_rss_single_mib"] == 1099 and r["wall_s"] == 1514.7
    assert r["peak_rss_mib"] == 2900 and r["dsm"].endswith("dsm.tif") and r["valid_fraction"] == 19 / 20


def test_the_rendered_pair_reuses_a_kept_run(tmp_path, monkeypatch):
    """``dsm_bench.py --cases rendered_rpc --cars --cars-dir DIR``: a finished CARS run of the B/H 0.4 pair kept in
    ``DIR/rendered_BH_0.4`` is read, not run again (before: CARS ran into the temporary folder every time, ~170-310 s
    of CPU, and ``--cars-dir`` applied to ventoux only)."""
    import peers_cars
    import rendered_rpc_pair
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import dsm_bench
    kept = tmp_path / "cars" / "rendered_BH_0.4"
    kept.mkdir(parents=True)
    (kept / "time.txt").write_text(TIME_V.format(0))
    _dsm(kept / "out" / "dsm" / "dsm.tif")
    images = [tmp_path / "a.tif", tmp_path / "b.tif"]
    for k, p in enumerate(images):
        p.write_bytes(bytes([k]) * 3000)
    (kept / "run.json").write_text(json.dumps({"exit_code": 0, "wall_s": 1281.0, "peak_rss_mib": 3721,
                                               "inputs": peers_cars.run_inputs(*images)}))

    def no_run(*a, **k):
        raise AssertionError("CARS ran again")
    monkeypatch.setattr(peers_cars, "run_cars", no_run)
    monkeypatch.setattr(rendered_rpc_pair, "compare", lambda *a, **k: {
        "rmse_m": 1.0, "nmad_m": 0.3, "median_m": 0.0, "within_1m": 0.9, "completeness": 0.85})
    monkeypatch.setattr(peers_cars, "compare_dsms", lambda ours, ref: {"ref": ref})
    row = {"case": "rendered_rpc 1024², B/H 0.4", "cpu_s": 40.0, "peak_rss_mib": 450.0, "nmad_m": 0.29,
           "completeness": 0.916}
    r = dsm_bench._cars_rendered(tmp_path / "BH_0.4", {"images": images}, tmp_path / "DSM.tif", row,
                                 keep=tmp_path / "cars")
    assert r["cpu_s"] == 142.2 and r["fotogeo_minus_cars"]["ref"] == str(kept / "out" / "dsm" / "dsm.tif")
    assert r["fotogeo_over_cars"]["cpu"] == 40.0 / 142.2


def test_a_kept_run_of_other_inputs_is_not_reused(tmp_path):
    """``--cars-dir`` reused a kept run by its folder's name alone: a run of other images (another rendering of
    the pair, another geom) stood for this one. ``run.json`` now keeps the inputs' size and the SHA-256 of their
    first MiB (``peers_cars.run_inputs``); a run is reused only for the same, and one kept without them is run
    again."""
    from peers_cars import run_inputs
    a, b, c = (tmp_path / f"{n}.tif" for n in "abc")
    a.write_bytes(b"\x01" * 5000)
    b.write_bytes(b"\x02" * 5000)
    c.write_bytes(b"\x02" * 4999 + b"\x03")  # the same size, other bytes
    (tmp_path / "time.txt").write_text(TIME_V.format(0))
    _dsm(tmp_path / "out" / "dsm" / "dsm.tif")
    (tmp_path / "run.json").write_text(json.dumps({"exit_code": 0}))
    assert finished_run(tmp_path, run_inputs(a, b)) is None  # kept before its inputs were recorded
    assert finished_run(tmp_path)["cpu_s"] == 142.2  # asked without inputs: as before
    (tmp_path / "run.json").write_text(json.dumps({"exit_code": 0, "inputs": run_inputs(a, b)}))
    assert finished_run(tmp_path, run_inputs(a, b))["cpu_s"] == 142.2
    assert finished_run(tmp_path, run_inputs(a, c)) is None and finished_run(tmp_path, run_inputs(b, a)) is None
    assert finished_run(tmp_path, run_inputs(a, b, a)) is None  # a geom the kept run did not have
