"""Ground control points from files: vector layers, CSV tables and QGIS ``.points`` files.

A GCP joins a ground position ``(X, Y[, Z])`` in a map CRS with an image position
``(col, row)`` in the GDAL corner convention (:mod:`fotogeo.pixels`), plus an ``id`` and a
``role`` (``control`` points fit a model, ``check`` points measure it).

Accepted inputs (:func:`read_gcps`):

* any point layer GDAL reads (GeoPackage, Shapefile, GeoJSON, …) with fields for the image
  position (default ``col``, ``row``), optional height ``z``, ``role`` and ``id``; a point whose
  optional ``enabled`` field is 0 (the GCP picker's unticked *on*, the Georeferencer's disabled
  point) is left out as if absent;
* a CSV table (``,``, ``;`` or tab separated; decimal commas with ``;`` or tab) with map coordinates in columns
  ``x``, ``y`` (or ``X``/``Y``, ``mapX``/``mapY``, ``lon``/``lat``, ``easting``/``northing``) and the same fields
  (the height: ``z``, else a column named as in :data:`Z_NAMES`); its CRS must be given;
* orthority's GCP GeoJSON (property ``ji`` = ``[col, row]``, pixel centres at integers; 3-D points: lon,
  lat, height), one image's;
* a QGIS Georeferencer ``.points`` file (enabled points are control points, disabled ones
  check points; see :mod:`fotogeo.io.points`).

Heights come from the height field, else from a DEM (bilinear, transformed into the DEM's
CRS as needed), else a constant (an :class:`~fotogeo.errors.InputNote` says how many; ``Gcps.heights`` counts
each source); otherwise they stay NaN and only 2-D models can be fitted. :func:`inside_image` is the one rule of
the tools for GCPs whose pixel lies outside the image: skipped by name, refused only when too few are left.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from pyproj import CRS

from ..crs import parse_crs, transform_points
from ..errors import FotogeoWarning, InputError, InputNote, VectorError
from ..image_extent import on_image, outside_reason
from .tables import duplicate_ids

#: ``blunder`` (written by ``orient`` for points data snooping removed) is kept out of the fit
#: and of the statistics when such a layer is read back
ROLES = ("control", "check", "blunder")


@dataclass(frozen=True)
class Gcps:
    ground: np.ndarray  # (N, 3) X, Y, Z (Z NaN when unknown) in ``crs``
    pixel: np.ndarray  # (N, 2) col, row (corner convention)
    role: np.ndarray  # (N,) 'control' | 'check'
    ids: np.ndarray  # (N,) str
    crs: CRS
    source: str = ""
    #: further role columns ``role_<label>`` of a table, by label: fixed control/check sets (compare-models)
    role_sets: dict = field(default_factory=dict)
    #: where the heights came from: ``{"file": n, "dem": n, "constant": n, "missing": n}`` (+ ``"dem_path"``)
    heights: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.pixel)

    @property
    def has_heights(self) -> bool:
        return bool(np.isfinite(self.ground[:, 2]).all())

    def subset(self, keep: np.ndarray) -> "Gcps":
        """The GCPs where the boolean ``keep`` is true (their role sets too)."""
        return replace(self, ground=self.ground[keep], pixel=self.pixel[keep], role=self.role[keep],
                       ids=self.ids[keep], role_sets={k: np.asarray(v)[keep] for k, v in self.role_sets.items()})


#: Accepted names of the map-coordinate columns of a CSV table (any letter case).
X_NAMES = ("x", "mapx", "lon", "easting")
Y_NAMES = ("y", "mapy", "lat", "northing")
#: Names the height column is found by when the default ``z`` field is absent (any letter case).
Z_NAMES = ("z", "height", "elevation", "elev", "alt", "altitude", "h")
_FIELD_HINT = "name the right one with the field options"


def read_gcps(path, *, layer=None, col="col", row="row", z="z", role="role", id="id", crs=None,
              raster=None, dem=None, height=None) -> Gcps:
    """Read GCPs from ``path`` (see the module docstring). ``crs`` overrides/sets the map CRS."""
    p = Path(path)
    what = f"GCP file {str(p)!r}"
    if not p.exists():
        raise VectorError(f"{what} does not exist")
    role_sets, n_disabled = {}, 0
    if p.suffix.lower() == ".points":
        xy, pix, roles, ids, zs, map_crs = _from_points_file(p, what, crs, raster)
    else:
        xy, pix, roles, ids, zs, map_crs, role_sets, n_disabled = _from_table(p, what, layer, crs, col, row, z,
                                                                              role, id)
    if len(pix) == 0:
        raise VectorError(f"{what} holds no points" + (f" that are enabled (its field 'enabled' is 0 for all "
                                                       f"{n_disabled}); enable some" if n_disabled else ""))
    ground = np.column_stack([xy, np.full(len(xy), np.nan) if zs is None else zs])
    g = Gcps(ground, pix, np.asarray(roles, dtype=object).astype(str), np.asarray(ids).astype(str), map_crs, str(p),
             role_sets)
    g = _fill_heights(g, dem, height)
    _validate(g, what)
    return g


def _from_points_file(p: Path, what: str, crs, raster):
    """``(map xy, pixel, roles, ids, heights=None, CRS)`` of a Georeferencer ``.points`` file."""
    from .points import read_points, source_to_pixel
    from .raster import raster_transform
    gp = read_points(p)
    pix = source_to_pixel(gp.source_xy, raster_transform(raster))
    spec = crs or gp.crs
    if not spec:
        raise VectorError(f"{what} has no '#CRS' line; give the map CRS of its points (crs=/--crs)")
    ids = np.array([str(i + 1) for i in range(len(gp))])
    return gp.map_xy, pix, np.where(gp.enabled, "control", "check"), ids, None, parse_crs(spec, what)


def _from_table(p: Path, what: str, layer, crs, col, row, z, role, id):
    """``(map xy, pixel, roles, ids, heights or None, CRS, {label: roles}, number of disabled points)`` of the
    enabled points of a CSV table or a point layer (the role sets: the further role columns ``<role>_<label>``)."""
    from .tables import find_column, is_layer, numeric_columns, read_table
    table = read_table(p, "GCP file", layer)
    if is_layer(table):
        xy, map_crs = _layer_positions(table, what, crs, id)
    else:
        xcol = next((c for c in table.columns if str(c).lower() in X_NAMES), None)
        ycol = next((c for c in table.columns if str(c).lower() in Y_NAMES), None)
        if xcol is None or ycol is None:
            fields = ", ".join(str(c) for c in table.columns)
            raise VectorError(f"{what} needs map coordinate columns x and y (or mapX/mapY, lon/lat, "
                              f"easting/northing); its columns: {fields}")
        if not crs:
            raise VectorError(f"{what}: a CSV carries no CRS; give the map CRS (crs=/--crs)")
        xy, map_crs = numeric_columns(table, [xcol, ycol], what, id_field=id), parse_crs(crs, what)
    ji = _orthority_ji(table, what) if is_layer(table) and (col, row) == ("col", "row") else None
    pix = ji if ji is not None else numeric_columns(table, [col, row], what, _FIELD_HINT, id_field=id)
    rf = find_column(table, role)
    roles = _roles(table, rf, what)
    prefix = f"{rf or role}_".lower()
    role_sets = {str(c)[len(prefix):]: _roles(table, c, what) for c in table.columns
                 if str(c).lower().startswith(prefix) and len(str(c)) > len(prefix)}
    idf = find_column(table, id)
    ids = table[idf].astype(str).to_numpy() if idf else np.array([str(i + 1) for i in range(len(table))])
    zf = find_column(table, z)
    if zf is None and z == "z":  # the default field absent: the usual names of a height column
        zf = next((c for c in table.columns if str(c).lower() in Z_NAMES and c != "geometry"), None)
    zs = numeric_columns(table, [zf], what, id_field=id)[:, 0] if zf is not None else None
    if zs is None and is_layer(table) and len(table) and table.geometry.has_z.all():  # 3-D points: their z
        zs = table.geometry.z.to_numpy(float)
    on = enabled_rows(table)
    if not on.all():  # disabled points: left out as if absent (module docstring)
        role_sets = {k: v[on] for k, v in role_sets.items()}
        xy, pix, roles, ids, zs = xy[on], pix[on], roles[on], ids[on], None if zs is None else zs[on]
    return xy, pix, roles, ids, zs, map_crs, role_sets, int((~on).sum())


def enabled_rows(table) -> np.ndarray:
    """Per row, whether the point is enabled: its ``enabled`` field (any letter case) is not 0 / false / no;
    every row without the field or with it empty (NULL)."""
    from .tables import find_column
    column = find_column(table, "enabled")
    if column is None:
        return np.ones(len(table), bool)
    text = table[column].astype(object).where(table[column].notna(), "1").astype(str).str.strip().str.lower()
    return ~text.isin(("0", "0.0", "false", "no", "off")).to_numpy()


def _roles(table, column, what: str) -> np.ndarray:
    """The roles of ``column`` (empty = control; all control without the column), checked."""
    roles = (table[column].fillna("control").astype(str).str.lower().to_numpy() if column
             else np.full(len(table), "control"))
    bad = sorted(set(roles) - set(ROLES))
    if bad:
        raise VectorError(f"{what}: {column or 'role'} values must be 'control', 'check' or 'blunder'; found {bad}")
    return roles


def _orthority_ji(table, what: str):
    """Pixel positions ``(N, 2)`` of orthority's GCP GeoJSON (property ``ji`` = ``[col, row]`` with pixel centres at
    integers, so ``+ 0.5`` in the corner convention; the geometry lon, lat, height), or None without ``ji``. A file
    holding GCPs of several images (``filename``) is refused: which rows belong to this image is not said."""
    from .tables import find_column
    jc = find_column(table, "ji")
    if jc is None:
        return None
    fc = find_column(table, "filename")
    names = sorted({str(v) for v in table[fc]}) if fc is not None else []
    if len(names) > 1:
        raise VectorError(f"{what} holds GCPs of {len(names)} images ({', '.join(names[:5])}); keep the rows of "
                          f"this image (e.g. ogr2ogr -where \"filename = '{names[0]}'\")")
    try:
        ji = np.array([np.asarray(v, float).reshape(2) for v in table[jc]], float).reshape(-1, 2)
    except (TypeError, ValueError):
        raise VectorError(f"{what}: its 'ji' values must be [col, row] pairs (orthority's GCP format)") from None
    return ji + 0.5


def _layer_positions(table, what: str, crs, id: str | None = "id"):
    """Map positions (N, 2) of a point layer's geometries and its CRS (``crs`` overrides it)."""
    from .tables import describe_rows
    geom = table.geometry
    missing = (geom.isna() | geom.is_empty).to_numpy()
    if missing.any():
        raise VectorError(f"{what}: {describe_rows(table, np.flatnonzero(missing), id)} "
                          f"{'have' if missing.sum() > 1 else 'has'} no geometry (the map position); "
                          f"fix or remove {'them' if missing.sum() > 1 else 'it'}")
    if len(table) and not (geom.geom_type == "Point").all():
        raise VectorError(f"{what}: GCPs must be points (single points); found {', '.join(sorted(set(map(str, geom.geom_type))))}")
    if crs:
        map_crs = parse_crs(crs, what)
    elif table.crs is None:
        raise VectorError(f"{what} has no CRS; set one on the layer or give it (crs=/--crs)")
    else:
        map_crs = CRS.from_user_input(table.crs)
    xy = np.column_stack([geom.x.to_numpy(float), geom.y.to_numpy(float)]) if len(table) else np.zeros((0, 2))
    return xy, map_crs


def _fill_heights(g: Gcps, dem, height) -> Gcps:
    """The heights of the GCPs without one (no z value) from ``dem`` (bilinear, in the DEM's CRS), else the constant
    ``height``; ``heights`` counts the sources, and an :class:`~fotogeo.errors.InputNote` states a DEM's or constant's
    use (a 3-D model then rests on heights the file did not give)."""
    z = g.ground[:, 2].copy()
    missing = ~np.isfinite(z)
    counts = {"file": int((~missing).sum()), "dem": 0, "constant": 0, "missing": int(missing.sum())}
    if missing.any() and dem is not None:
        from ..geometry.dem import Dem
        from .raster import read_dem
        d = dem if isinstance(dem, Dem) else read_dem(dem)
        if d.crs is None:
            raise InputError(f"DEM {d.path!r} has no CRS; it cannot be matched to the GCPs")
        xy = transform_points(g.crs, CRS.from_user_input(d.crs), g.ground[missing, :2])
        h = d.heights(xy)
        if not np.isfinite(h).all():
            bad = g.ids[missing][~np.isfinite(h)]
            raise InputError(f"DEM {d.path!r} does not cover GCP(s) {', '.join(bad[:10])}"
                             f"{' …' if len(bad) > 10 else ''}; use a DEM covering all GCPs or give heights")
        z[missing] = h
        counts.update(dem=counts.pop("missing"), missing=0, dem_path=str(d.path))
        source = f"the DEM {str(d.path)!r} (bilinear)"
    elif missing.any() and height is not None:
        z[missing] = float(height)
        counts.update(constant=counts.pop("missing"), missing=0)
        source = f"the constant height {float(height):g}"
    if missing.any() and counts["missing"] == 0:
        warnings.warn(f"heights of {int(missing.sum())} of {len(z)} GCPs (those without a z value) taken from "
                      f"{source}", InputNote, stacklevel=4)
    return replace(g, ground=np.column_stack([g.ground[:, :2], z]), heights=counts)


def _validate(g: Gcps, what: str):
    bad = ~(np.isfinite(g.ground[:, :2]).all(axis=1) & np.isfinite(g.pixel).all(axis=1))
    if bad.any():
        raise InputError(f"{what}: GCP(s) {', '.join(g.ids[bad][:10])} have missing (empty, NaN) or infinite "
                         f"coordinates; fix or remove them")
    key = np.round(np.column_stack([g.ground[:, :2], g.pixel]), 6)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        dup = g.ids[first[counts > 1]]
        raise InputError(f"{what}: duplicated GCP(s) {', '.join(dup[:10])}; remove the copies")
    dup_ids = sorted(duplicate_ids(g.ids))
    if dup_ids:
        raise InputError(f"{what}: GCP id(s) {', '.join(dup_ids[:10])} are used more than once")


#: the share of GCPs outside the image (of at least :data:`FEW_OUTSIDE` + 1) above which they are refused, not skipped
MOST_OUTSIDE = 0.5
#: GCPs outside the image that are skipped whatever their share (a typo or two, a scene cropped by its vendor)
FEW_OUTSIDE = 2


def _refuse_another_size(pixel, out, width: int, height: int, what: str, reason: str) -> None:
    """Refuse GCPs most of which lie outside the image and whose pixels span more than the image across and down:
    coordinates measured on a copy of another size (a 2x enlargement puts about three quarters of them outside) or
    on another image, where the few left inside would give a plausible wrong model. A few outside stay skipped
    (:func:`skip_outside`), and so do many beyond one edge only (a scene cut along it)."""
    scale = another_size(pixel, out, width, height)
    if scale is None:
        return
    n_out, n = int(out.sum()), len(out)
    lo, hi = pixel.min(axis=0), pixel.max(axis=0)
    size = f", about {scale:.2g}x the image's size" if scale > 1 else ""
    raise InputError(f"{n_out} of {n} GCP(s) of {what} lie {reason}: their pixels span col {lo[0]:.0f}..{hi[0]:.0f}, "
                     f"row {lo[1]:.0f}..{hi[1]:.0f}{size}; the col/row were likely measured on a copy of another "
                     f"size (resized, cropped) or on another image — measure them on this image ({width}x{height} "
                     f"px) or scale them to it")


def another_size(pixel, out, width: int, height: int):
    """The size, as a factor of this image's, of the copy the GCP pixels ``(N, 2)`` span when most of them (``out``:
    the mask of those outside) lie outside and they span more than the image across and down (the rule of
    :func:`_refuse_another_size`): ``max(col_max / width, row_max / height)``; ``None`` when the rule does not
    apply."""
    pixel, out = np.asarray(pixel, float).reshape(-1, 2), np.asarray(out, bool)
    n_out, n = int(out.sum()), len(out)
    lo, hi = pixel.min(axis=0), pixel.max(axis=0)
    if n_out <= FEW_OUTSIDE or n_out <= MOST_OUTSIDE * n or not (hi - lo > (width, height)).all():
        return None
    return float(max(hi[0] / width, hi[1] / height))


def outside_image(pixel, width: int, height: int) -> np.ndarray:
    """Boolean mask of the pixel positions ``(N, 2)`` (col, row; corner convention) outside the ``width`` x
    ``height`` image: not :func:`~fotogeo.image_extent.on_image` (edges included), the rule the QGIS picker's
    click guard applies too."""
    pixel = np.asarray(pixel, float).reshape(-1, 2)
    return ~on_image(pixel[:, 0], pixel[:, 1], width, height)


def inside_image(g: Gcps, width: int, height: int, what: str, needed: int = 1, needed_by: str = "the model",
                 span: bool = True):
    """``(kept, skipped)``: the GCPs whose image position lies inside the ``width`` x ``height`` image, and one
    record ``{"id", "col", "row", "reason"}`` per GCP left out — the one policy of every tool fitting to GCPs
    (:func:`skip_outside`)."""
    keep, skipped = skip_outside(g.ids, g.pixel, g.role, width, height, what, needed, needed_by, g.source,
                                 span=span)
    return (g, []) if not skipped else (g.subset(keep), skipped)


def skip_outside(ids, pixel, roles, width: int, height: int, what: str, needed: int = 1,
                 needed_by: str = "the model", source: str = "", points=None, span=True):
    """``(keep mask, skipped records)`` of GCP measurements ``ids`` at ``pixel`` (``roles``: "control",
    "check", ...) on a ``width`` x ``height`` image: the one rule of orient, rpc-bias, compare-models and
    triangulate (whose ids name the frame too, and whose ``points`` name the ground point of each measurement:
    one point measured in several frames counts once against ``needed``; None: one point per measurement).

    A GCP whose pixel lies outside the raster is almost always a typo in col/row or a GCP of another image
    (or of the uncropped scene): it is skipped with one :class:`~fotogeo.errors.FotogeoWarning` naming each id
    and pixel, and the rest is fitted. When the skipping leaves fewer than ``needed`` control points
    (``needed_by`` names what needs them; too few in the file as well is the model's own error), or none at all,
    the GCPs are refused by an :class:`InputError` naming the skipped ones and the likely fix; so are most of
    them outside, spanning more than the image (:func:`_refuse_another_size`) unless ``span`` is false (a caller
    whose fit tells a copy of another size from a crop, :mod:`fotogeo.orientation.copy_reading`; a mask, one per
    measurement: the rule looks at those where it is true, e.g. every frame but those the fit confirms a crop of
    the image their GCPs were measured on); for a ``.points``
    ``source`` it explains the file's source-coordinate convention, the usual cause when most points fall
    outside: an unreferenced raster's points have ``sourceY = -row`` (y up), so positive ``sourceY`` values put
    them above the image.
    """
    ids, pixel, roles = np.asarray(ids).astype(str), np.asarray(pixel, float).reshape(-1, 2), np.asarray(roles)
    out = outside_image(pixel, width, height)
    if not out.any():
        return ~out, []
    reason = outside_reason(width, height)
    skipped = [{"id": str(i), "col": float(c), "row": float(r), "reason": reason}
               for i, (c, r) in zip(ids[out], pixel[out])]

    def named(most):
        return (", ".join(f"{s['id']} (col {s['col']:.1f}, row {s['row']:.1f})" for s in skipped[:most])
                + (f" and {len(skipped) - most} more" if len(skipped) > most else ""))

    points = ids if points is None else np.asarray(points).astype(str)
    control = roles == "control"
    n_kept, n_control = int((~out).sum()), len(set(points[~out & control]))
    if n_kept and (n_control >= needed or len(set(points[control])) < needed):  # too few anyway: the model says
        ruled = np.broadcast_to(np.asarray(span, bool), out.shape)
        if ruled.any():
            _refuse_another_size(pixel[ruled], out[ruled], width, height, what, reason)
        warnings.warn(f"{len(skipped)} GCP(s) of {what} lie {reason} and are skipped, the other "
                      f"{_measurements(n_kept, len(set(points[~out])))} used: {named(10)} (a typo in col/row, or a "
                      f"GCP of another image?)", FotogeoWarning, stacklevel=4)
        return ~out, skipped
    head = (f"GCP(s) {named(5)} of {what} lie {reason}: {n_control} control point(s) remain"
            f"{_measured_in(int((~out & control).sum()), n_control)}, {needed_by} needs {needed}")
    if not str(source).lower().endswith(".points"):
        raise InputError(f"{head}; check the col/row fields (corner convention) and that the GCPs were measured "
                         f"on this image")
    if (pixel[out, 1] < 0).all() and (pixel[out, 1] >= -height).all() and (pixel[out, 0] >= 0).all():
        raise InputError(f"{head}. Their rows come out negative because the file's sourceY values are positive. "
                         f"For an unreferenced raster QGIS writes sourceY = -row (y up from the top-left corner), "
                         f"so this file uses the opposite sign: negate its sourceY column, or, if the points were "
                         f"measured on a georeferenced copy of the image, give that raster (raster=/--raster)")
    raise InputError(f"{head}. A .points file holds sourceX = col, sourceY = -row for an unreferenced raster, "
                     f"or the raster's map coordinates for a georeferenced one; check that the file was measured "
                     f"on this image (and on its georeferenced or unreferenced version as used here)")


def _measurements(n_measurements: int, n_points: int) -> str:
    """``"5"`` when every point is measured once, else ``"5 measurements of 2 points"``."""
    return str(n_measurements) if n_measurements == n_points else f"{n_measurements} measurements of {n_points} points"


def _measured_in(n_measurements: int, n_points: int) -> str:
    """`` (measured 5 times)`` after a count of points measured more often than once, else nothing."""
    return "" if n_measurements == n_points else f" (measured {n_measurements} times)"
