"""Seamlines of a mosaic: which orthophoto each cell comes from (arrays in, a label image out).

On a (coarse) grid covering the mosaic, with ``valid[i]`` the cells orthophoto ``i`` covers:

1. **Voronoi cells of nadir distance** (:func:`voronoi_labels`): every cell takes the orthophoto whose nadir
   point (the ground point under its projection centre, where relief displacement vanishes) is nearest among
   those that cover it — each cell is seen as vertically as the block allows.
2. **Least-cost refinement** (:func:`refine_pair`): between two orthophotos ``i`` and ``j`` the Voronoi boundary
   is replaced by the cheapest 8-connected path through their overlap, inside a band of ``band`` cells around the
   boundary, from one end of the boundary to the other. The cost of a cell is ``ε + |A_i − A_j|`` (the grey
   difference of the two orthophotos, large on anything that leans differently in the two images — buildings,
   trees, bridges — and on moving objects) plus ``penalty`` on cells a DSM marks as above ground; the path is
   Dijkstra's shortest path on the band's grid graph (``scipy.sparse.csgraph``), as in the seamline methods of
   Kerschner (2001) and Pan et al. (2009). The band minus the path falls into pieces (4-connected); each piece
   goes to the orthophoto whose Voronoi side it touches.

Labels are ``-1`` where no orthophoto covers a cell.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from .patches import overlapping_pairs, pair_window

#: cost of a cell besides the grey difference (keeps paths short where the images agree)
EPSILON = 1.0


def voronoi_labels(patches, nadirs, transform, shape) -> np.ndarray:
    """``shape`` labels of the covering orthophoto with the nearest nadir point (module docstring, 1).

    ``patches``: the orthophotos on the seam grid (:class:`~fotogeo.mosaic.patches.Patch`, each visited over its
    own window only); ``nadirs``: ``(n, 2)`` map points; ``transform``: the grid's affine."""
    best = np.full(shape, np.inf)
    labels = np.full(shape, -1, np.int32)
    for i, (p, (nx, ny)) in enumerate(zip(patches, np.asarray(nadirs, float))):
        r0, r1, c0, c1 = p.window
        c, r = np.meshgrid(np.arange(c0, c1) + 0.5, np.arange(r0, r1) + 0.5)
        X, Y = transform * (c, r)
        d = np.hypot(X - nx, Y - ny)
        near, lab = best[r0:r1, c0:c1], labels[r0:r1, c0:c1]  # views: written in place
        take = p.valid & (d < near)
        near[take], lab[take] = d[take], i
    return labels


def _boundary_ends(labels, i, j, overlap):
    """The cells of the ``i``/``j`` Voronoi boundary inside ``overlap``, and its two ends (farthest apart)."""
    a, b = labels == i, labels == j
    edge = (a & ndimage.binary_dilation(b)) | (b & ndimage.binary_dilation(a))
    edge &= overlap
    pts = np.argwhere(edge)
    if len(pts) < 2:
        return None
    if len(pts) > 400:  # the two farthest-apart boundary cells, by their extreme projections
        pts = pts[np.unique(np.concatenate([np.argsort(pts @ d)[[0, -1]] for d in
                                            ((1, 0), (0, 1), (1, 1), (1, -1))]))]
    d = ((pts[:, None, :] - pts[None, :, :]) ** 2).sum(-1)
    k, m = np.unravel_index(np.argmax(d), d.shape)
    return tuple(pts[k]), tuple(pts[m])


def _shortest_path(cost, mask, start, end):
    """Cells ``(k, 2)`` of the cheapest 8-connected path from ``start`` to ``end`` through ``mask``; the weight of
    a step is the mean cost of its two cells times the step length."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra
    idx = -np.ones(mask.shape, np.int64)
    cells = np.argwhere(mask)
    idx[mask] = np.arange(len(cells))
    rows, cols, w = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r, c = cells[:, 0] + dr, cells[:, 1] + dc
        ok = (r >= 0) & (r < mask.shape[0]) & (c >= 0) & (c < mask.shape[1])
        ok[ok] &= mask[r[ok], c[ok]]
        a, b = idx[cells[ok, 0], cells[ok, 1]], idx[r[ok], c[ok]]
        step = np.hypot(dr, dc) * 0.5 * (cost[cells[ok, 0], cells[ok, 1]] + cost[r[ok], c[ok]])
        rows += [a, b]
        cols += [b, a]
        w += [step, step]
    g = coo_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))), shape=(len(cells),) * 2)
    s, e = idx[start], idx[end]
    dist, pred = dijkstra(g.tocsr(), indices=s, return_predecessors=True)
    if not np.isfinite(dist[e]):
        return None
    path = [e]
    while path[-1] != s:
        path.append(pred[path[-1]])
    return cells[np.array(path[::-1])]


def refine_pair(labels, i, j, grey_i, grey_j, valid_i, valid_j, *, band: int = 24, above=None,
                penalty: float = 1000.0) -> np.ndarray:
    """``labels`` with the ``i``/``j`` Voronoi boundary replaced by the least-cost seam (module docstring, 2);
    unchanged when the two do not share a boundary inside their overlap or no path joins its ends."""
    overlap = valid_i & valid_j & ((labels == i) | (labels == j))
    ends = _boundary_ends(labels, i, j, overlap)
    if ends is None:
        return labels
    a, b = labels == i, labels == j
    edge = (a & ndimage.binary_dilation(b)) | (b & ndimage.binary_dilation(a))
    near = ndimage.maximum_filter(edge.view(np.uint8), size=2 * band + 1) > 0  # a square band: one separable pass
    region = near & overlap
    cost = EPSILON + np.abs(np.nan_to_num(grey_i, nan=0.0) - np.nan_to_num(grey_j, nan=0.0))
    if above is not None:
        cost = cost + penalty * above
    path = _shortest_path(cost, region, *ends)
    if path is None:
        return labels
    cut = region.copy()
    cut[path[:, 0], path[:, 1]] = False
    pieces, n = ndimage.label(cut)  # 4-connected: an 8-connected path separates them
    out = labels.copy()
    outside_i, outside_j = a & ~region, b & ~region
    for k in range(1, n + 1):
        piece = pieces == k
        grown = ndimage.binary_dilation(piece)
        ti, tj = (grown & outside_i).sum(), (grown & outside_j).sum()
        if ti or tj:
            out[piece] = i if ti >= tj else j
    on_path = labels[path[:, 0], path[:, 1]]
    out[path[:, 0], path[:, 1]] = on_path  # path cells keep their Voronoi side
    return out


def seam_labels(patches, nadirs, transform, shape, *, band: int = 24, above=None) -> np.ndarray:
    """Voronoi labels refined pair by pair (every pair of orthophotos sharing valid cells), each pair over the
    intersection of the two windows grown by ``band + 1`` cells: everything :func:`refine_pair` looks at, so the
    work and memory per pair follow its overlap, not the mosaic."""
    labels = voronoi_labels(patches, nadirs, transform, shape)
    for i, j in overlapping_pairs(patches):
        win = pair_window(patches, i, j, band + 1, shape)
        if win is None:
            continue
        r0, r1, c0, c1 = win
        gi, gj = patches[i].crop(win, grey=True), patches[j].crop(win, grey=True)
        labels[r0:r1, c0:c1] = refine_pair(labels[r0:r1, c0:c1], i, j, gi, gj, np.isfinite(gi), np.isfinite(gj),
                                           band=band, above=None if above is None else above[r0:r1, c0:c1])
    return labels
