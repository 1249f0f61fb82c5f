"""Dense matching of the kept pairs (frames, and RPC pairs through :class:`.rpc_pairs.RpcPairMatch`) by output
tiles: memory bounded by the tile, not by the images or the DSM.

The output grid is cut into tiles of ``TILE_CELLS`` cells a side, each expanded by
:data:`~fotogeo.tools.dsm.outputs.TILE_MARGIN` cells (:meth:`fotogeo.stereo.fusion.GridSpec.tiles`). For each
tile and pair, the rectified left pixels whose points can fall in the expanded tile are the bounding box of the
projections of its eight corners at the pair's lowest and highest height (a pinhole maps the convex box between
the two planes onto the convex hull of its corners' images); :func:`.frames.dense_points` matches that box strip
by strip, reading only the source windows it needs. The points land on the tile's own grid (one
:class:`~fotogeo.stereo.fusion.PairLayer` per pair), the pairs are fused there, and :class:`.outputs.Products`
writes the tile. The point cloud gets each point once: those whose cell lies in the tile's core.
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ...errors import FotogeoWarning
from ...stereo.fusion import Fusion, GridSpec, PairLayer
from . import frames
from .outputs import TILE_MARGIN

#: output tiles' side (cells)
TILE_CELLS = 1024
#: rectified pixels added around a tile's box
BOX_PAD = 2


@dataclass
class PairMatch:
    """One kept pair ready to match: its :class:`~fotogeo.tools.dsm.plan` choice ``pair``, rectified pair ``rp``,
    disparity range, height range, views and :class:`~fotogeo.tools.dsm.inputs.SourceImage` s, whether to refine
    its disparities (:func:`fotogeo.stereo.refine.refine`), and what its tiles gave (pixel counts, points, seconds)."""
    pair: object
    rp: object
    drange: tuple
    zlim: tuple
    views: tuple
    sources: tuple
    refine: bool = False
    stats: dict = field(default_factory=dict)
    points: int = 0
    seconds: float = 0.0

    def box(self, sub: GridSpec) -> tuple | None:
        """``(u0, v0, u1, v1)``: the rectified left pixels whose points may fall in ``sub`` (module docstring);
        None when they lie outside the rectified image."""
        x0, y1 = sub.x0, sub.y0
        x1, y0 = x0 + sub.width * sub.resolution, y1 - sub.height * sub.resolution
        P = np.array([(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in self.zlim], float)
        px = self.rp.project(P, 0)
        w, h = self.rp.size
        if not np.isfinite(px).all():
            return 0, 0, w, h
        u0, v0 = (max(0, math.floor(c) - BOX_PAD) for c in px.min(axis=0))
        u1, v1 = min(w, math.ceil(px[:, 0].max()) + BOX_PAD), min(h, math.ceil(px[:, 1].max()) + BOX_PAD)
        return (u0, v0, u1, v1) if u1 > u0 and v1 > v0 else None

    @property
    def name(self) -> str:
        return f"{self.views[0].name}-{self.views[1].name}"

    def dense(self, box, colours: bool = False):
        """Yield ``(points (N, 3), colours or None)`` of the rectified left pixels ``box``
        (:func:`.frames.dense_points`)."""
        yield from frames.dense_points(self.rp, self.views, self.sources, *self.drange, self.zlim, self.stats, box,
                                       colours=colours, refine=self.refine)

    def report(self, low_density: float) -> None:
        """The pair's entry in the report; a warning naming it when less than ``low_density`` of it matched."""
        p, (a, b) = self.pair, (v.name for v in self.views)
        density = self.stats.get("matched", 0) / max(1, self.stats.get("matchable", 0))
        p.extra.update(disparity_range_px=[round(self.drange[0], 2), round(self.drange[1], 2)],
                       height_range=[round(self.zlim[0], 2), round(self.zlim[1], 2)],
                       rectified_size=list(self.rp.size),
                       rectified_scale=round(self.rp.focal / (0.5 * (self.views[0].focal + self.views[1].focal)), 4),
                       match_density=round(density, 4), points=self.points)
        if density < low_density:
            warnings.warn(f"pair {a}-{b}: only {100 * density:.0f} % of the overlap matched (textureless, "
                          f"cloud-covered or changed areas?); its holes stay nodata", FotogeoWarning, stacklevel=4)


def _tile(matches, sub: GridSpec, core: GridSpec, cloud) -> Fusion:
    """The pairs' points fused on the expanded tile ``sub``; the point cloud gets those in ``core``."""
    fusion = Fusion(sub)
    for m in matches:
        box = m.box(sub)
        if box is None:
            continue
        t, layer = time.perf_counter(), PairLayer(sub)
        for P, rgb in m.dense(box, colours=cloud is not None):
            layer.add(P)
            inside = core.cells(P[:, :2])[1]
            m.points += int(inside.sum())
            if cloud is not None:
                cloud.write(P[inside], rgb[inside])
        m.seconds += time.perf_counter() - t
        if layer.n.any():
            fusion.add(layer)
    return fusion


def match_tiles(grid: GridSpec, matches, products, stage, timings: dict) -> None:
    """Match ``matches`` (:class:`PairMatch`, or RPC pairs' :class:`.rpc_pairs.RpcPairMatch`: anything with
    ``box(sub)``, ``dense(box, colours)``, ``name``, ``points``, ``seconds``) tile by tile onto ``grid`` and hand
    each tile to ``products`` (:class:`~fotogeo.tools.dsm.outputs.Products`); ``timings`` gets each pair's seconds."""
    tiles = list(grid.tiles(TILE_CELLS, TILE_MARGIN if TILE_CELLS < max(grid.width, grid.height) else 0))
    for k, (core, expanded) in enumerate(tiles):
        stage(k / len(tiles), f"tile {k + 1} of {len(tiles)}")
        fusion = _tile(matches, grid.sub(*expanded), grid.sub(*core), products.cloud)
        products.add(core, expanded, *fusion.result())
    for m in matches:
        timings[m.name] = round(timings.get(m.name, 0.0) + m.seconds, 3)
