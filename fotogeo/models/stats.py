"""Residual statistics: the one place they are computed (array layer).

For residual vectors ``v = (dx, dy)`` (model minus measurement, in whatever unit they come)::

    RMS_x = sqrt(mean dx²),  RMS_y = sqrt(mean dy²),  RMS_xy = sqrt(mean (dx² + dy²))

and the minimum, maximum and median of the lengths ``|v|``. The RMS_xy is the RMSE of the
source paper (Dihkan 2019): ``sqrt(1/n Σ((x − x')² + (y − y')²))``.

>>> s = residual_stats([[3.0, 4.0], [0.0, 0.0]])
>>> s["n"], round(s["rms_xy"], 4), s["max"], s["median"]
(2, 3.5355, 5.0, 2.5)
>>> residual_stats(np.zeros((0, 2)))
{'n': 0}
"""
from __future__ import annotations

import numpy as np


def residual_stats(residuals) -> dict:
    """``n``, ``rms_x``, ``rms_y``, ``rms_xy``, ``min``, ``max``, ``median`` of residual vectors ``(N, 2)``.

    With no residuals only ``{"n": 0}``.
    """
    r = np.asarray(residuals, dtype=np.float64).reshape(-1, 2)
    if len(r) == 0:
        return {"n": 0}
    d = np.hypot(r[:, 0], r[:, 1])
    return {"n": int(len(r)), "rms_x": float(np.sqrt(np.mean(r[:, 0] ** 2))),
            "rms_y": float(np.sqrt(np.mean(r[:, 1] ** 2))), "rms_xy": float(np.sqrt(np.mean(d ** 2))),
            "min": float(d.min()), "max": float(d.max()), "median": float(np.median(d))}


def rmse(residuals, empty=float("nan")):
    """``RMS_xy`` of residual vectors ``(N, 2)``; ``empty`` when there are none.

    >>> rmse([[3.0, 4.0]]), rmse(np.zeros((0, 2)), None)
    (5.0, None)
    """
    return residual_stats(residuals).get("rms_xy", empty)
