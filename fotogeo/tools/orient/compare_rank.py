"""Which row of a model comparison ranks first (standard library only: the QGIS provider imports it).

A check RMS from one or two check points says little about a model's accuracy, so only rows with at least
:data:`MIN_CHECK_POINTS` check points are ranked, and the sentence says so.
"""
from __future__ import annotations


#: check points a row needs before its check RMS ranks it (fewer say little about a model's accuracy)
MIN_CHECK_POINTS = 5


def ranking(rows, min_check: int = MIN_CHECK_POINTS):
    """``(best row, sentence)``: the row of lowest check RMS xy among those with at least ``min_check`` check
    points, and a sentence that says so — or None and why no row ranks.

    >>> rows = [{"model": "dlt", "spread": "homogeneous", "n_control": 39, "n_check": 1, "check_rms_xy_px": 0.1},
    ...         {"model": "affine", "spread": "homogeneous", "n_control": 20, "n_check": 20, "check_rms_xy_px": 4.2}]
    >>> ranking(rows)[1]
    'lowest check RMS xy among the 1 rows with >= 5 check points: affine (homogeneous, 20 control, 20 check) 4.200 px'
    >>> ranking(rows[:1])[1]
    'no ranking: no row has 5 check points (a check RMS of fewer says little); hold more points out as check points'
    >>> ranking([{"model": "collinearity", "spread": "homogeneous", "n_control": 20, "n_check": 40,
    ...           "note": "model 'collinearity' needs the interior orientation"}])[1]
    'no ranking: collinearity fitted no set; the notes in the table say why'
    """
    fitted = [r for r in rows if r.get("check_rms_xy_px") is not None]
    ranked = [r for r in fitted if (r.get("n_check") or 0) >= min_check]
    waiting = [r for r in rows if (r.get("n_check") or 0) >= min_check and r not in fitted]
    if not ranked and waiting:  # check points enough, no check RMS: the models did not fit (their notes say why)
        models = ", ".join(dict.fromkeys(r["model"] for r in waiting))
        return None, f"no ranking: {models} fitted no set; the notes in the table say why"
    if not ranked:
        return None, (f"no ranking: no row has {min_check} check points (a check RMS of fewer says little); hold more "
                      f"points out as check points")
    best = min(ranked, key=lambda r: r["check_rms_xy_px"])
    return best, (f"lowest check RMS xy among the {len(ranked)} rows with >= {min_check} check points: {best['model']} "
                  f"({best['spread']}, {best['n_control']} control, {best['n_check']} check) "
                  f"{best['check_rms_xy_px']:.3f} px")
