"""The documented rule of ``model="auto"`` for terrain-aware registration, checked on a report.

DESIGN and :mod:`fotogeo.orientation.terrain`: every candidate is fitted on the control
points; among the fits without ill-posedness warnings (all fits if every one has a warning)
the chosen model is the *simplest* — in the order collinearity, DLT, RFM-poly, RFM-common,
RFM — whose compared RMSE (the report's ``compared``: the blocked cross-validation RMSE, or the
check RMSE with too few control points, or the control RMSE without check points) is within 5 %
of the best. The report lists the candidates in that order.
"""
from __future__ import annotations

import pytest

#: the candidates of ``auto``, simplest first (the documented parsimony order)
SIMPLEST_FIRST = ("collinearity", "dlt", "rfm-poly", "rfm-common", "rfm")


def assert_auto_choice(terrain: dict, check_n: int):
    """``terrain`` is the report's ``terrain`` entry; ``check_n`` the report's number of check points."""
    cands = terrain["candidates"]
    names = [c["model"] for c in cands]
    assert names == [m for m in SIMPLEST_FIRST if m in names], names  # listed simplest first
    key = terrain["compared"]
    assert key in ("blocked_cv_rmse_px", "check_rmse_px" if check_n else "control_rmse_px"), key
    fitted = [c for c in cands if c.get(key) is not None and c[key] < float("inf")]
    eligible = [c for c in fitted if not c["ill_posed"]] or fitted
    best = min(c[key] for c in eligible)
    chosen = next(c for c in cands if c["model"] == terrain["chosen"])
    assert chosen in eligible, (chosen, eligible)
    assert chosen[key] <= 1.05 * best, (chosen, best)  # within 5 % of the best
    simpler = eligible[:eligible.index(chosen)]
    assert all(c[key] > 1.05 * best for c in simpler), (simpler, best)  # no simpler one qualifies
    if check_n:  # the report's check RMSE is the chosen candidate's
        assert terrain["check_rmse_target_px"] == pytest.approx(chosen["check_rmse_px"], rel=1e-9)
