"""A pair's islands of mismatched heights are removed in its own layer, before the pairs are fused (issue 30:
oblique frame sets of ``tests/dsm_oblique_sets.py``, where two pairs' mismatches at the rim joined into one island
larger than ``SPECKLE_CELLS`` and stayed, 25–42 m below the surface)."""
import numpy as np

from fotogeo.stereo.fusion import GridSpec, remove_speckles
from fotogeo.tools.dsm import matching
from fotogeo.tools.dsm.outputs import SPECKLE_CELLS, SPECKLE_STEP


class _Pair:
    """What ``matching._tile`` reads of a pair: its box, its points, its counters."""

    def __init__(self, points):
        self.P, self.points, self.seconds = points, 0, 0.0

    def box(self, sub):
        return 0, 0, 1, 1

    def dense(self, box, colours=False):
        yield self.P, None


def _cells(c0, c1, r0, r1, z, top=40.0):
    """One point at the centre of each cell of columns ``c0:c1``, rows ``r0:r1`` (1 m cells, top edge ``top``)."""
    c, r = np.meshgrid(np.arange(c0, c1) + 0.5, np.arange(r0, r1) + 0.5)
    return np.column_stack([c.ravel(), top - r.ravel(), np.full(c.size, z)])


def test_a_pairs_island_is_removed_before_it_joins_another_pairs():
    """Pair A: a surface of 800 cells and, apart from it, an island of 40 cells 30 m lower; pair B: an island of
    40 cells 2 m from A's island and touching it. Each island is below ``SPECKLE_CELLS``; fused, they would be one
    island of 80 cells joined by a 2 m step (within ``SPECKLE_STEP`` cells) and stay (before: all 80 kept)."""
    assert 40 < SPECKLE_CELLS < 80
    grid = GridSpec(0.0, 40.0, 1.0, 40, 40)
    a = _Pair(np.vstack([_cells(0, 20, 0, 40, 300.0), _cells(30, 35, 0, 8, 270.0)]))
    b = _Pair(_cells(35, 40, 0, 8, 272.0))
    height, count, _ = matching._tile([a, b], grid, grid, None).result()
    height, _ = remove_speckles(height, SPECKLE_CELLS, SPECKLE_STEP * grid.resolution)
    assert np.isfinite(height[:, :20]).all() and np.allclose(height[:, :20], 300.0)
    assert np.isnan(height[:, 21:]).all()


def test_a_flat_surface_is_not_a_speckle():
    """A surface whose heights span less than about twice the step limit (a flat field, a tile of it) stays:
    before, the step limit in quantised heights overflowed OpenCV's 16 bits and every cell was its own island
    (all 800 removed)."""
    for span in (0.0, 0.5, 6.0, 10.0):
        h = np.full((40, 40), np.nan, np.float32)
        h[:, :20] = 300.0 + np.linspace(0.0, span, 40)[:, None]
        assert remove_speckles(h, SPECKLE_CELLS, 4.0)[1] == 0, span
