"""CARS beside fotogeo in ``benchmarks/dsm_bench.py`` (``--cars``, ``--cars-dir``): CARS run now, or a kept run reused
when it ran on these very inputs (``peers_cars.finished_run``), or CARS's runs recorded by ``peers_cars.py``; its
rows against fotogeo's. Split from dsm_bench.py (no change of behaviour but the kept run's inputs checked)."""
from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _cars_rendered(folder: Path, sc: dict, ours: Path, row: dict, keep=None) -> dict:
    """CARS on a rendered pair (its GeoTIFF RPC tags, margins ±100 m): against the truth as fotogeo's row,
    fotogeo − CARS, and fotogeo's CPU, peak memory, NMAD and completeness as ratios of CARS's. With ``keep``
    (``--cars-dir``) the run goes to ``keep/rendered_<folder>`` and a finished one found there is reused (the
    pair is rendered the same every time: fixed seeds) when it ran on these images (``peers_cars.run_inputs``)."""
    from peers_cars import compare_dsms, finished_run, run_cars, run_inputs
    from rendered_rpc_pair import compare
    case = row["case"].replace("rendered_rpc", "rendered_rpc CARS 1.3", 1)
    where = Path(keep) / f"rendered_{folder.name}" if keep else folder / "cars"
    r = ((finished_run(where, run_inputs(*sc["images"][:2])) if keep else None)
         or run_cars(sc["images"][0], sc["images"][1], where, margins=100))
    if "skipped" in r or "error" in r:
        return {"case": case, "skipped": r.get("skipped") or r.get("error"), "log_tail": r.get("log_tail")}
    c = compare(r["dsm"], sc)
    return {"case": case, "config": "GeoTIFF RPC tags, margins 100 m, 1 worker, full resolution only, 0.5 m",
            "rmse_m": c["rmse_m"], "nmad_m": c["nmad_m"], "median_m": c["median_m"], "within_1m": c["within_1m"],
            "completeness": c["completeness"], "cpu_s": r["cpu_s"], "wall_s": r["wall_s"],
            "peak_rss_mib": r["peak_rss_mib"], "max_rss_single_mib": r["max_rss_single_mib"],
            "valid_fraction_in_overlap": r.get("valid_fraction_in_overlap"), "cars_measured": r.get("cars_measured"),
            "initial_height": r.get("initial_height"), "fotogeo_minus_cars": compare_dsms(ours, r["dsm"]),
            "fotogeo_over_cars": {"cpu": row["cpu_s"] / r["cpu_s"], "peak_memory": row["peak_rss_mib"] /
                                  r["peak_rss_mib"], "nmad": row["nmad_m"] / c["nmad_m"],
                                  "completeness": row["completeness"] / c["completeness"]}}


def _valid_area(path) -> float:
    import rasterio
    with rasterio.open(path) as ds:
        h = ds.read(1)
        return float((h != ds.nodata).sum() * abs(ds.transform.a * ds.transform.e))


def _cars_recorded(outs: dict) -> list:
    """CARS's runs recorded by ``benchmarks/peers_cars.py`` on this machine (``results/peers_cars.json``)."""
    rec = ROOT / "benchmarks" / "results" / "peers_cars.json"
    if not rec.is_file():
        return [{"case": "ventoux CARS", "skipped": "no recorded run (benchmarks/peers_cars.py; or pass --cars)"}]
    return _cars_rows(outs, json.loads(rec.read_text()), "recorded")


def _cars_rows(outs: dict, runs: dict, how: str) -> list:
    """CARS's figures (``runs``: ``cars_ventoux_m100``, ``cars_ventoux_bias`` -> :func:`peers_cars.run_cars`'s
    records) and fotogeo's DSMs against CARS's where both have a height (``peers_cars.compare_dsms``: its
    ``share_of_ref_area`` is the share of CARS's valid cells where fotogeo has a height); fotogeo's valid area over
    the same footprint overlap CARS's completeness is measured on."""
    from peers_cars import compare_dsms
    rows = []
    for key, right in (("cars_ventoux_m100", "right_image.geom"), ("cars_ventoux_bias", "right_image_bias.geom"),
                       ("cars_ventoux_m100", "right_image.geom, --refine")):
        r = runs.get(key, {})
        if not r.get("dsm") or not Path(r["dsm"]).is_file():
            rows.append({"case": f"ventoux CARS ({right})", "skipped": f"{how} DSM of {key} not found"})
            continue
        rows.append({"case": f"ventoux CARS ({right.split(',')[0]}, {how}, margins 100 m) vs fotogeo ({right})",
                     "completeness": r.get("valid_fraction_in_overlap"), "median_height_m": r.get("h_median_m"),
                     "cpu_s": r.get("cpu_s"), "wall_s": r.get("wall_s"), "peak_rss_mib": r.get("peak_rss_mib"),
                     "fotogeo_in_cars_overlap": _valid_area(outs[right]) / r["footprint_overlap_m2"],
                     "fotogeo_minus_cars": compare_dsms(outs[right], r["dsm"]), "cars_dsm": r["dsm"]})
    return rows


def _cars(tmp: Path, v: Path, outs: dict, keep=None) -> list:
    """CARS on ventoux now (``peers_cars.run_cars``, margins ±100 m), into ``keep`` (``--cars-dir``) when given,
    where a finished run of an earlier call is reused (``peers_cars.finished_run``), else into ``tmp``."""
    try:
        from peers_cars import finished_run, run_cars, run_inputs
    except ImportError:
        return [{"case": "ventoux CARS", "skipped": "benchmarks/peers_cars.py is not in this checkout"}]
    runs = {}
    for key, right in (("cars_ventoux_m100", "right_image.geom"), ("cars_ventoux_bias", "right_image_bias.geom")):
        folder = Path(keep or tmp) / key
        given = (v / "left_image.tif", v / "right_image.tif", v / "left_image.geom", v / right)
        r = (finished_run(folder, run_inputs(*given)) if keep else None) or run_cars(
            *given[:2], folder, geom1=given[2], geom2=given[3], margins=100)
        if "skipped" in r:
            return [{"case": "ventoux CARS", "skipped": r["skipped"]}]
        runs[key] = r
    return _cars_rows(outs, runs, "kept" if keep else "run now")
