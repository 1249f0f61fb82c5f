"""The regular grid of matching windows over the overlap, and its strips.

Window centres lie on integer pixel corners (corner convention), ``spacing`` px apart, inside
the overlap box; the grid is centred in the box. Strips group consecutive grid rows so that
one read of the two images (a strip of rows) serves many windows while memory stays bounded.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class WindowGrid:
    """``xy`` (N, 2) centres (corner convention, integer values), ``index`` (N, 2) their
    ``(row, col)`` in the grid of ``shape``; ``spacing``, ``window`` px."""

    xy: np.ndarray
    index: np.ndarray
    shape: tuple
    spacing: int
    window: int

    def __len__(self) -> int:
        return len(self.xy)

    def strips(self, rows_per_strip: int):
        """``(indices of the windows, row0, row1)`` per group of ``rows_per_strip`` grid rows:
        the pixel rows ``row0 … row1 − 1`` their windows cover."""
        k = max(1, int(rows_per_strip))
        for g0 in range(0, self.shape[0], k):
            sel = np.nonzero((self.index[:, 0] >= g0) & (self.index[:, 0] < g0 + k))[0]
            if len(sel):
                y = self.xy[sel, 1]
                yield sel, int(y.min()) - self.window // 2, int(y.max()) + self.window // 2


def _axis(lo: float, hi: float, spacing: int) -> np.ndarray:
    a, b = int(np.ceil(lo)), int(np.floor(hi))
    if b <= a:
        return np.zeros(0)
    n = (b - a - 1) // spacing + 1
    start = a + (b - a - (n - 1) * spacing) // 2
    return start + spacing * np.arange(n, dtype=np.float64)


def window_grid(box, spacing: int, window: int) -> WindowGrid:
    """The grid of window centres every ``spacing`` px over ``box = (col0, row0, col1, row1)``
    (pixel edges, corner convention), centred in it; windows near the edge reach beyond the
    box (their pixels outside the images are nodata, see ``min_coverage``).

    >>> g = window_grid((0, 0, 300, 200), 100, 64); g.shape, g.xy[:2].tolist()
    ((2, 3), [[50.0, 50.0], [150.0, 50.0]])
    """
    if int(spacing) != spacing or spacing < 1:
        raise InputError(f"grid_spacing must be a whole number of pixels >= 1; got {spacing!r}")
    c0, r0, c1, r1 = box
    xs, ys = _axis(c0, c1, int(spacing)), _axis(r0, r1, int(spacing))
    X, Y = np.meshgrid(xs, ys)
    J, I = np.meshgrid(np.arange(len(xs)), np.arange(len(ys)))
    xy = np.stack([X.ravel(), Y.ravel()], axis=1)
    return WindowGrid(xy, np.stack([I.ravel(), J.ravel()], axis=1), (len(ys), len(xs)), int(spacing), int(window))
