"""The numbers of benchmarks/register_bench.py: a worker's result summarised (:func:`summarise`), rows merged into an
earlier run's JSON (:func:`merge_rows`), the table and the fotogeo SURF / peer ratios printed."""
from __future__ import annotations

import json
from pathlib import Path

from register_bench_common import fmt


def summarise(res, truth, case):
    """Flat numbers for the table (and the JSON) from a worker result."""
    t = res.get("timings_s", {})
    s = {"ok": res["ok"], "peak_rss_mb": res.get("peak_rss_mb"), "base_rss_mb": res.get("base_rss_mb"),
         "error": res.get("error")}
    if res["method"].startswith("otb"):
        o = res.get("otb", {})
        s.update(otb_peak_mb=o.get("otb_peak_mb"), otb_pairs=o.get("pairs"),
                 keypoints=[o.get("keypoints_reference"), o.get("keypoints_target")])
        features = t.get("read_fuse_reference", 0) + t.get("read_fuse_target", 0) + t.get("otb", 0)
        s["time_s"] = {"features_and_matching": features, "otb_call": t.get("otb"), "fit": t.get("fit"),
                       "resample": t.get("resample"),
                       "total": features + t.get("total", 0) if "total" in t else None}
    else:
        features = sum(t.get(k, 0) for k in ("read_fuse_reference", "detect_reference", "read_fuse_target",
                                             "detect_target", "match"))
        s["time_s"] = {"features_and_matching": features if t else None,
                       "read_fuse": t.get("read_fuse_reference", 0) + t.get("read_fuse_target", 0) if t else None,
                       "detect": t.get("detect_reference", 0) + t.get("detect_target", 0) if t else None,
                       "match": t.get("match"), "fit": t.get("fit"), "resample": t.get("resample"),
                       "total": t.get("total")}
    if res["ok"]:
        rep = res["report"]
        kp = rep["keypoints"]
        s.update(keypoints=[kp.get("reference"), kp.get("target")], matches=rep["matches"], inliers=rep["inliers"],
                 check_n=rep["check"].get("n"), check_rmse_m=rep["check"].get("rmse_m"),
                 check_rmse_px=rep["check"].get("rmse_px"), weak_fit=weak_fit(rep))
        if truth is not None:
            from fotogeo.models import model_from_dict
            s.update(truth.in_crs(rep["output_crs"]).evaluate(model_from_dict(rep["model"]), case["reference"],
                                                               res.get("raw")))
    elif truth is not None and res.get("raw"):
        s.update(truth.correct_share(res["raw"], case["reference"]))
    return s


def weak_fit(rep) -> dict | None:
    """What register's weak-fit check did (``None``: the feature fit was strong, the windows never ran)."""
    se = rep.get("corner_standard_error_px")
    if rep.get("windows_check"):
        return {"corner_se_px": se, "kept": "feature fit", **{k: rep["windows_check"].get(k) for k in (
            "feature_fit_rmse_px", "windows_fit_rmse_px", "at")}}
    area = rep.get("area_based")
    if area:
        c = area.get("compared") or {}
        return {"why": area.get("why"), "corner_se_px": c.get("feature_fit_corner_se_px"), "kept": "windows",
                "feature_fit_rmse_px": c.get("feature_fit_rmse_px"),
                "windows_fit_rmse_px": c.get("windows_fit_rmse_px"), "at": c.get("at"),
                "window_tie_points": rep.get("matches")}
    return None


def merge_rows(output: Path, rows: list, run: dict) -> tuple[list, list]:
    """The rows of ``output`` (an earlier run's JSON) with this run's rows in place of the same (case, method)
    and the others kept, each tagged with the run that measured it (``measured``); and the runs merged."""
    old = json.loads(output.read_text())
    first = {k: old.get(k) for k in ("command", "date", "source")}
    runs = old.get("runs") or [first]
    for r in rows:
        r["measured"] = run
    new = {(r["case"], r["method"]): r for r in rows}
    kept = [{**r, "measured": r.get("measured", first)} for r in old["rows"] if (r["case"], r["method"]) not in new]
    order = [(r["case"], r["method"]) for r in old["rows"]]
    merged = sorted(kept + rows, key=lambda r: order.index((r["case"], r["method"]))
                    if (r["case"], r["method"]) in order else len(order))
    return merged, runs + [run]


def print_table(rows):
    hdr = (f"{'case':<13}{'method':<6}{'kp ref/tgt':>14}{'match':>7}{'inl':>6}{'chk':>5}{'chk m':>8}{'chk px':>8}"
           f"{'dense m':>9}{'best m':>8}{'d/best':>7}{'corr%':>7}{'t feat':>8}{'t fit':>7}{'t res':>7}"
           f"{'t tot':>8}{'peak MB':>9}")
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        s = r["summary"]
        kp = s.get("keypoints") or [None, None]
        kps = f"{fmt(kp[0], '{:d}')}/{fmt(kp[1], '{:d}')}"
        t = s["time_s"]
        peak = fmt(s["peak_rss_mb"], "{:.0f}")
        if r["method"].startswith("otb") and s.get("otb_peak_mb") is not None:
            peak += f"+{s['otb_peak_mb']:.0f}"
        corr = fmt(100 * s["raw_correct_share"], "{:.0f}") if "raw_correct_share" in s else "-"
        if s.get("raw_correct_against", "truth") != "truth":
            corr = "~" + corr  # against the target's own georeference, not a truth
        print(f"{r['case']:<13}{r['method']:<6}{kps:>14}{fmt(s.get('matches', s.get('otb_pairs')), '{:d}'):>7}"
              f"{fmt(s.get('inliers'), '{:d}'):>6}{fmt(s.get('check_n'), '{:d}'):>5}{fmt(s.get('check_rmse_m')):>8}"
              f"{fmt(s.get('check_rmse_px')):>8}{fmt(s.get('dense_rmse_m')):>9}"
              f"{fmt(s.get('best_homography_rmse_m')):>8}"
              f"{fmt(s.get('dense_over_best')):>7}{corr:>7}{fmt(t.get('features_and_matching')):>8}"
              f"{fmt(t.get('fit')):>7}{fmt(t.get('resample')):>7}{fmt(t.get('total')):>8}{peak:>9}")
        if not s["ok"]:
            print(f"{'':<19}FAILED: {s['error'][:240]}")


def ratios(rows):
    """fotogeo SURF / peer for total time, check RMSE, dense RMSE, peak memory."""
    by = {(r["case"], r["method"]): r["summary"] for r in rows}
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        ours = by.get((case, "surf"))
        for peer in ("sift", "otb", "otb180"):
            other = by.get((case, peer))
            if not ours or not other:
                continue

            def q(a, b):
                return a / b if (a is not None and b not in (None, 0) and ours["ok"] and other["ok"]) else None
            out.append({"case": case, "peer": peer,
                        "time": q(ours["time_s"]["total"], other["time_s"]["total"]),
                        "check_rmse": q(ours.get("check_rmse_m"), other.get("check_rmse_m")),
                        "dense_rmse": q(ours.get("dense_rmse_m"), other.get("dense_rmse_m")),
                        "peak_mb": q(ours.get("peak_rss_mb"), other.get("peak_rss_mb")),
                        "peer_failed": not other["ok"]})
    return out


def print_ratios(rat):
    print(f"\n{'case':<13}{'fotogeo SURF / ':<15}{'time':>7}{'check RMSE':>12}{'dense RMSE':>12}{'peak MB':>9}")
    for r in rat:
        note = "  (peer failed)" if r["peer_failed"] else ""
        print(f"{r['case']:<13}{r['peer']:<15}{fmt(r['time']):>7}{fmt(r['check_rmse']):>12}"
              f"{fmt(r['dense_rmse']):>12}{fmt(r['peak_mb']):>9}{note}")
