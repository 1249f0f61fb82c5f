"""Heights from rays meeting under a small angle (fotogeo.stereo.rays.intersection_angles) are set aside in the
fusion where a pair of wider rays gives one (fotogeo.stereo.fusion.Fusion ``min_angle``, dsm --min-ray-angle), and
still give the height where no pair does."""
import numpy as np
import pytest

from fotogeo.stereo.fusion import Fusion, GridSpec, PairLayer, fuse
from fotogeo.stereo.rays import closest_points, intersection_angles
from fotogeo.tools.dsm import matching


def test_the_angle_of_two_rays_at_their_point():
    c1, c2 = np.array([-10.0, 0.0, 100.0]), np.array([10.0, 0.0, 100.0])
    P = np.array([[0.0, 0.0, 0.0], [0.0, 50.0, 0.0], [10.0, 0.0, 0.0]])
    g = intersection_angles(P, c1, c2)
    assert g[0] == pytest.approx(2 * np.degrees(np.arctan(10 / 100)))
    r = np.hypot(50.0, 100.0)                          # farther off the base: a narrower angle
    assert g[1] == pytest.approx(2 * np.degrees(np.arctan(10 / r)))
    c_a, c_b = c1 - P[2], c2 - P[2]
    assert g[2] == pytest.approx(np.degrees(np.arccos(c_a @ c_b / np.linalg.norm(c_a) / np.linalg.norm(c_b))))
    X, _ = closest_points(c1, P[:1] - c1, c2, P[:1] - c2)     # the rays of the triangulation meet at the point
    assert np.allclose(X, P[:1])


def _points(grid, cols, z, rng, sigma):
    """One point per cell of columns ``cols`` (all rows) at height ``z`` + N(0, ``sigma``)."""
    c, r = np.meshgrid(np.arange(*cols) + 0.5, np.arange(grid.height) + 0.5)
    c, r = c.ravel() * grid.resolution + grid.x0, grid.y0 - r.ravel() * grid.resolution
    return np.column_stack([c, r, z + rng.normal(0.0, sigma, c.size)])


def _layers(grid, rng):
    """A narrow pair (2°, σ 0.6 m) over the whole grid and a wide one (12°, σ 0.1 m) over its left half."""
    narrow, wide = PairLayer(grid), PairLayer(grid)
    P = _points(grid, (0, grid.width), 50.0, rng, 0.6)
    narrow.add(P, np.full(len(P), 2.0))
    P = _points(grid, (0, grid.width // 2), 50.0, rng, 0.1)
    wide.add(P, np.full(len(P), 12.0))
    return narrow, wide


def test_narrow_rays_are_set_aside_where_wide_ones_measure_and_kept_where_none_do():
    rng = np.random.default_rng(7)
    grid = GridSpec(0.0, 40.0, 1.0, 40, 40)
    narrow, wide = _layers(grid, rng)
    before, n0, _ = fuse([narrow, wide])              # every pair's height alike: the two heights' mean
    f = Fusion(grid, min_angle=5.0)
    f.add(narrow)
    f.add(wide)
    after, n1, _ = f.result()
    left, right = np.s_[:, 2:18], np.s_[:, 22:38]
    assert np.isfinite(after).all() and np.isfinite(before).all()      # no hole where only narrow rays reach
    err0, err1 = np.std(before[left] - 50.0), np.std(after[left] - 50.0)
    assert err1 < 0.6 * err0                          # the wide pair's heights alone where it measures
    assert np.allclose(after[right], before[right])   # the narrow pair's where it is alone
    assert (n0[left] == 2).all() and (n1[left] == 1).all() and (n1[right] == 1).all()
    assert f.set_aside[0] >= 19 * 40 and f.set_aside[1] == 0   # the left half (its edge column splat-reached)


class _Pair:
    """A pair as :func:`fotogeo.tools.dsm.matching._tile` takes it: fixed points, their angles when ``angle``."""

    def __init__(self, P, angle=None):
        self.P, self.angle, self.stats, self.points, self.seconds = P, angle, {}, 0, 0.0
        if angle is not None:
            self.angles = lambda P: np.full(len(P), angle)

    def box(self, sub):
        return 0, 0, 1, 1

    def dense(self, box, colours=False):
        yield self.P, None


def test_tiles_set_narrow_pairs_aside_and_count_their_cells_and_pairs_without_angles_are_never_set_aside():
    rng = np.random.default_rng(8)
    grid = GridSpec(0.0, 40.0, 1.0, 40, 40)
    narrow = _points(grid, (0, 40), 50.0, rng, 0.6)
    wide = _points(grid, (0, 20), 50.0, rng, 0.1)
    whole = (0, 0, grid.height, grid.width)
    a, b = _Pair(narrow, 2.0), _Pair(wide, 12.0)
    height, count, _ = matching._tile([a, b], grid, whole, None, min_angle=5.0)
    assert a.stats["set_aside_cells"] >= 19 * 40 and "set_aside_cells" not in b.stats
    assert (count[:, :19] == 1).all() and np.isfinite(height).all()
    core = (0, 0, 40, 10)                             # counted within the tile's core only
    c = _Pair(narrow, 2.0)
    matching._tile([c, _Pair(wide, 12.0)], grid, core, None, min_angle=5.0)
    assert c.stats["set_aside_cells"] == 10 * 40
    d, e = _Pair(narrow), _Pair(wide)                 # RPC pairs: no angles, every height counts
    height2, count2, _ = matching._tile([d, e], grid, whole, None, min_angle=5.0)
    assert (count2[:, :19] == 2).all() and not d.stats
