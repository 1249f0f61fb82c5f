"""A coarse DEM (``fotogeo dsm --dem``) as the guide of each strip of a pair: the heights it expects and searches.

**The fit** (:func:`fit`): the DEM's heights ``H`` at the pair's sparse matches (:func:`.local.guides`, without the
mismatches) against the heights ``Z`` the orientation gives them: offset ``o = median(H − Z)``, spread
``s = 1.4826 · median |H − Z − o|`` (NMAD), and the margin the strips search around the DEM,
``m = DEM_PAD_M + DEM_ERROR_K · U`` — what a coarse DEM misses (a smoothed ridge, a roof, a tree, a void's edge) is
measured at the matches, not assumed. ``U`` (:func:`upper_quantile`) bounds the ``DEM_QUANTILE`` quantile of
``|H − Z − o|`` over the pair's ground with confidence ``DEM_CONFIDENCE``, not the matches' own percentile, which
few matches underestimate: with ``n`` matches sorted, ``a(r)`` is above the ``p`` quantile with probability
``P(Binomial(n, p) ≤ r − 1)`` whatever their distribution (Wilks 1941), and ``U`` is the least such ``a(r)`` reaching
the confidence ``c``; when even the largest does not (``1 − pⁿ < c``: fewer than 59 for ``p = c = 0.95``), the largest
bounds the lower quantile ``p_n = (1 − c)^(1/n)``, and an exponential tail (a generalized Pareto tail of shape 0,
Pickands 1975) through the median ``a½`` and it reaches ``p``:
``U = a½ + (a(n) − a½) · ln(½ / (1 − p)) / ln(½ / (1 − p_n))``. **Above the DEM** the error is one-sided and
heavy-tailed (a DEM of the ground lies under roofs and trees, and the tallest of them are the few matches a
quantile leaves out): ``rise`` is the highest a match stands over the shifted DEM, ``max(Z − (H − o))``, or, when
larger, the upper bound above of the ``DEM_RISE_QUANTILE`` quantile of ``max(Z − (H − o), 0)`` (from few matches
that bound lies beyond the largest, along the exponential tail), and the margin above is ``max(m, DEM_PAD_M +
rise)`` (:attr:`DemFit.above`; :meth:`DemGuide.span`, the heights a frame pair's strip, :mod:`.local`, and a
satellite pair's tile, :mod:`.rpc_dem`, search). The DEM is used shifted by ``−o``: the DSM's
heights come from the orientation, the DEM only says where to look; an offset over ``DEM_OFFSET_WARN_M`` (another
vertical reference, a shifted DEM) and a spread over ``DEM_MAX_SPREAD_M`` (a DEM of other ground or time) are named
(:func:`problems`), and a DEM that spread does not guide the pair (the sparse matches do, as without ``--dem``).

**Node heights** (:meth:`DemGuide.node_heights`): the height where the ray of a rectified left pixel meets the DEM,
by the damped fixed point ``z ← z + ½ (H(C + λ(z) d) − z)``, ``λ(z) = (z − C_z) / d_z`` (C the left centre, d the
pixel's ray), started at the median height of the nearest sparse matches. With ``g = dH/dz`` along the ray (the
slope times the ray's tangent) the error shrinks by ``(1 + g) / 2`` per step: it converges for ``−3 < g < 1``;
what is left (``|H − z|`` after ``DEM_ITER`` steps) widens that node's range. NaN where the DEM has no height
(voids, outside it): those nodes take the sparse matches' heights (:mod:`.local`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...geometry.dem import Dem, heights_at

#: the margin around the DEM's heights (m): this much plus ``DEM_ERROR_K`` times an upper bound, with confidence
#: ``DEM_CONFIDENCE``, of the ``DEM_QUANTILE`` quantile of the DEM's error measured at the sparse matches (module
#: docstring)
DEM_PAD_M = 5.0
DEM_ERROR_K = 1.5
DEM_QUANTILE = 0.95
DEM_CONFIDENCE = 0.95
#: the quantile of the matches' rise over the DEM bounded for the margin above it (module docstring)
DEM_RISE_QUANTILE = 0.99
#: fewer sparse matches with a DEM height than this and the pair's fit is not measured (the run's is used)
DEM_MIN_MATCHES = 20
#: a DEM this far (m, median) from the matches' heights is named; this spread (NMAD, m) and it guides no strip
DEM_OFFSET_WARN_M = 10.0
DEM_MAX_SPREAD_M = 25.0
#: the least margin (m) of a pair no sparse match measured the DEM for (the run's padding of the DEM's range when
#: larger; named in a warning)
DEM_UNMEASURED_M = 30.0
#: damped fixed-point steps of a node's height (module docstring)
DEM_ITER = 8
#: the DEM is kept per pair on at most this many nodes a side (its own cells when fewer)
DEM_NODES = 512


@dataclass(frozen=True)
class DemFit:
    """The DEM against a pair's sparse matches (module docstring): ``offset`` and ``spread`` (m), the strips'
    ``margin`` (m), the ``matches`` measured, and ``rise`` (m): how high over the shifted DEM the surface stands
    (roofs, trees on the ground a DEM models; module docstring)."""
    offset: float
    spread: float
    margin: float
    matches: int
    rise: float = 0.0

    @property
    def above(self) -> float:
        """The margin searched above the shifted DEM (module docstring): the ``rise`` plus ``DEM_PAD_M``, at least
        the symmetric ``margin``."""
        return max(self.margin, DEM_PAD_M + self.rise)

    def as_report(self, used: bool) -> dict:
        return {"offset_m": round(self.offset, 2), "nmad_m": round(self.spread, 2),
                "margin_m": round(self.margin, 2), "margin_above_m": round(self.above, 2), "matches": self.matches,
                "guides_strips": used}


def fit(source, points) -> DemFit | None:
    """The :class:`DemFit` of the height source ``source`` at the sparse matches ``points`` ``(N, 3)`` (map
    frame); None with fewer than ``DEM_MIN_MATCHES`` of them on the DEM."""
    P = np.asarray(points, float).reshape(-1, 3)
    h = heights_at(source, P[:, :2]) if len(P) else np.zeros(0)
    ok = np.isfinite(h)
    if ok.sum() < DEM_MIN_MATCHES:
        return None
    r = h[ok] - P[ok, 2]
    o = float(np.median(r))
    a = np.abs(r - o)
    return DemFit(o, float(1.4826 * np.median(a)), DEM_PAD_M + DEM_ERROR_K * upper_quantile(a), int(ok.sum()),
                  max(0.0, float(np.max(o - r)), upper_quantile(np.maximum(o - r, 0.0), DEM_RISE_QUANTILE)))


#: from this many values on, the exponential tail of :func:`upper_quantile` is anchored on the second largest
TAIL_SECOND_FROM = 10


def upper_quantile(a, p: float = DEM_QUANTILE, c: float = DEM_CONFIDENCE) -> float:
    """An upper bound of the ``p`` quantile of the population the values ``a`` (>= 0, at least one) are a random
    sample of, with confidence ``c`` (module docstring): an order statistic of ``a``, or beyond its largest along an
    exponential tail when ``a`` is too small for one. The tail runs from the median through the ``k``-th largest
    value, taken as the quantile it exceeds with confidence ``c`` (the ``k``-th largest of ``n`` uniform values is
    Beta(n − k + 1, k) distributed); ``k`` is 2 from :data:`TAIL_SECOND_FROM` values on, so that one mismatch among
    20–60 matches does not widen the search by tens of metres."""
    from scipy.stats import binom
    s = np.sort(np.asarray(a, float).ravel())
    n = len(s)
    r = int(binom.ppf(c, n, p))  # the least r with P(Binomial(n, p) <= r) >= c: s[r] is the bound
    if r < n - 1 or (r < n and n < TAIL_SECOND_FROM):
        return float(s[r])
    from scipy.stats import beta
    half = float(np.median(s))
    k = 2 if n >= TAIL_SECOND_FROM else 1  # anchored on the second largest: one mismatch does not set the bound
    p_k = float(beta.ppf(1.0 - c, n - k + 1, k))  # the k-th largest of n lies above this quantile with confidence c
    return half + (float(s[-k]) - half) * float(np.log(0.5 / (1.0 - p)) / np.log(0.5 / (1.0 - p_k)))


def problems(f: DemFit, where: str, sparse: int = 0, guides: bool = True, other: str = "") -> list:
    """What a user is told about the fit ``f`` (module docstring); ``where`` names the matches, ``sparse`` how many
    the pair has: with none measured (``f.matches`` 0), the DEM guides that pair unchecked, or (``guides`` False:
    too few matches to check it, or matches none of which is on the DEM) nothing; ``other`` another cause of an
    offset the orientation may have (satellite RPCs: their absolute pointing)."""
    if not f.matches and not guides and sparse < DEM_MIN_MATCHES:
        return [f"pair {where} has {sparse} sparse matches, fewer than the {DEM_MIN_MATCHES} that check it: "
                f"unchecked, it is not used for that pair (an offset or another vertical reference would cut the "
                f"surface out of the search; the matches' heights are searched)"]
    if not f.matches and not guides:
        return [f"it has a height under fewer than {DEM_MIN_MATCHES} of the {sparse} sparse matches of {where} (a "
                f"void, or it does not cover that pair): unchecked, it guides nothing there (the matches do); give a "
                f"DEM covering the images"]
    if not f.matches:
        return [f"it was not checked for pair {where} ({sparse} sparse matches; {DEM_MIN_MATCHES} on the DEM "
                f"measure it, and no other pair did): its heights, as they are, guide that pair's search "
                f"± {f.margin:.0f} m; give a DEM in the orientation's vertical reference"]
    out = []
    if abs(f.offset) > DEM_OFFSET_WARN_M:
        out.append(f"its heights lie {f.offset:+.1f} m from those the orientation gives {f.matches} sparse matches "
                   f"of {where} (median; NMAD {f.spread:.1f} m): another vertical reference (geoid or ellipsoid: "
                   f"--dem-heights, --geoid){other} or a shifted DEM? It is used shifted by {-f.offset:+.1f} m (the "
                   f"DSM's heights come from the orientation); give a DEM in the orientation's vertical reference")
    if f.spread > DEM_MAX_SPREAD_M:
        out.append(f"its heights disagree with the {f.matches} sparse matches of {where} (NMAD {f.spread:.1f} m "
                   f"after the median offset): a DEM of other ground or time? It does not guide that pair's "
                   f"search (its sparse matches do); check the DEM")
    return out


def heights_reference(ims, dem_ref, fit, said: bool) -> tuple:
    """``(reference, notes)`` of the DSM's heights, which are the orientation's (a DEM only guides the search):
    the orientation's own when it states one; else the DEM's as the run reads it (``dem_ref``: stated in its file,
    or by ``--dem-heights``/``--geoid``, ``said``) when its ``fit`` at the sparse matches finds the two within
    ``DEM_OFFSET_WARN_M`` (where the geoid lies nearer the ellipsoid than that, the fit cannot tell them apart), or,
    with no fit, when the user stated it; else None (not stated), with a note saying why."""
    refs = {im.height_reference for im in ims} - {None}
    if refs or dem_ref is None:
        return (refs.pop() if len(refs) == 1 else None), []
    if fit is None and said:
        return dem_ref, []
    if fit is not None and abs(fit.offset) <= DEM_OFFSET_WARN_M:
        return dem_ref, []
    why = (f"{-fit.offset:+.1f} m from the DEM's {dem_ref} heights, the median at the sparse matches"
           if fit is not None else f"not measured against the DEM's {dem_ref} heights")
    return None, [f"heights: the orientation's, reference not stated ({why})"]


@dataclass(frozen=True)
class DemGuide:
    """A pair's DEM (``dem``, a :class:`~fotogeo.geometry.dem.Dem` sampled in the map CRS over the pair's ground,
    picklable for a Dask task) and its :class:`DemFit` ``fitted``; heights are the DEM's minus the fit's offset."""
    dem: Dem
    fitted: DemFit

    @property
    def margin(self) -> float:
        return self.fitted.margin

    @property
    def above(self) -> float:
        return self.fitted.above

    def span(self, z, residual=0.0) -> tuple:
        """``(low, high)``: the heights searched about the DEM's heights ``z`` (finite, shifted) each widened by
        its ``residual``: the margin below the lowest, the margin above (:attr:`DemFit.above`) over the highest —
        the one rule of a frame pair's strips (:mod:`.local`) and an RPC pair's tiles (:mod:`.rpc_dem`)."""
        z, r = np.asarray(z, float), np.asarray(residual, float)
        return float(np.min(z - r)) - self.margin, float(np.max(z + r)) + self.above

    def pair_range(self, other: tuple, zlim: tuple) -> tuple:
        """The pair's heights: the shifted DEM's over the pair within its margins (:meth:`span`) joined with the
        range ``other`` (what guides where the DEM has a void: an RPC pair's tie points; a frame pair's run range),
        inside ``zlim``."""
        h = self.dem.data[np.isfinite(self.dem.data)] - self.fitted.offset
        if not h.size:
            return other
        lo, hi = self.span(h)
        return max(zlim[0], min(other[0], lo)), min(zlim[1], max(other[1], hi))

    def heights(self, XY) -> np.ndarray:
        return self.dem.heights(np.asarray(XY, float)) - self.fitted.offset

    def node_heights(self, rp, u, v, z0) -> tuple:
        """``(z, residual)``: where the rays of the rectified left pixels ``(u, v)`` meet the DEM (module
        docstring), started at ``z0``, and ``|H − z|`` left after the last step; NaN where the DEM has none."""
        d = rp.rays(np.ravel(u), np.ravel(v), 0)
        C = rp.centres[0]

        def ground(z):
            with np.errstate(divide="ignore", invalid="ignore"):
                lam = (z - C[2]) / d[:, 2]
            return np.where((lam > 0)[:, None], C[:2] + lam[:, None] * d[:, :2], np.nan)
        return self.meet(ground, z0, len(d))

    def meet(self, ground, z0, n: int) -> tuple:
        """``(z, residual)``: the damped fixed point of the module docstring for any line of sight, ``ground(z)``
        ``(n, 2)`` the map points of the ``n`` lines at heights ``z`` ``(n,)`` (NaN where a line has none), started
        at ``z0``; NaN where the DEM has no height."""
        z = np.broadcast_to(np.asarray(z0, float), (n,)).copy()
        found = np.zeros(len(z), bool)
        h = np.full(len(z), np.nan)
        for _ in range(DEM_ITER):
            XY = np.asarray(ground(z), float)
            h = np.full(len(z), np.nan)
            xy_ok = np.isfinite(XY).all(axis=1)
            h[xy_ok] = self.heights(XY[xy_ok])
            ok = np.isfinite(h)
            found |= ok
            z = np.where(ok, z + 0.5 * (h - z), z)
        z = np.where(found & np.isfinite(h), z, np.nan)
        return z, np.abs(h - z)


def pair_guide(source, points, sparse: int, unmeasured: DemFit | None, footprints) -> tuple:
    """``(DemGuide or None, report entry, DemFit or None)`` of a pair: the height source ``source`` fitted at its
    sparse matches ``points`` (:func:`fit`; ``sparse`` how many it has), sampled over its ``footprints``
    (:func:`pair_dem`). With fewer than ``DEM_MIN_MATCHES`` on the DEM the fit ``unmeasured`` stands in (the run's,
    or the DEM unchecked), unless the pair has that many matches, all off the DEM (a void, a DEM beside it: nothing
    checks it, it guides nothing), or ``unmeasured`` is None (satellite pairs: their tie points always give a
    range, and an unchecked DEM 50 m off would cut the truth out of it); a spread over ``DEM_MAX_SPREAD_M`` guides
    nothing either."""
    f = fit(source, points)
    if f is None and (unmeasured is None or sparse >= DEM_MIN_MATCHES):
        return None, {"matches": 0, "guides_strips": False}, None
    f = f or unmeasured
    used = f.spread <= DEM_MAX_SPREAD_M
    if not used:
        return None, f.as_report(False), f
    from ...geometry.dem import underlying_dem
    d, other = underlying_dem(source)
    grid = pair_dem(source, footprints, 0.0 if other else abs(float(d.transform.a)))
    return (None if grid is None else DemGuide(grid, f)), f.as_report(grid is not None), f


def pair_dem(source, footprints, cell: float) -> Dem | None:
    """The height source ``source`` sampled at its own cells ``cell`` (m; coarser when the area would need more
    than ``DEM_NODES`` a side) over the bounding box of ``footprints`` ``(N, 2+)`` (a pair's ground at its lowest
    and highest heights) and a cell around it; None when no footprint."""
    from rasterio.transform import from_origin
    xy = np.vstack([np.asarray(f, float)[:, :2] for f in footprints if len(f)]) if footprints else np.zeros((0, 2))
    xy = xy[np.isfinite(xy).all(axis=1)]
    if not len(xy):
        return None
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    step = max(float(cell), (x1 - x0) / DEM_NODES, (y1 - y0) / DEM_NODES, 1e-3)
    x0, y1 = x0 - step, y1 + step
    nx, ny = int(np.ceil((x1 + step - x0) / step)), int(np.ceil((y1 - (y0 - step)) / step))
    X, Y = np.meshgrid(x0 + (np.arange(nx) + 0.5) * step, y1 - (np.arange(ny) + 0.5) * step)
    Z = heights_at(source, np.column_stack([X.ravel(), Y.ravel()])).reshape(ny, nx)
    return Dem(Z, from_origin(x0, y1, step, step))
