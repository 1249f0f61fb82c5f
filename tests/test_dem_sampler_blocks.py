"""A DEM in another CRS is sampled a block of rows at a time (:meth:`fotogeo.geometry.dem.DemSampler.heights_grid`
interpolates the lattice's DEM positions along the rows per block, :func:`fotogeo.geometry.lattice.along` on a
subset of the indices) and points strictly inside the DEM skip the clipping (:meth:`fotogeo.geometry.dem.Dem.
_index_pixels`): the same values, bit for bit, as the full-size planes of positions and the clipped path (NGI 5 m
over its DEM in UTM 35S: a 512² window's heights ~7.3 -> ~5.7 ms; docs/benchmarks/products.md)."""
from __future__ import annotations

import numpy as np

from fotogeo.geometry import dem as dem_module
from fotogeo.geometry.dem import DemSampler, _with_middles
from fotogeo.geometry.lattice import along, bilinear, lattice
from test_dem_sampler_grid import LO25, _utm_dem, _window


def test_along_a_subset_of_the_indices_is_the_whole_ranges_values():
    rng = np.random.default_rng(5)
    v = rng.normal(0, 100, (2, 9, 7))
    rows, cols = np.array([0, 5, 11, 17, 30, 40, 41, 60, 70]), np.array([0, 3, 9, 10, 20, 33, 34])
    full = bilinear(v, rows, cols, 71, 35)
    top = along(v, cols, np.arange(35), 2)
    for at in (np.arange(71), np.arange(13, 40), np.array([0, 70, 41, 5, 6])):
        assert np.array_equal(along(top, rows, at, 1), full[:, at])
    assert np.array_equal(along(v[:, :1], rows[:1], np.arange(4), 1), np.repeat(v[:, :1], 4, axis=1))  # one node


def _heights_of_full_planes(s, X, Y):
    """The heights from full-size planes of the lattice's bilinear DEM positions (the code before)."""
    rows, cols = lattice(len(Y), dem_module.GRID_STEP), lattice(len(X), dem_module.GRID_STEP)
    exact = s._dem_pixels(X[_with_middles(cols)], Y[_with_middles(rows)])
    full = bilinear(exact[:, ::2, ::2], rows, cols, len(Y), len(X))
    return s.dem.heights_at_pixels(full[0].ravel(), full[1].ravel()).reshape(len(Y), len(X))


def test_heights_grid_by_blocks_of_rows_is_the_full_planes_heights():
    s = DemSampler(_utm_dem(), LO25)
    for size in ((700, 530), (45, 333), (1, 70)):  # past the DEM's edge and hole; rows not a multiple of a block
        X, Y = _window(s, size=size)
        grid = s.heights_grid(X, Y)
        assert grid is not None and np.isfinite(grid).any()
        assert np.array_equal(grid, _heights_of_full_planes(s, X, Y), equal_nan=True)


def test_points_inside_the_dem_skip_the_clipping_with_the_same_values():
    d = _utm_dem()
    rng = np.random.default_rng(6)
    rows, cols = d.data.shape
    col, row = rng.uniform(0.5, cols - 0.5, 50000), rng.uniform(0.5, rows - 0.5, 50000)  # corner convention
    inside = d._index_pixels(col.copy(), row.copy())
    # a point in the DEM's outer half-cell (clipped onto the edge) and one outside send every point through the
    # clipped path
    edge = d._index_pixels(np.r_[col, 0.1, -1.0], np.r_[row, 0.1, 5.0])
    for a, b in zip(inside, edge):
        assert np.array_equal(a, b[:-2])
    assert inside[4].all() and edge[4][-2] and not edge[4][-1]
    heights = d.heights_at_pixels(np.r_[col, 0.1, -1.0], np.r_[row, 0.1, 5.0])
    assert np.array_equal(d.heights_at_pixels(col, row), heights[:-2], equal_nan=True)  # the hole: NaN in both
    assert heights[-2] == d.data[0, 0] and np.isnan(heights[-1])
