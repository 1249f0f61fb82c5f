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

**Tiles as Dask tasks** (``scheduler`` / ``workers``: the options and the cluster of ``triangulate`` and
``mosaic``, :func:`fotogeo.tools.common.dask_cluster.connect`): each task gets the pairs as they are matched
here — paths of the images and the small parameters of their models and rectifications, never an open dataset or
an array — reads its windows from disk, and returns the fused tile (height, count, spread over the expanded tile)
with the pairs' counters; its points, when a point cloud is asked for, go to a file beside the output that this
process copies into the cloud. This process only removes speckles from, fills and writes the returned tiles, in
tile order (the in-process order: the same DSM, the same point cloud), with at most a few tiles in flight per
worker: its memory stays that of a tile whatever the grid.
"""
from __future__ import annotations

import copy
import math
import shutil
import tempfile
import time
import warnings
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import FotogeoWarning
from ...stereo.fusion import Fusion, GridSpec, PairLayer, remove_speckles
from ...stereo.rays import intersection_angles
from . import frames
from .outputs import SPECKLE_CELLS, SPECKLE_STEP, TILE_MARGIN

#: output tiles' side (cells)
TILE_CELLS = 1024
#: rectified pixels added around a tile's box
BOX_PAD = 2
#: width (degrees) of the bins in which a pair's intersection angles are counted for its report entry
ANGLE_BIN = 0.1
#: the report's narrow rays: the share of a pair's points whose rays meet under this angle (degrees)
NARROW_RAYS = 5.0


@dataclass
class PairMatch:
    """One kept pair ready to match: its :class:`~fotogeo.tools.dsm.plan` choice ``pair``, rectified pair ``rp``,
    disparity range, height range, views and :class:`~fotogeo.tools.dsm.inputs.SourceImage` s, whether to refine
    its disparities (:func:`fotogeo.stereo.refine.refine`), its sparse matches ``near`` that give each pixel's
    expected disparity (:func:`.local.expected_disparity`) and, when ``local``, bound each strip's disparities
    (:func:`.local.guides`, :func:`.local.local_range`; None or not ``local``: the pair's range everywhere), its SGBM
    penalty factor (:func:`.frames.pair_penalty`; None: each strip's own), its DEM (:class:`.dem_guide.DemGuide`:
    the heights each strip expects and searches where it has them; None: the matches'), its images' noise σ
    (:func:`.frames.pair_noise`: the texture test's thresholds; None: the stretch's only), and what its tiles gave
    (pixel counts, points, seconds)."""
    pair: object
    rp: object
    drange: tuple
    zlim: tuple
    views: tuple
    sources: tuple
    refine: bool = False
    near: object = None
    penalty: float | None = None
    local: bool = True
    dem: object = None
    noise: tuple | None = None
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
                                       colours=colours, refine=self.refine, near=self.near, penalty=self.penalty,
                                       local=self.local, dem=self.dem, noise=self.noise)

    def count_angles(self, P) -> None:
        """Add the intersection angles of the pair's rays at its points ``P`` ``(N, 3)``
        (:func:`fotogeo.stereo.rays.intersection_angles`) to ``stats["angles"]``, counts in bins of ``ANGLE_BIN``
        degrees from 0° to 180°: the report's median angle and share of narrow rays (:func:`angle_figures`)."""
        g = intersection_angles(P, *self.rp.centres)
        k = (g[np.isfinite(g)] / ANGLE_BIN).astype(np.int64)
        n = int(round(180.0 / ANGLE_BIN))
        self.stats["angles"] = self.stats.get("angles", 0) + np.bincount(np.minimum(k, n - 1), minlength=n)

    def report(self, low_density: float) -> None:
        """The pair's entry in the report; a warning naming it when less than ``low_density`` of it matched."""
        p, (a, b) = self.pair, (v.name for v in self.views)
        density = self.stats.get("matched", 0) / max(1, self.stats.get("matchable", 0))
        st = self.stats
        p.extra.update(disparity_range_px=[round(self.drange[0], 2), round(self.drange[1], 2)],
                       disparities_searched=round(st.get("searched", 0) / max(1, st.get("searched_pixels", 0)), 1),
                       local_range_strips=f"{st.get('local_strips', 0)} of {st.get('strips', 0)}",
                       coarse_to_fine_strips=f"{st.get('coarse_strips', 0)} of {st.get('strips', 0)}",
                       height_range=[round(self.zlim[0], 2), round(self.zlim[1], 2)],
                       rectified_size=list(self.rp.size),
                       rectified_scale=round(self.rp.focal / (0.5 * (self.views[0].focal + self.views[1].focal)), 4),
                       penalty_scale=None if self.penalty is None else round(self.penalty, 4),
                       match_density=round(density, 4), points=self.points,
                       **angle_figures(st.get("angles")))
        if density < low_density:
            warnings.warn(f"pair {a}-{b}: only {100 * density:.0f} % of the overlap matched (textureless, "
                          f"cloud-covered or changed areas?); its holes stay nodata", FotogeoWarning, stacklevel=4)


def angle_figures(counts) -> dict:
    """A pair's ``ray_angle_median_deg`` (the median intersection angle of its points, interpolated within its
    bin) and ``ray_angle_under_5deg`` (the share of its points whose rays meet under ``NARROW_RAYS``) from the counts
    of :meth:`PairMatch.count_angles`; nothing without counts (RPC pairs, no point)."""
    counts = np.asarray(0 if counts is None else counts)
    total = int(counts.sum())
    if not total:
        return {}
    cum = np.cumsum(counts)
    k = int(np.searchsorted(cum, 0.5 * total))
    below = cum[k - 1] if k else 0
    median = ANGLE_BIN * (k + (0.5 * total - below) / counts[k])
    narrow = cum[int(round(NARROW_RAYS / ANGLE_BIN)) - 1] / total
    return {"ray_angle_median_deg": round(float(median), 1), "ray_angle_under_5deg": round(float(narrow), 4)}


def _tile(matches, sub: GridSpec, core: GridSpec, cloud) -> Fusion:
    """The pairs' points fused on the expanded tile ``sub``; the point cloud gets those in ``core``, and the
    intersection angles of those are counted (pairs with ``count_angles``: frames)."""
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
            if hasattr(m, "count_angles"):
                m.count_angles(P[inside])
            if cloud is not None:
                cloud.write(P[inside], rgb[inside])
        m.seconds += time.perf_counter() - t
        if layer.n.any():
            fusion.add(_despeckled(layer))
    return fusion


def _despeckled(layer: PairLayer) -> PairLayer:
    """``layer`` without its islands of heights (:func:`fotogeo.stereo.fusion.remove_speckles`, ``SPECKLE_CELLS``,
    ``SPECKLE_STEP``): a pair's mismatches are removed before fusion, where they are isolated; after it, islands of
    two pairs joined by a ramp of small steps outgrow the size limit."""
    h = layer.mean()
    out, k = remove_speckles(h, SPECKLE_CELLS, SPECKLE_STEP * layer.grid.resolution)
    if k:
        gone = (np.isfinite(h) & ~np.isfinite(out)).ravel()
        layer.n[gone], layer.s[gone], layer.s2[gone] = 0, 0.0, 0.0
    return layer


def match_tiles(grid: GridSpec, matches, products, stage, timings: dict, scheduler=None, workers=None) -> None:
    """Match ``matches`` (:class:`PairMatch`, or RPC pairs' :class:`.rpc_pairs.RpcPairMatch`: anything with
    ``box(sub)``, ``dense(box, colours)``, ``name``, ``points``, ``seconds``, ``stats``) tile by tile onto
    ``grid`` and hand each tile to ``products`` (:class:`~fotogeo.tools.dsm.outputs.Products`); ``timings`` gets
    each pair's seconds. With ``scheduler`` or ``workers`` the tiles are Dask tasks (module docstring)."""
    tiles = list(grid.tiles(TILE_CELLS, TILE_MARGIN if TILE_CELLS < max(grid.width, grid.height) else 0))
    if scheduler or workers:
        from ..common.dask_cluster import connect
        client, close = connect(None, scheduler, workers, what="dsm --scheduler/--workers")
        try:
            _dask_tiles(client, grid, matches, tiles, products, stage)
        finally:
            close()
    else:
        for k, (core, expanded) in enumerate(tiles):
            stage(k / len(tiles), f"tile {k + 1} of {len(tiles)}")
            fusion = _tile(matches, grid.sub(*expanded), grid.sub(*core), products.cloud)
            products.add(core, expanded, *fusion.result())
    for m in matches:
        timings[m.name] = round(timings.get(m.name, 0.0) + m.seconds, 3)


#: tiles in flight per Dask worker (their results wait on the workers, not here)
AHEAD_PER_WORKER = 2


def _fresh(m):
    """A copy of the pair ``m`` for one task: what matching needs, without its report entry, counters at zero."""
    c = copy.copy(m)
    c.pair, c.stats, c.points, c.seconds = None, {}, 0, 0.0
    if hasattr(c, "miss"):
        c.miss = []
    return c


def _merge(m, counters) -> None:
    """Add a task's ``counters`` of the pair (:func:`tile_task`) to ``m``'s, as the in-process tiles would have."""
    stats, points, seconds, miss = counters
    for k, v in stats.items():
        if isinstance(v, list):
            m.stats.setdefault(k, []).extend(v)
        else:
            m.stats[k] = m.stats.get(k, 0) + v
    m.points += points
    m.seconds += seconds
    if miss is not None:
        m.miss.extend(miss)


class _PointFile:
    """A task's points (the in-process cloud's ``write`` calls), saved as one ``.npz`` of numbered chunks."""

    def __init__(self, path: str):
        self.path, self.chunks = path, {}

    def write(self, xyz, rgb) -> None:
        k = len(self.chunks) // 2
        self.chunks[f"p{k}"], self.chunks[f"c{k}"] = xyz, rgb

    def save(self) -> str | None:
        if not self.chunks:
            return None
        np.savez(self.path, **self.chunks)
        return self.path


def tile_task(matches, grid: GridSpec, core, expanded, cloud_path=None) -> tuple:
    """One output tile on a Dask worker: ``((height, count, spread), counters per pair, points file or None)``
    (module docstring); one thread for GDAL, OpenCV and BLAS."""
    from ..common.dask_cluster import pin_threads
    pin_threads()
    ms = [_fresh(m) for m in matches]  # a worker's copies are shared by its tasks: each task counts its own
    cloud = _PointFile(cloud_path) if cloud_path else None
    fusion = _tile(ms, grid.sub(*expanded), grid.sub(*core), cloud)
    counters = [(m.stats, m.points, m.seconds, getattr(m, "miss", None)) for m in ms]
    return fusion.result(), counters, cloud.save() if cloud else None


def _copy_points(path, cloud) -> None:
    """The task's points file into the point cloud, chunk by chunk, then deleted."""
    with np.load(path) as z:
        for k in range(len(z.files) // 2):
            cloud.write(z[f"p{k}"], z[f"c{k}"])
    Path(path).unlink()


def _dask_tiles(client, grid, matches, tiles, products, stage) -> None:
    """The tiles as Dask tasks on ``client``, their results written in tile order (module docstring)."""
    light = [_fresh(m) for m in matches]
    ahead = AHEAD_PER_WORKER * max(1, len(client.scheduler_info().get("workers", {})))
    folder = None
    if products.cloud is not None:
        for src in {id(s): s for m in light for s in m.sources}.values():
            src.stretches()  # once here, sent with the pairs: not once per task
        out = Path(products.output)
        folder = Path(tempfile.mkdtemp(prefix=f".{out.stem}.points.", dir=out.parent))
    pending, nxt = deque(), 0
    try:
        for k, (core, expanded) in enumerate(tiles):
            stage(k / len(tiles), f"tile {k + 1} of {len(tiles)} (Dask)")
            while nxt < len(tiles) and nxt <= k + ahead:
                path = str(folder / f"tile_{nxt:06d}.npz") if folder else None
                pending.append(client.submit(tile_task, light, grid, *tiles[nxt], path, pure=False))
                nxt += 1
            bands, counters, points = pending.popleft().result()
            for m, c in zip(matches, counters):
                _merge(m, c)
            if points:
                _copy_points(points, products.cloud)
            products.add(core, expanded, *bands)
    except BaseException:
        for fut in pending:
            fut.cancel()
        raise
    finally:
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
