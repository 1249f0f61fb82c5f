"""A coarse DEM (``fotogeo dsm --rpc --dem``) as the guide of each tile of an RPC pair, through :mod:`.dem_guide`.

**The fit**: the DEM's heights at the pair's tie points (:func:`.rpc_pairs.pointing`, located through the left
RPC at the heights the two RPCs give them) against those heights: :func:`.dem_guide.fit`'s offset, NMAD and margin,
named by :func:`.dem_guide.problems` (an offset: another vertical reference, a shifted DEM, or RPCs whose absolute
pointing is off; a spread: a DEM of other ground). Fewer than ``DEM_MIN_MATCHES`` tie points on the DEM (a void, a
DEM beside the pair, or a pair with fewer tie points) and the DEM, unchecked, guides nothing there (named): the tie
points' range stands; a spread over ``DEM_MAX_SPREAD_M`` likewise.

**The tiles** (:func:`tile_range`): the left pixels of a ``TILE_NODES`` × ``TILE_NODES`` grid over a tile meet the
DEM (shifted by the offset) where their lines of sight through the left RPC, ``X(z) = RPC⁻¹(p, z)``, reach it
(:meth:`.dem_guide.DemGuide.meet`, the damped fixed point ``z ← z + ½ (H(X(z)) − z)``); the tile searches
``[min z − m, max z + m⁺]`` (:meth:`.dem_guide.DemGuide.span`, the frame pairs' rule too: ``m`` the fit's margin,
``m⁺`` its margin above, :attr:`.dem_guide.DemFit.above`:
the tie points' rise over the DEM plus the pad, so that roofs and trees a DEM of the ground lies under stay in the
range; each widened by what the nodes' iteration left), inside the pair's range. A tile any node of which falls in
a void or off the DEM keeps the pair's range (the tie points'). Heights are ellipsoidal as the RPCs' (the DEM is
read in that reference: ``--dem-heights``, ``--geoid``).
"""
from __future__ import annotations

import numpy as np

from . import dem_guide, plan

#: nodes a side of the grid over a tile whose lines of sight meet the DEM
TILE_NODES = 9
#: the RPC's other causes of an offset from the DEM, appended to :func:`.dem_guide.problems`' question
RPC_OFFSET = ", RPCs whose absolute pointing is off (fotogeo rpc-bias with GCPs)"


def pair_guide(p, name: str, ims, pt: dict, source, zlim) -> tuple:
    """``(DemGuide or None, warnings)`` of the pair ``p`` (images ``ims`` i, j) from its tie points ``pt``
    (:func:`.rpc_pairs.pointing`) on the height source ``source``; ``zlim`` the run's heights. A DEM the tie points
    cannot check (fewer than ``DEM_MIN_MATCHES`` of them on it) guides nothing: the tie points' range stands, as
    without a DEM (an unchecked DEM 50 m high, guiding ± max(30 m, the DEM range's padding), cut the truth out of a
    tile's range with 15 tie points). The fit goes into the pair's report (``dem``)."""
    ground = ims[p.i].model.inverse(pt["p1"], pt["z"])
    n = int(len(pt["z"]))
    guide, p.extra["dem"], f = dem_guide.pair_guide(source, np.column_stack([ground[:, :2], pt["z"]]), n, None,
                                                    plan.pair_footprints(ims, p, zlim))
    # with no fit measured nothing guides (``guides`` False); a measured fit's problems do not depend on it
    return guide, dem_guide.problems(f or dem_guide.DemFit(0.0, 0.0, 0.0, 0), name, n, guides=False, other=RPC_OFFSET)


def tile_range(m1, guide, tile, zlo: float, zhi: float) -> tuple:
    """``(low, high)`` heights a tile ``(c0, r0, c1, r1)`` of left pixels searches (module docstring), inside the
    pair's ``(zlo, zhi)``; those when any node has no DEM height."""
    c0, r0, c1, r1 = tile
    u, v = np.meshgrid(np.linspace(c0, c1, TILE_NODES), np.linspace(r0, r1, TILE_NODES))
    g = np.column_stack([u.ravel(), v.ravel()])
    z, res = guide.meet(lambda h: m1.inverse(g, h)[:, :2], 0.5 * (zlo + zhi), len(g))
    if not np.isfinite(z).all():
        return zlo, zhi
    lo, hi = guide.span(z, res)
    lo, hi = max(zlo, lo), min(zhi, hi)
    return (lo, hi) if hi > lo else (zlo, zhi)
