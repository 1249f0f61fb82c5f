"""The design matrix of a fitted model along its free parameters: what the GCP adjustment's redundancy numbers
(:mod:`fotogeo.orientation.adjustment`) and the blunder test (:mod:`fotogeo.orientation.blunders`) are built on."""
from __future__ import annotations

import numpy as np


def free_directions(model):
    """``(len(params), u)`` basis of the model's free parameters in its stored ``params``, or
    None when the closed form does not apply (a regularised fit: the RFMs).

    A model may say it with ``param_directions()`` (the similarity: 4 free directions in its
    3x3 matrix); otherwise the first ``n_params`` stored parameters are the free ones and the
    rest are fixed (the matrix models' ``h33 = 1``, the DLT's ``L12 = 1``, the camera of the
    collinearity model).
    """
    if hasattr(model, "param_directions"):
        return model.param_directions()
    if model.name.startswith("rfm"):
        return None
    return np.eye(len(model.params))[:, :model.n_params]


def jacobian(model, src: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """``(2n, u)`` derivative of ``forward(src)`` (x, y interleaved) along ``directions``, by central differences."""
    from dataclasses import replace
    p0 = model.params
    cols = []
    for d in directions.T:
        h = 1e-6 * max(1.0, float(np.abs(p0 @ d)) if np.any(d) else 1.0)
        fp = replace(model, params=p0 + h * d).forward(src)
        fm = replace(model, params=p0 - h * d).forward(src)
        cols.append(((fp - fm) / (2 * h)).reshape(-1))
    return np.column_stack(cols)
