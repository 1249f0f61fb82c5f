"""Model comparison over control-point counts and spreads (Öztürk, Karşlı & Dihkan, Table 1 style).

Each model x control-point count x spread is fitted over seeded trials; all points not chosen
as control points are check points; the table holds the median RMS x / y / xy per role.
"""
from __future__ import annotations

import numpy as np

from .adjustment import fit_orientation
from ..errors import FotogeoError, ModelError
from ..models import get_model
from ..models.robust import spread_split


def select_controls(pixel, n_control: int, spread: str, rng) -> np.ndarray:
    """Mask of ``n_control`` control points: ``homogeneous`` (stratified over the image area) or
    ``heterogeneous`` (clustered: the points nearest to two random centres)."""
    n = len(pixel)
    rng = np.random.default_rng(rng)
    if spread == "homogeneous":
        return spread_split(pixel, n_control / n, rng, cells=max(2, int(np.sqrt(n_control))))
    if spread in ("heterogeneous", "clustered"):
        mask = np.zeros(n, bool)
        centres = pixel[rng.choice(n, 2, replace=False)]
        for k, c in enumerate(centres):
            want = n_control // 2 + (k == 0) * (n_control % 2)
            order = np.argsort(np.hypot(*(pixel - c).T))
            mask[[i for i in order if not mask[i]][:want]] = True
        return mask
    raise ModelError(f"spread {spread!r} unknown; use 'homogeneous' or 'heterogeneous'")


def compare(models, ground, pixel, *, counts=(40, 20, 15, 10, 6), spreads=("homogeneous", "heterogeneous"),
            trials: int = 5, seed: int = 0, camera=None, progress=None) -> list[dict]:
    """Table-1-style comparison: each model x control-point count x spread, over seeded trials.

    All points not chosen as control points are check points. Returns one row per
    (model, spread, count) with median RMS x / y / xy at control and check points over the
    trials (or the reason the model could not be fitted).
    """
    from ..progress import as_progress
    prog = as_progress(progress)
    ground, pixel = np.asarray(ground, float), np.asarray(pixel, float)
    n = len(pixel)
    rows, jobs = [], [(m, s, c) for m in models for s in spreads for c in counts if c < n]
    for j, (name, spread, count) in enumerate(jobs):
        cls = get_model(name)
        if name == "collinearity" and camera is None:
            rows.append({"model": name, "spread": spread, "n_control": count, "n_check": n - count,
                         "note": "needs the camera's interior orientation"})
            continue
        row = {"model": name, "spread": spread, "n_control": count, "n_check": n - count}
        if count < cls.min_points:
            row["note"] = f"needs at least {cls.min_points} control points"
            rows.append(row)
            continue
        acc = {k: [] for k in ("control_rms_x_px", "control_rms_y_px", "check_rms_x_px", "check_rms_y_px",
                               "check_rms_xy_px", "check_max_px")}
        notes = set()
        for t in range(trials):
            mask = select_controls(pixel, count, spread, seed * 1000 + t)
            role = np.where(mask, "control", "check")
            try:
                f = fit_orientation(name, ground, pixel, role, np.arange(n).astype(str), snooping=False,
                                    camera=camera)
            except FotogeoError as e:
                notes.add(str(e))
                continue
            for r in ("control", "check"):
                acc[f"{r}_rms_x_px"].append(f.stats[r].get("rms_x_px", np.nan))
                acc[f"{r}_rms_y_px"].append(f.stats[r].get("rms_y_px", np.nan))
            acc["check_rms_xy_px"].append(f.stats["check"].get("rms_xy_px", np.nan))
            acc["check_max_px"].append(f.stats["check"].get("max_px", np.nan))
            notes.update(w.split(":")[0] for w in f.warnings)
        row.update({k: float(np.median(v)) if v else None for k, v in acc.items()})
        row["trials"] = len(acc["check_rms_x_px"])
        if notes:
            row["note"] = "; ".join(sorted(notes))[:200]
        rows.append(row)
        prog((j + 1) / len(jobs), f"{name} {spread} {count}")
    return rows
