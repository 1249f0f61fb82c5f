"""Vector and report outputs: tie points and error vectors as GeoPackage layers.

Error vectors are LineStrings from the reference (true) position ``P`` to the model's
position ``P'``; with an ``exaggeration`` k the drawn line ends at ``P + k (P' − P)`` so that
metre-sized errors are visible on a map, while ``dx``, ``dy`` and ``length`` always hold
the true (unexaggerated) values in map units.

``exaggeration="auto"`` (the default of the tools) picks k from the 1-2-5 series (1, 2, 5,
10, 20, ...) so that a typical vector — the median residual for a registration, one image
pixel on the ground for an orientation (the same k for every model fitted to the same
GCPs) — is drawn as about 3 % of the diagonal of the layer's extent (:func:`auto_exaggeration`).
The layers carry k in the field ``exaggeration`` and a legend sentence (:func:`legend_text`)
in the field ``legend`` and in the GeoPackage layer description, stated for a nominal map
scale at which the extent fills 20 cm (:func:`nominal_scale`).
"""
from __future__ import annotations

import math
from pathlib import Path

import geopandas as gpd
import numpy as np
import shapely

from ..errors import InputError, OutputError
from .clocale import c_case_rules, import_pyogrio

#: the drawn length of a typical vector, as a fraction of the diagonal of the layer's extent
VISIBLE_FRACTION = 0.03
#: the paper size (mm) the layer's extent fills at the nominal map scale of the legend
MAP_MM = 200.0


def error_vectors(start: np.ndarray, end: np.ndarray, exaggeration: float = 1.0) -> np.ndarray:
    """Shapely LineStrings from ``start`` to ``start + exaggeration * (end - start)``."""
    stop = start + exaggeration * (end - start)
    coords = np.stack([start, stop], axis=1)  # (N, 2, 2)
    return shapely.linestrings(coords)


def nice_number(x: float) -> float:
    """The value of the 1-2-5 series (…, 0.5, 1, 2, 5, 10, …) nearest to ``x`` on a log scale.

    >>> nice_number(3.3), nice_number(140.0), nice_number(0.0007)
    (5.0, 100.0, 0.0005)
    """
    if not (x > 0 and math.isfinite(x)):
        return 1.0
    e = math.floor(math.log10(x))
    return min((m * 10.0 ** e for m in (1, 2, 5, 10)), key=lambda v: abs(math.log(v / x)))


def extent_diagonal(points) -> float:
    """Diagonal of the bounding box of ``points`` (N, 2), ignoring NaN rows."""
    p = np.asarray(points, float).reshape(-1, 2)
    p = p[np.isfinite(p).all(axis=1)]
    return float(np.hypot(*(p.max(axis=0) - p.min(axis=0)))) if len(p) else 0.0


def auto_exaggeration(typical_length: float, points) -> float:
    """k >= 1 from the 1-2-5 series drawing a vector of ``typical_length`` as about
    :data:`VISIBLE_FRACTION` (3 %) of the diagonal of the extent of ``points``.

    >>> auto_exaggeration(0.5, [[0, 0], [3000, 4000]])  # 3 % of 5 km = 150 m: 300x, nearest 1-2-5 is 200
    200.0
    >>> auto_exaggeration(400.0, [[0, 0], [3000, 4000]])  # already visible: drawn true to scale
    1.0
    """
    diag = extent_diagonal(points)
    if not (typical_length > 0 and diag > 0):
        return 1.0
    return max(1.0, nice_number(VISIBLE_FRACTION * diag / typical_length))


def readable_subset(points, cells: int = 16) -> np.ndarray:
    """``(N,)`` mask of the arrows drawn at full extent: in each cell of a grid of about ``cells`` x ``cells``
    over the points' extent (square cells), the point nearest the cell's centre — one arrow per cell, so that
    hundreds of check points do not cover the map (the others stay in the layer, not drawn).

    >>> xy = np.array([[0, 0], [1, 1], [50, 50], [99, 99], [100, 100]], float)
    >>> readable_subset(xy, cells=2).tolist()
    [False, True, False, True, True]
    """
    p = np.asarray(points, float).reshape(-1, 2)
    ok = np.isfinite(p).all(axis=1)
    shown = np.zeros(len(p), bool)
    if not ok.any():
        return shown
    lo, hi = p[ok].min(axis=0), p[ok].max(axis=0)
    size = max(float(np.max(hi - lo)) / cells, 1e-12)
    ij = np.floor((p[ok] - lo) / size).astype(np.int64)
    centre = lo + (ij + 0.5) * size
    dist = np.hypot(*(p[ok] - centre).T)
    key = ij[:, 0] * (cells + 2) + ij[:, 1]
    order = np.lexsort((dist, key))
    first = order[np.r_[True, key[order][1:] != key[order][:-1]]]
    shown[np.flatnonzero(ok)[first]] = True
    return shown


def fitting_exaggeration(k: float, lengths, points, cells: int = 16) -> float:
    """``k`` lowered (1-2-5 series, never below 1) until the 90th percentile of the drawn arrows ``k·lengths``
    fits in 80 % of a :func:`readable_subset` cell, so that the arrows drawn do not run into each other.

    >>> fitting_exaggeration(500.0, [1.0, 1.0], [[0, 0], [1600, 0]])  # cells of 100: an arrow of 80 at most
    50.0
    """
    lengths = np.asarray(lengths, float)
    lengths = lengths[np.isfinite(lengths)]
    cell = extent_diagonal(points) / (cells * math.sqrt(2)) if len(lengths) else 0.0
    typical = float(np.percentile(lengths, 90)) if len(lengths) else 0.0
    while k > 1.0 and typical > 0 and cell > 0 and k * typical > 0.8 * cell:
        smaller = nice_number(k / 2.0)
        k = max(1.0, smaller if smaller < k else k / 2.0)
    return k


def exaggeration_value(option, typical_length: float, points) -> tuple[float, str]:
    """The exaggeration ``option`` (``"auto"``, a number or a numeric text) as ``(k, how)``."""
    if option is None or str(option).strip().lower() == "auto":
        return auto_exaggeration(typical_length, points), "auto"
    try:
        k = float(option)
    except (TypeError, ValueError):
        raise InputError(f"exaggeration must be 'auto' or a number > 0; got {option!r}") from None
    if not (k > 0 and math.isfinite(k)):
        raise InputError(f"exaggeration must be 'auto' or a number > 0; got {option!r}")
    return k, "given"


def nominal_scale(points) -> float:
    """A map scale denominator (1-2-5 series) at which the extent of ``points`` (metres) fills
    about :data:`MAP_MM` on paper.

    >>> nominal_scale([[0, 0], [5000, 3000]])  # 5 km on 200 mm: 1:25 000 -> 1:20 000
    20000.0
    """
    p = np.asarray(points, float).reshape(-1, 2)
    p = p[np.isfinite(p).all(axis=1)]
    side = float((p.max(axis=0) - p.min(axis=0)).max()) if len(p) else 0.0
    return nice_number(side / (MAP_MM / 1000.0)) if side > 0 else 1000.0


def legend_text(k: float, scale: float, unit: str = "m") -> str:
    """The legend sentence of an error-vector layer drawn ``k`` times at 1:``scale``.

    At 1:S one millimetre on the map is S/1000 units on the ground; a vector drawn k times its
    length shows S / (1000 k) units of error per millimetre.

    >>> legend_text(200.0, 20000.0)
    'x200; 1 mm on the map = 0.1 m of error (at 1:20 000)'
    """
    per_mm = scale / 1000.0 / k
    return f"x{k:g}; 1 mm on the map = {per_mm:.3g} {unit} of error (at 1:{scale:,.0f})".replace(",", " ")


def grid_means(points, d, *, min_count: int = 3, cells: int | None = None) -> dict:
    """Mean residual per square grid cell over the extent of ``points`` (N, 2) with residuals ``d`` (N, 2).

    ``cells`` per side defaults to about one cell per 8 points (2 to 20). Cells with fewer than
    ``min_count`` points are left out. Returns columns ``cell_col``, ``cell_row`` (0 = top-left),
    ``n``, ``x``, ``y`` (mean position of the cell's points), ``mean_dx``, ``mean_dy``, ``length``
    (of the mean vector) and ``rms`` (of the residuals in the cell).

    >>> g = grid_means([[0, 0], [1, 0], [0, 1], [9, 9], [10, 9], [9, 10], [10, 10]], [[1, 0]] * 7, cells=2)
    >>> g["n"].tolist(), g["mean_dx"].tolist()
    ([4, 3], [1.0, 1.0])
    """
    p, d = np.asarray(points, float).reshape(-1, 2), np.asarray(d, float).reshape(-1, 2)
    ok = np.isfinite(p).all(axis=1) & np.isfinite(d).all(axis=1)
    p, d = p[ok], d[ok]
    empty = {k: np.zeros(0) for k in ("cell_col", "cell_row", "n", "x", "y", "mean_dx", "mean_dy", "length", "rms")}
    if len(p) < min_count:
        return empty
    cells = cells or int(np.clip(round(math.sqrt(len(p) / 8.0)), 2, 20))
    lo, hi = p.min(axis=0), p.max(axis=0)
    size = max(float((hi - lo).max()) / cells, 1e-12)
    col = np.minimum(((p[:, 0] - lo[0]) / size).astype(int), cells - 1)
    row = np.minimum(((hi[1] - p[:, 1]) / size).astype(int), cells - 1)
    key = row * cells + col
    out = {k: [] for k in empty}
    for c in np.unique(key):
        m = key == c
        if m.sum() < min_count:
            continue
        md = d[m].mean(axis=0)
        for k, v in (("cell_col", c % cells), ("cell_row", c // cells), ("n", int(m.sum())), ("x", p[m, 0].mean()),
                     ("y", p[m, 1].mean()), ("mean_dx", md[0]), ("mean_dy", md[1]), ("length", float(np.hypot(*md))),
                     ("rms", float(np.sqrt((d[m] ** 2).sum(axis=1).mean())))):
            out[k].append(v)
    return {k: np.asarray(v, int if k in ("cell_col", "cell_row", "n") else float) for k, v in out.items()}


def write_layers(path, layers: dict, crs, descriptions: dict | None = None, append: bool = False) -> None:
    """Write ``{layer name: GeoDataFrame-like dict with 'geometry'}`` into one GeoPackage (a new
    one, or added to the existing ``path`` with ``append``); ``descriptions`` (``{layer name:
    text}``) become the layers' GeoPackage descriptions (QGIS shows them as the layer's abstract)."""
    path = Path(path)
    descriptions = descriptions or {}
    import_pyogrio()  # pyogrio (its GDAL started under C case rules) on the first write, not when this module loads
    try:
        for i, (name, columns) in enumerate(layers.items()):
            gdf = gpd.GeoDataFrame({k: v for k, v in columns.items() if k != "geometry"},
                                   geometry=columns["geometry"], crs=crs)
            # GeoPackage 1.2: QGIS 3.22's GDAL reads the 1.4 files newer GDALs write only partially
            first = i == 0 and not append
            opts = {"dataset_options": {"VERSION": "1.2"}} if first else {}
            if name in descriptions:
                opts["layer_options"] = {"DESCRIPTION": descriptions[name]}
            with c_case_rules():  # pyogrio checks the options against the driver's list with strcasecmp
                gdf.to_file(path, layer=name, driver="GPKG", mode="w" if first else "a", engine="pyogrio", **opts)
    except Exception as e:  # noqa: BLE001 - any writer failure becomes one clear error
        raise OutputError(f"could not write GeoPackage {str(path)!r}: {e}") from None
