"""Orthophotos on the seam grid, each kept over its own footprint only (arrays in, arrays out).

A mosaic of ``n`` orthophotos on a seam grid of ``R x C`` cells would need ``n·R·C`` cells per quantity if every
orthophoto were held on the whole grid; a :class:`Patch` holds one orthophoto's band values only inside the
window of the seam grid its bounds cover, so the seam grid's memory is ``k·R·C`` cells with ``k`` the mean number
of orthophotos covering a cell (about 1–4 for a block), whatever ``n``. Pairs of orthophotos are compared only
where their windows intersect (:func:`overlapping_pairs`, :func:`pair_window`).

Windows are ``(r0, r1, c0, c1)`` half-open row and column ranges of the seam grid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Patch:
    """One orthophoto on the seam grid: ``values`` ``(bands, h, w)`` (NaN where it has no data) at ``(r0, c0)``."""
    r0: int
    c0: int
    values: np.ndarray

    @property
    def window(self) -> tuple[int, int, int, int]:
        h, w = self.values.shape[1:]
        return self.r0, self.r0 + h, self.c0, self.c0 + w

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.values).all(axis=0)

    def crop(self, window, grey: bool = False) -> np.ndarray:
        """Band values ``(bands, h, w)`` (or with ``grey`` the grey level ``(h, w)``, their mean) over ``window``
        of the seam grid, NaN outside the patch."""
        r0, r1, c0, c1 = window
        out = np.full((self.values.shape[0], r1 - r0, c1 - c0), np.nan, np.float32)
        pr0, pr1, pc0, pc1 = self.window
        a0, a1, b0, b1 = max(r0, pr0), min(r1, pr1), max(c0, pc0), min(c1, pc1)
        if a0 < a1 and b0 < b1:
            out[:, a0 - r0:a1 - r0, b0 - c0:b1 - c0] = self.values[:, a0 - pr0:a1 - pr0, b0 - pc0:b1 - pc0]
        return out.mean(axis=0) if grey else out


def intersection(a, b, pad: int = 0, shape=None):
    """The intersection of windows ``a`` and ``b`` grown by ``pad`` cells (clipped to the grid ``shape``), or
    None when they do not intersect."""
    r0, r1, c0, c1 = max(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), min(a[3], b[3])
    if r0 >= r1 or c0 >= c1:
        return None
    r0, r1, c0, c1 = r0 - pad, r1 + pad, c0 - pad, c1 + pad
    if shape is not None:
        r0, c0, r1, c1 = max(r0, 0), max(c0, 0), min(r1, shape[0]), min(c1, shape[1])
    return r0, r1, c0, c1


def overlapping_pairs(patches) -> list[tuple[int, int]]:
    """``(i, j)``, ``i < j``, of the patches whose windows intersect (sorted sweep along the columns: the work
    grows with the pairs, not with ``n²``)."""
    order = sorted(range(len(patches)), key=lambda k: patches[k].window[2])
    out, active = [], []
    for k in order:
        w = patches[k].window
        active = [a for a in active if patches[a].window[3] > w[2]]
        out += [(min(a, k), max(a, k)) for a in active if intersection(patches[a].window, w) is not None]
        active.append(k)
    return sorted(out)


def pair_window(patches, i: int, j: int, pad: int, shape):
    """The window where orthophotos ``i`` and ``j`` both have data, grown by ``pad`` (None when they share no
    valid cell)."""
    win = intersection(patches[i].window, patches[j].window)
    if win is None:
        return None
    both = np.isfinite(patches[i].crop(win, grey=True)) & np.isfinite(patches[j].crop(win, grey=True))
    if not both.any():
        return None
    return intersection(patches[i].window, patches[j].window, pad, shape)
