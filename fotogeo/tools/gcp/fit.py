"""The GCP picker's quick refit (issue 14): GCPs as JSON in, residuals and prediction grids out.

:func:`fit_gcps` is what the QGIS dock calls on every change, through a long-lived worker
(``python -m fotogeo.worker --session``), so it takes and returns plain JSON types and keeps
the rasters it reads (image size, DEM, camera) in a small cache keyed by path, size and
modification time. It fits with ``orient``'s own code (:func:`fotogeo.orientation.adjustment.fit_orientation`
on the control points, :func:`fotogeo.tools.orient.tool.ground_residuals` for the map residuals), so
a row's residuals and the RMS are exactly what ``fotogeo orient`` reports for the same points.

Conventions (``orient``'s): pixels ``(col, row)`` in the corner convention; residual
``v = model(ground) − measured pixel``; ``dx_map, dy_map`` = where the model puts the measured
pixel on the ground (at the point's height) minus the GCP; RMS = ``sqrt(mean(dx² + dy²))``
per role. ``w`` is the standardised residual of a control point and ``redundancy`` its redundancy number,
from ``orient``'s blunder test (:mod:`fotogeo.orientation.blunders`: a robust start, then Baarda's (1968) test of
each point against the critical value for the fit's redundancy, with the a priori ``image_sigma`` — the click
precision — when given); a point's ``flag`` says "blunder", "suspect" (flagged where the redundancy is too low to
call it a blunder) or "not testable". Nothing is removed automatically (the user disables or fixes the point), as
``orient`` without ``--remove-blunders``.

Heights, per point: the given ``z`` (``"field"``), else bilinear from ``dem`` (``"dem"``, any
CRS; a point the DEM does not cover gets no height and says so), else ``default_height``
(``"constant"``), else none (``"none"``: 2-D models only).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ...crs import parse_crs
from ...errors import InputError, ModelError, one_line
from ...image_extent import outside_reason
from ...io.gcps import outside_image
from ...io.tables import duplicate_ids
from ...models import get_model
from ...orientation.adjustment import fit_orientation, image_residuals, select_model
from ..common.boundary import tool
from .grids import prediction_grids

ROLES = ("control", "check", "disabled")
NO_DEM_HEIGHT = "no height: the DEM does not cover this point"
_CACHE: dict = {}
_CACHE_SIZE = 8


def cached_load(kind: str, path, load, extra=""):
    """``load(path)`` once per file version (path, size, modification time) and ``extra`` key; a few kept."""
    try:
        st = os.stat(path)
    except OSError:
        return load(path)  # the loader names the missing file
    key = (kind, os.path.abspath(path), st.st_size, st.st_mtime_ns, extra)
    if key not in _CACHE:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = load(path)
    return _CACHE[key]


def _dem(path):
    from ...io.raster import read_dem
    d = cached_load("dem", path, read_dem)
    if d.crs is None:
        raise InputError(f"DEM {str(path)!r} has no CRS; it cannot be matched to the GCPs (assign one with "
                         f"gdal_edit.py -a_srs)")
    return d


def dem_sampler(dem, crs):
    """The DEM file ``dem`` as a height source at points in ``crs`` (:class:`~fotogeo.geometry.dem.DemSampler`:
    one transformer, built once per DEM version and CRS — building it costs more than a refit)."""
    from ...geometry.dem import DemSampler
    return cached_load("sampler", dem, lambda p: DemSampler(_dem(p), crs), extra=crs.to_wkt())


def grid_dem(dem, crs):
    """The DEM on a grid in the map CRS for the prediction grids (:func:`~fotogeo.tools.gcp.grids.dem_on_map_grid`)."""
    from .grids import dem_on_map_grid
    return cached_load("dem_on_map_grid", dem, lambda p: dem_on_map_grid(_dem(p), crs), extra=crs.to_wkt())


def dem_heights(dem, crs, xy) -> np.ndarray:
    """Bilinear DEM heights ``(N,)`` at map points ``xy`` in ``crs`` (NaN outside the DEM): the transform
    (always_xy) and bilinear sampling :func:`fotogeo.io.gcps.read_gcps` applies for ``orient``."""
    return np.asarray(dem_sampler(dem, crs).heights(np.asarray(xy, float).reshape(-1, 2)), float)


@tool()
def sample_heights(xy, *, crs, dem, progress=None) -> dict:
    """``{"z": [...]}``: DEM heights at map points ``xy`` (``[[x, y], ...]`` in ``crs``); null outside the DEM."""
    z = dem_heights(dem, parse_crs(crs, "the points' crs"), xy)
    return {"z": [float(v) if np.isfinite(v) else None for v in z]}


def parse_gcp_rows(gcps) -> tuple:
    """``(ids, roles, pixel (N, 2), xy (N, 2), z (N,))`` of the JSON GCPs; :class:`InputError` naming a bad one."""
    if not isinstance(gcps, (list, tuple)):
        raise InputError("gcps must be a list of {id, col, row, x, y, z, role} objects")
    ids, roles, rows = [], [], []
    for k, p in enumerate(gcps):
        gid = str(p.get("id", k + 1)) if isinstance(p, dict) else str(k + 1)
        try:
            vals = [float(p[key]) for key in ("col", "row", "x", "y")]
            z = p.get("z")
            z = np.nan if z is None else float(z)
        except (KeyError, TypeError, ValueError):
            raise InputError(f"GCP {gid}: col, row, x and y must be numbers (z a number or null)") from None
        if not np.isfinite(vals).all():
            raise InputError(f"GCP {gid}: col, row, x and y must be finite numbers")
        role = str(p.get("role", "control")).lower()
        if role not in ROLES:
            raise InputError(f"GCP {gid}: role {role!r} is not one of {', '.join(ROLES)}")
        ids.append(gid)
        roles.append(role)
        rows.append(vals + [z])
    dup = sorted(duplicate_ids(ids))
    if dup:
        raise InputError(f"GCP id(s) {', '.join(dup[:10])} are used more than once; give each GCP its own id")
    a = np.array(rows, float).reshape(-1, 5)
    return np.array(ids, dtype=object), np.array(roles, dtype=object), a[:, :2], a[:, 2:4], a[:, 4]


def _heights(xy, z, crs, dem, default_height):
    """``(z, z_source, flags)`` per point (module docstring)."""
    z = z.copy()
    source = np.where(np.isfinite(z), "field", "none").astype(object)
    flags = np.full(len(z), "", dtype=object)
    missing = ~np.isfinite(z)
    if missing.any() and dem:
        h = dem_heights(dem, crs, xy[missing])
        idx = np.flatnonzero(missing)
        z[idx] = h
        source[idx[np.isfinite(h)]] = "dem"
        flags[idx[~np.isfinite(h)]] = NO_DEM_HEIGHT
    elif missing.any() and default_height is not None:
        z[missing] = float(default_height)
        source[missing] = "constant"
    return z, source, flags


def _image_size(image, width, height):
    if image:
        from ...io.raster import open_raster
        info = cached_load("image", image, lambda p: open_raster(p, "image"))
        return info.width, info.height
    if width and height:
        return int(width), int(height)
    return None, None


def _camera(camera, size, image):
    if not camera:
        return None
    from ...io.camera import load_camera
    cam = cached_load("camera", camera, load_camera)
    if size[0]:
        from ..common.checks import check_camera_size
        check_camera_size(cam, size[0], size[1], image or "the image")
    return cam


def _needed(name: str, n_control: int, n_without_height: int) -> tuple[int, str]:
    """``(more control points needed, message)`` for model ``name`` (``auto``: the simplest candidate)."""
    cls = get_model("similarity" if name == "auto" else name)
    need = max(0, cls.min_points - n_control)
    if not need:
        return 0, ""
    what = f"{name} needs {cls.min_points} control points" + (" (similarity)" if name == "auto" else "")
    if cls.src_dims == 3 and n_without_height:
        what += f" with heights ({n_without_height} without a height)"
    return need, f"{what}: {need} more"


@dataclass
class Prepared:
    """The GCPs of one request, parsed and with their heights: what a fit and the live preview start from."""

    map_crs: object
    ids: np.ndarray
    roles: np.ndarray
    pixel: np.ndarray
    ground: np.ndarray  # (N, 3), Z NaN where no height
    z_source: np.ndarray
    flags: np.ndarray
    size: tuple
    camera: object
    use: np.ndarray  # points that enter the fit (control and check)
    outside: np.ndarray
    needed: int
    message: str


def prepare(gcps, model, *, crs, image=None, width=None, height=None, dem=None, camera=None,
            default_height=None) -> Prepared:
    """Parse the picker's GCPs, give them heights and say which are used and how many more are needed."""
    map_crs = parse_crs(crs, "the GCPs' crs")
    ids, roles, pixel, xy, z = parse_gcp_rows(gcps)
    z, z_source, flags = _heights(xy, z, map_crs, dem, default_height)
    size = _image_size(image, width, height)
    cam = _camera(camera, size, image)
    if model != "auto":
        get_model(model).options_from(camera=cam)  # names a missing camera
    outside = np.zeros(len(ids), bool)
    if size[0]:
        outside = outside_image(pixel, *size)  # orient's rule and wording; the table shows it per point
        flags[outside] = outside_reason(*size)
    three_d = model != "auto" and get_model(model).src_dims == 3
    use = (roles != "disabled") & ~outside & (np.isfinite(z) if three_d else True)
    n_no_z = int(((roles == "control") & ~np.isfinite(z)).sum())
    needed, message = _needed(model, int((use & (roles == "control")).sum()), n_no_z)
    return Prepared(map_crs, ids, roles, pixel, np.column_stack([xy, z]), z_source, flags, size, cam, use, outside,
                    needed, message)


def fit_prepared(p: Prepared, model: str, *, snooping: bool = False, image_sigma=None):
    """``(model name, OrientFit, auto's selection or None)`` of the points ``p.use`` (orient's fitting code,
    its blunder test with ``snooping``)."""
    name, selection = model, None
    u = p.use
    if model == "auto":
        name, selection = select_model(p.ground[u], p.pixel[u], p.roles[u], p.ids[u], camera=p.camera)
    fit = fit_orientation(name, p.ground[u], p.pixel[u], p.roles[u], p.ids[u], snooping=snooping, camera=p.camera,
                          image_sigma=image_sigma)
    return name, fit, selection


@tool()
def fit_gcps(gcps, model, *, crs, image=None, width=None, height=None, dem=None, camera=None,
             default_height=None, snooping: bool = True, image_sigma=None, grid: int = 25, progress=None) -> dict:
    """Fit ``model`` to the picker's GCPs; residuals per point, RMS per role and prediction grids
    (the interface is described in DESIGN.md; ``image_sigma``: the click precision in px, or None to
    estimate it). JSON types in and out."""
    p = prepare(gcps, model, crs=crs, image=image, width=width, height=height, dem=dem, camera=camera,
                default_height=default_height)
    result = _empty_result(model, p.ids, p.roles, p.ground[:, 2], p.z_source, p.flags, p.needed, p.message)
    if p.needed:
        return result
    try:
        name, fit, selection = fit_prepared(p, model, snooping=snooping, image_sigma=image_sigma)
    except (ModelError, np.linalg.LinAlgError) as e:  # degenerate points: the table says so, no error
        result.update(message=one_line(f"{model}: {e}" if isinstance(e, np.linalg.LinAlgError) else e))
        return result
    if selection is not None:
        result["model_selection"] = selection
    result["model"] = name
    _fill_points(result, fit, name, p.ground, p.pixel, p.map_crs, p.use, ~p.outside)
    result["ok"], result["message"] = True, _summary(name, result["rms"], result["points"])
    if "not testable" in result["blunder_test"]:
        result["message"] += "; " + result["blunder_test"]
    result["warnings"] = fit.warnings
    if grid:
        result["forward"], result["inverse"] = prediction_grids(
            fit.model, p.map_crs, p.ground[p.use], p.size, int(grid),
            dem=grid_dem(dem, p.map_crs) if dem else None, default_height=default_height)
    return result


def _empty_result(model, ids, roles, z, z_source, flags, needed, message) -> dict:
    nan = None
    points = [{"id": i, "role": r, "z": float(h) if np.isfinite(h) else None, "z_source": s, "dx_px": nan,
               "dy_px": nan, "residual_px": nan, "dx_map": nan, "dy_map": nan, "residual_map": nan, "w": nan,
               "redundancy": nan, "mdb_px": nan, "flag": f} for i, r, h, s, f in zip(ids, roles, z, z_source, flags)]
    rms = {"control_px": nan, "control_map": nan, "check_px": nan, "check_map": nan, "n_control": 0, "n_check": 0}
    return {"model": model, "ok": False, "message": message, "needed": int(needed), "points": points,
            "rms": rms, "forward": None, "inverse": None}


def _fill_points(result, fit, name, ground, pixel, crs, use, inside):
    """Residuals (pixels, map), w, redundancy and flags of every row: orient's numbers for the points used;
    the fitted model's prediction for disabled rows that have what the model needs."""
    from ..orient.tool import ground_residuals
    cls = get_model(name)
    has = np.isfinite(ground[:, 2]) if cls.src_dims == 3 else np.ones(len(ground), bool)
    shown = use | (inside & has)
    res = np.full((len(ground), 2), np.nan)
    res[use] = fit.residual
    other = shown & ~use
    if other.any():
        res[other] = image_residuals(fit.model, ground[other], pixel[other])
    d_map = np.full((len(ground), 2), np.nan)
    d_map[shown] = ground_residuals(fit.model, ground[shown], pixel[shown], crs)[1]
    w, red, flags = np.full(len(ground), np.nan), np.full(len(ground), np.nan), np.full(len(ground), "", object)
    w[use], red[use], flags[use] = fit.w, fit.redundancy, fit.flag
    mdb = np.full(len(ground), np.nan)
    if fit.mdb is not None:
        mdb[use] = fit.mdb
    result["blunder_test"] = fit.blunder_test
    for k, p in enumerate(result["points"]):
        p.update(dx_px=_num(res[k, 0]), dy_px=_num(res[k, 1]), residual_px=_num(np.hypot(*res[k])),
                 dx_map=_num(d_map[k, 0]), dy_map=_num(d_map[k, 1]), residual_map=_num(np.hypot(*d_map[k])),
                 w=_num(w[k]), redundancy=_num(red[k]), mdb_px=_num(mdb[k]))
        if flags[k]:
            p["flag"] = flags[k] + (f"; {p['flag']}" if p["flag"] else "")
    result["rms"] = _rms(fit.stats, d_map, fit.role, use)


def _num(v):
    return float(v) if np.isfinite(v) else None


def _rms(fit_stats, d_map, fit_role, use) -> dict:
    """RMS (pixels: orient's ``rms_xy_px``; map units) and counts per role of the points used."""
    out = {}
    for role in ("control", "check"):
        sel = np.zeros(len(d_map), bool)
        sel[np.flatnonzero(use)[fit_role == role]] = True
        n = int(sel.sum())
        out[f"{role}_px"] = fit_stats[role].get("rms_xy_px") if n else None  # orient's own number
        ok = sel & np.isfinite(d_map).all(axis=1)
        out[f"{role}_map"] = float(np.sqrt(np.mean(np.sum(d_map[ok] ** 2, axis=1)))) if ok.any() else None
        out[f"n_{role}"] = n
    return out


def _summary(name, rms, points) -> str:
    """One line for the dock's status: model, RMS, blunders."""
    text = f"{name}: control RMS {rms['control_px']:.3f} px ({rms['n_control']} points)"
    if rms["n_check"]:
        text += f", check RMS {rms['check_px']:.3f} px ({rms['n_check']})"
    for flag in ("blunder", "suspect"):
        found = [p["id"] for p in points if p["flag"].startswith(flag)]
        if found:
            text += f"; {flag} at {', '.join(found[:5])}"
    return text
