"""The checked lattice of ground → image positions (fotogeo/geometry/lattice.py): interpolated where the model is
smooth, within its bound of the exact model at every cell; exact where the lattice cannot meet the bound."""
import numpy as np

from fotogeo.geometry.lattice import MODEL_TOL_PX, bilinear, ground_to_image_on_lattice, lattice


def _window(h=200, w=300, seed=0):
    """Cell centres of a 2-m grid and a rough terrain on them (a DEM's kinks at every cell, NaN in one corner)."""
    rng = np.random.default_rng(seed)
    X, Y = 500_000 + 2.0 * np.arange(w), 7_000_000 - 2.0 * np.arange(h)
    Z = 300 + 40 * np.sin(np.arange(w) / 37.0)[None, :] + rng.normal(0, 3, (h, w))
    Z[:20, :30] = np.nan
    return X, Y, Z


def _frame(XYZ):
    """A tilted pinhole camera 20 km above the terrain, about 2 m per pixel (projective in X, Y and Z)."""
    d = np.asarray(XYZ, float) - [500_300, 6_999_800, 20_000]
    z = -d[:, 2] + 0.05 * d[:, 0] + 0.03 * d[:, 1]
    return np.column_stack([5000 + 10_000 * (d[:, 0] + 0.02 * d[:, 2]) / z, 4000 - 10_000 * d[:, 1] / z])


def _exact(forward, X, Y, Z):
    XX, YY = np.meshgrid(X, Y)
    return forward(np.column_stack([XX.ravel(), YY.ravel(), Z.ravel()]))


def test_smooth_model_on_rough_terrain_is_within_the_bound_everywhere():
    X, Y, Z = _window()
    calls = []

    def forward(XYZ):
        calls.append(len(XYZ))
        return _frame(XYZ)
    got = ground_to_image_on_lattice(forward, X, Y, Z)
    want = _exact(_frame, X, Y, Z)
    assert np.array_equal(np.isnan(got), np.isnan(want)) and np.isnan(got[0]).all()
    assert np.nanmax(np.abs(got - want)) <= MODEL_TOL_PX
    assert sum(calls) < 0.1 * Z.size  # the model was evaluated on the lattice, not at every cell


def test_a_model_the_lattice_cannot_follow_gives_the_exact_positions():
    X, Y, Z = _window(seed=1)

    def folded(XYZ):  # a kink every 7 m: no lattice of 4 or 16 cells follows it
        px = _frame(XYZ)
        return px + np.abs(np.sin(XYZ[:, :1] / 7.0))
    got = ground_to_image_on_lattice(folded, X, Y, Z)
    np.testing.assert_array_equal(got, _exact(folded, X, Y, Z))


def test_bilinear_reproduces_a_bilinear_function_at_every_cell():
    h, w = 37, 50
    rows, cols = lattice(h, 8), lattice(w, 8)
    f = lambda r, c: 3.0 + 0.5 * r - 0.25 * c + 0.01 * r * c  # noqa: E731
    values = np.stack([f(*np.meshgrid(rows, cols, indexing="ij")), -f(*np.meshgrid(rows, cols, indexing="ij"))])
    got = bilinear(values, rows, cols, h, w)
    R, C = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    np.testing.assert_allclose(got, np.stack([f(R, C), -f(R, C)]), atol=1e-12)
