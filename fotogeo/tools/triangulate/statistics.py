"""The report's lists beyond the adjustment's own statistics, as the digital aerial triangulation literature lists
them (Yastıklı; Büyüksalih): image residuals sorted by size with the adjusted image coordinates, the mean σ of the
adjusted points per point type, the tie-point matching statistics and the timings of the run's stages.

* **Residuals by size**: every observation still in the block (used or culled), ``|v| = sqrt(vx² + vy²)`` of
  its image residual ``v = projected − measured`` (px), largest first; the adjusted image coordinate is the
  projection of the adjusted point, ``measured + v``. ``report.json`` holds the :data:`LARGEST` largest, the
  ``residuals`` layer of ``block.gpkg`` every one (with ``col_adjusted``, ``row_adjusted``).
* **Mean σ per point type**: for tie, control, check (and rejected control) points the mean of the adjusted
  points' a-posteriori σX, σY, σZ (m; σ₀-scaled covariance of the adjustment), and their RMS.
* **Matching**: pairs tried (footprints overlap) and matched (≥ 1 epipolar inlier), inliers per pair (min,
  median, max, and each pair with its frames), rays per track after matching and after the adjustment (tie
  points with their used observations).
* **Timings**: wall-clock seconds of the stages (inputs, control, matching, adjustment, outputs, mosaic) and of the
  adjustment's own steps.
"""
from __future__ import annotations

import numpy as np

LARGEST = 1000  # residuals listed in report.json (all of them are in block.gpkg)


def residuals_by_size(result, block, limit: int | None = LARGEST) -> list:
    """The image observations still in the block, largest ``|v|`` first (module docstring): dicts of frame,
    point, measured and adjusted pixel, ``vx``, ``vy``, ``v`` (px), status and standardised residual ``w``."""
    live = np.flatnonzero(np.isfinite(result.residuals).all(axis=1))
    v = result.residuals[live]
    size = np.hypot(v[:, 0], v[:, 1])
    order = np.argsort(-size, kind="stable")[:limit]
    frames, ids = np.array(block.frames, dtype=object), np.array(block.point_ids, dtype=object)
    rows = []
    for k in order:
        o = live[k]
        measured = block.obs_pixel[o]
        w = result.w_test[o]
        rows.append({"frame": str(frames[block.obs_frame[o]]), "point": str(ids[block.obs_point[o]]),
                     "col": float(measured[0]), "row": float(measured[1]),
                     "col_adjusted": float(measured[0] + v[k, 0]), "row_adjusted": float(measured[1] + v[k, 1]),
                     "vx_px": float(v[k, 0]), "vy_px": float(v[k, 1]), "v_px": float(size[k]),
                     "status": str(result.status[o]), "w": float(w) if np.isfinite(w) else None})
    return rows


def adjusted_pixels(result, block) -> np.ndarray:
    """``(n, 2)`` adjusted image coordinates ``measured + v`` of every observation (NaN where dropped)."""
    return block.obs_pixel + result.residuals


def point_sigma_by_role(result) -> dict:
    """``{role: {n, sigma_x_m, sigma_y_m, sigma_z_m, rms_m}}``: the mean a-posteriori σ of the adjusted points of
    each type (module docstring); a type without points is left out."""
    out = {}
    sig = np.asarray(result.point_sigma, dtype=np.float64)
    ok = np.isfinite(sig).all(axis=1) & np.isfinite(result.point_xyz).all(axis=1)
    for role in ("tie", "control", "check", "rejected"):
        s = sig[ok & (result.roles == role)]
        if len(s):
            mean = s.mean(axis=0)
            out[role] = {"n": int(len(s)), "sigma_x_m": float(mean[0]), "sigma_y_m": float(mean[1]),
                         "sigma_z_m": float(mean[2]), "rms_m": [float(x) for x in np.sqrt(np.mean(s ** 2, axis=0))]}
    return out


def matching_summary(matching: dict | None, result) -> dict | None:
    """Pairs tried and matched, inliers per pair, rays per track after matching and after the adjustment
    (module docstring); None when the observations were given (nothing was matched)."""
    if not matching:
        return None
    inliers = np.array([p["inliers"] for p in matching.get("pairs", [])], dtype=np.int64)
    tie = (result.roles == "tie") & np.isfinite(result.point_xyz).all(axis=1)
    rays = np.asarray(result.point_rays)[tie].astype(np.int64)
    counts = np.unique(rays, return_counts=True)
    return {"pairs_tried": int(len(inliers)), "pairs_matched": int(np.count_nonzero(inliers)),
            "inliers_per_pair": ({"min": int(inliers.min()), "median": float(np.median(inliers)),
                                  "max": int(inliers.max()), "total": int(inliers.sum())} if len(inliers) else None),
            "rays_per_track_matched": matching.get("rays_per_track"),
            "rays_per_tie_point_adjusted": {str(int(k)): int(c) for k, c in zip(*counts)}}


def stage_timings(stages: dict, adjustment_steps: dict) -> dict:
    """``{stage: s, ..., "total": s, "adjustment_steps": {...}}`` in the order the run went through them."""
    order = ("inputs", "control", "matching", "adjustment", "outputs", "mosaic")
    out = {k: float(stages[k]) for k in order if k in stages}
    out["total"] = float(sum(out.values()))
    out["adjustment_steps"] = {k: float(v) for k, v in adjustment_steps.items()}
    return out
