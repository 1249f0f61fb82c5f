"""``newton_2d`` evaluates a point and its four Jacobian neighbours in one call of the model up to
``NEWTON_BATCH_POINTS`` points, in five calls beyond: both give the same solution to the last bit, with and without
per-point extra columns (a 3-D model's fixed height), and the solution solves the system."""
from __future__ import annotations

import numpy as np

from fotogeo.models import base


def _apply(s):
    """A smooth nonlinear map of ``(M, 2)`` or ``(M, 3)`` (the third column a height)."""
    z = s[:, 2] if s.shape[1] > 2 else 0.0
    return np.column_stack([s[:, 0] + 0.1 * s[:, 1] ** 2 + 0.05 * z, s[:, 1] + 0.1 * np.sin(s[:, 0]) - 0.02 * z])


def test_batched_and_five_calls_agree(monkeypatch):
    rng = np.random.default_rng(3)
    d = rng.uniform(-1, 1, (500, 2))
    z = rng.uniform(-1, 1, (500, 1))
    calls = []

    def counted(s):
        calls.append(len(s))
        return _apply(s)

    batched = base.newton_2d(counted, d, np.zeros_like(d), 30, 1e-12, extra=z)
    assert calls and set(calls) == {5 * len(d)}
    assert np.abs(_apply(np.column_stack([batched, z])) - d).max() < 1e-10
    monkeypatch.setattr(base, "NEWTON_BATCH_POINTS", 10)
    calls.clear()
    separate = base.newton_2d(counted, d, np.zeros_like(d), 30, 1e-12, extra=z)
    assert set(calls) == {len(d)}
    assert np.array_equal(batched, separate)
    plain = base.newton_2d(_apply, d, np.zeros_like(d), 30, 1e-12)
    monkeypatch.setattr(base, "NEWTON_BATCH_POINTS", 2 ** 16)
    assert np.array_equal(plain, base.newton_2d(_apply, d, np.zeros_like(d), 30, 1e-12))
