"""RPC pairs (``fotogeo dsm --rpc``): the triangulated point lies halfway between the two images' geolocations
(the relative pointing correction split between them) at the height the images measure; ``--refine`` runs on
RPC pairs."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.tools.dsm.rpc_pairs import triangulate


class _Affine:
    """An affine camera ``px = M·(X, Y, Z) + c`` with the model protocol's ``forward`` and ``inverse``."""

    def __init__(self, M, c):
        self.M, self.c = np.asarray(M, float), np.asarray(c, float)

    def forward(self, P):
        return np.asarray(P, float)[:, :3] @ self.M.T + self.c

    def inverse(self, px, z):
        z = np.broadcast_to(np.asarray(z, float), (len(px),))
        rhs = np.asarray(px, float) - self.c - np.outer(z, self.M[:, 2])
        xy = np.linalg.solve(self.M[:, :2], rhs.T).T
        return np.column_stack([xy, z])


def _pair():
    left = _Affine([[2.0, 0.1, 0.30], [-0.1, 2.0, 0.02]], [100.0, 80.0])   # 0.5 m pixels, looking forward
    right = _Affine([[2.0, 0.05, -0.35], [-0.05, 2.0, 0.03]], [90.0, 85.0])  # and backward
    rng = np.random.default_rng(5)
    X = np.column_stack([rng.uniform(-50, 50, 40), rng.uniform(-50, 50, 40), rng.uniform(400, 700, 40)])
    return left, right, X


@pytest.mark.parametrize("tau", [(0.0, 0.0), (0.0, -3.0), (1.0, -20.0)])
def test_height_kept_and_planimetry_halfway(tau):
    """The right RPC misplaced by ``-tau`` (so that its corrected projection ``forward + tau`` is right): the
    height is the true one whatever ``tau``; the planimetry moves from the truth (the left image's) by half the
    ground offset of the right pixel's uncorrected line of sight."""
    left, right, X = _pair()
    tau = np.array(tau)
    p1, p2 = left.forward(X), right.forward(X) + tau
    P, miss = triangulate(left, right, tau, p1, p2, 300.0, 800.0)
    assert np.allclose(P[:, 2], X[:, 2], atol=1e-6) and np.allclose(miss, 0.0, atol=1e-6)
    uncorrected = right.inverse(p2, X[:, 2])[:, :2]
    assert np.allclose(P[:, :2], 0.5 * (X[:, :2] + uncorrected), atol=1e-6)
    if np.any(tau):
        assert np.all(np.linalg.norm(P[:, :2] - X[:, :2], axis=1) > 0.1)  # the split is not a no-op


@pytest.mark.data
def test_refine_runs_on_the_ventoux_pair(data_dir, tmp_path):
    """``--refine`` on the Pleiades pair: the same coverage, heights moved by sub-pixel amounts only."""
    import rasterio

    from fotogeo.tools.dsm import dsm
    from test_dsm import _ventoux
    images = _ventoux(data_dir, tmp_path / "a", "right_image.geom")
    a = dsm(images, tmp_path / "a.tif", rpc=True, resolution=0.5)
    b = dsm(images, tmp_path / "b.tif", rpc=True, resolution=0.5, refine=True)
    assert abs(a["completeness"] - b["completeness"]) < 0.02
    with rasterio.open(tmp_path / "a.tif") as da, rasterio.open(tmp_path / "b.tif") as db:
        ha, hb = da.read(1), db.read(1)
        both = (ha != da.nodata) & (hb != db.nodata)
    dz = hb[both] - ha[both]
    assert abs(np.median(dz)) < 0.2 and 0.0 < np.median(np.abs(dz)) < 1.0
