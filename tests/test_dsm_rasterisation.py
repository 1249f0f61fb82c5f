"""The rasterisation of a pair's points (fotogeo.stereo.fusion.PairLayer): a Gaussian splat of one cell's reach
that closes the gaps of the sampling where the grid is as fine as the points, and leaves real holes open."""
import numpy as np

from fotogeo.stereo.fusion import SPLAT_MIN_CELLS, GridSpec, PairLayer, fuse


def _plane_points(grid, spacing, rng, hole=None):
    """Points on the plane z = 100 + 0.3 x − 0.2 y every ``spacing`` map units (jittered), none inside ``hole``
    (xmin, xmax, ymin, ymax)."""
    xs = np.arange(grid.x0 + 0.01, grid.x0 + grid.width * grid.resolution, spacing)
    ys = np.arange(grid.y0 - 0.01, grid.y0 - grid.height * grid.resolution, -spacing)
    X, Y = np.meshgrid(xs, ys)
    X = X + rng.uniform(-0.2, 0.2, X.shape) * spacing
    Y = Y + rng.uniform(-0.2, 0.2, Y.shape) * spacing
    keep = np.ones(X.shape, bool)
    if hole is not None:
        keep = ~((X > hole[0]) & (X < hole[1]) & (Y > hole[2]) & (Y < hole[3]))
    X, Y = X[keep], Y[keep]
    return np.column_stack([X, Y, 100 + 0.3 * X - 0.2 * Y])


def test_points_as_sparse_as_the_cells_leave_no_pinholes_and_keep_the_plane():
    rng = np.random.default_rng(3)
    g = GridSpec(0.0, 60.0, 0.5, 120, 120)
    layer = PairLayer(g)
    layer.add(_plane_points(g, 0.62, rng))  # the points a little sparser than the cells, as a 0.7-m sensor on 0.5 m
    own = (layer.n > 0).mean()
    h = layer.mean()
    X, Y = g.centres()
    truth = 100 + 0.3 * X[None, :] - 0.2 * Y[:, None]
    inner = np.s_[2:-2, 2:-2]
    assert own < 0.8                                  # without the splat a fifth of the cells would be empty
    assert np.isfinite(h[inner]).mean() > 0.98         # measured 0.992 (a few two-cell gaps stay)
    err = (h - truth)[inner]
    reach = 0.36 * 1.5 * g.resolution                 # the plane's slope times the farthest a point can weigh in
    assert np.nanmax(np.abs(err)) < reach             # the weighted mean of points on a plane stays near it
    assert abs(np.nanmean(err)) < 0.01 and np.sqrt(np.nanmean(err ** 2)) < 0.06


def test_a_hole_wider_than_the_reach_stays_open_and_one_point_does_not_spread():
    rng = np.random.default_rng(4)
    g = GridSpec(0.0, 30.0, 0.5, 60, 60)
    layer = PairLayer(g)
    layer.add(_plane_points(g, 0.4, rng, hole=(10.0, 20.0, 10.0, 20.0)))
    layer.add(np.array([[15.1, 14.9, 500.0]]))         # a lone point in the middle of the hole
    h = layer.mean()
    X, Y = g.centres()
    deep = (X[None, :] > 11.0) & (X[None, :] < 19.0) & (Y[:, None] > 11.0) & (Y[:, None] < 19.0)
    lone = (int((30.0 - 14.9) / 0.5), int(15.1 / 0.5))
    deep[lone] = False
    assert np.isnan(h[deep]).all()                    # the hole is not filled beyond one cell from its rim
    assert h[lone] == 500.0                           # the lone point keeps its own cell ...
    ring = h[lone[0] - 1:lone[0] + 2, lone[1] - 1:lone[1] + 2].copy()
    ring[1, 1] = np.nan
    assert np.isnan(ring).all() and SPLAT_MIN_CELLS > 1   # ... and reaches no neighbour


def test_the_fused_spread_is_defined_wherever_a_height_is():
    rng = np.random.default_rng(5)
    g = GridSpec(0.0, 30.0, 0.5, 60, 60)
    layers = []
    for _ in range(2):
        ly = PairLayer(g)
        ly.add(_plane_points(g, 0.6, rng))
        layers.append(ly)
    h, n, s = fuse(layers)
    assert (np.isfinite(h) == np.isfinite(s)).all() and (n[np.isfinite(h)] >= 1).all()
