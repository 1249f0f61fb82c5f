"""Point blocks of the reduced normal equations (fotogeo.orientation.bundle_normals.inverse3)."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.orientation.bundle_normals import inverse3


def test_inverse3_equals_the_inverse_and_survives_a_point_at_infinity():
    rng = np.random.default_rng(0)
    J = rng.normal(size=(50, 4, 3))
    M = J.transpose(0, 2, 1) @ J  # well-conditioned point blocks (4 ray equations each)
    assert np.allclose(inverse3(M), np.linalg.inv(M))
    ray = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    P = np.eye(3) - np.outer(ray, ray)  # two parallel rays: the depth along the ray is not observed
    singular = 1e-15 * (P + 0.5 * P)[None]
    inv = inverse3(np.concatenate([M[:2], singular]))
    assert np.allclose(inv[:2], np.linalg.inv(M[:2]))
    assert np.isfinite(inv[2]).all()
    assert ray @ inv[2] @ ray > 1e8 * np.trace(np.linalg.pinv(singular[0]))  # a huge variance along the ray
    with pytest.raises(np.linalg.LinAlgError):
        inverse3(np.full((1, 3, 3), np.nan))
