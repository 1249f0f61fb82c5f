"""Rasters beside each orthophoto of ``fotogeo ortho``, on its grid (one value per output cell, float32, NaN where
the image does not reach):

* ``<orthophoto>_sigma.tif`` (``--uncertainty``) — the predicted planimetric σ (m) of the cell's position,
  ``σ_P = √(Σ_XX + Σ_YY)`` propagated from the adjustment's covariance of the frame's orientation (and of the
  interior orientation when it was estimated) and the DEM's height σ ``--dem-sigma``
  (:mod:`fotogeo.orientation.ground_sigma`). The covariance is read from triangulate's ``report.json`` beside
  the ``--eo`` file (its ``exterior_orientation.txt``); an orientation without one is refused. Default DEM σ:
  half the DEM's cell, the rule of triangulate's automatic control
  (:func:`fotogeo.tools.triangulate.control.reference_sigmas`). A separate single-band raster rather than a band
  of the orthophoto, so that QGIS shows the orthophoto in its colours and the σ with its own pseudocolour legend
  in metres (``processing_provider/styles/uncertainty.qml``); the cell's σ is for where it is, not whether it is
  seen (occlusion leaves the orthophoto's cell nodata, not the σ).
* ``<orthophoto>_view.tif`` (``--view-bands``) — band 1 the off-nadir angle (degrees) of the line of sight from the
  cell's ground point ``P`` to the sensor, ``atan(|d_XY| / d_Z)``, band 2 the distance ``|C − P|`` (m) to a
  frame's projection centre ``C`` (NaN for an RPC image, which has no centre; both NaN for a 2-D fitted ``orient``
  model, which has no line of sight). ``d`` is
  :func:`fotogeo.geometry.occlusion.line_of_sight` (a frame's ``C − P``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from ...geometry.lattice import bilinear, lattice
from ...io.raster import geotiff_profile, ropen
from ...io.warp import windows_of
from ...io.warp_gdal import centres_to_map

SIGMA_SUFFIX, VIEW_SUFFIX = "_sigma.tif", "_view.tif"
#: cells per window of the written rasters
BLOCK = 256
#: the σ raster's image terms are computed exactly every LATTICE cells and interpolated between
#: (:meth:`CellGeometry.sigma`)
LATTICE = 8
#: largest difference (m) between the --eo file's projection centres and the report's
SAME_EO_M = 0.01


def product_paths(orthos: dict, uncertainty: bool, view_bands: bool) -> dict:
    """name → {"sigma": path, "view": path} beside each orthophoto path of ``orthos``, as asked."""
    out = {}
    for name, p in orthos.items():
        p = Path(p)
        stem = p.name[:-len(p.suffix)] if p.suffix else p.name
        out[name] = {**({"sigma": p.with_name(stem + SIGMA_SUFFIX)} if uncertainty else {}),
                     **({"view": p.with_name(stem + VIEW_SUFFIX)} if view_bands else {})}
    return out


def frame_covariances(eo, ims) -> dict:
    """name → :class:`~fotogeo.orientation.ground_sigma.FrameCovariance` of every image, from triangulate's
    ``report.json`` beside ``eo`` (module docstring); refused (one line) where there is none."""
    from ...orientation.ground_sigma import covariances_from_report
    rpc = [im.name for im in ims if im.kind != "frame"]
    if rpc or eo is None:
        raise InputError(f"uncertainty: the image(s) {', '.join(rpc[:5]) or 'given'} carry no orientation "
                         f"covariance; it comes from triangulate's adjustment of frame cameras (--eo "
                         f"exterior_orientation.txt with its report.json)", option="uncertainty")
    report = Path(eo).parent / "report.json"
    rep = _read_report(report)
    cov = covariances_from_report(rep) if rep.get("fotogeo") == "triangulate" else {}
    if not cov:
        raise InputError(f"uncertainty: --eo {str(eo)!r} carries no covariance: no triangulate report.json with "
                         f"covariances beside it (write it with fotogeo triangulate, or orthorectify without "
                         f"--uncertainty)", option="uncertainty")
    missing = [im.name for im in ims if im.name not in cov]
    if missing:
        raise InputError(f"uncertainty: {str(report)!r} has no covariance for the image(s) "
                         f"{', '.join(missing[:10])}", option="uncertainty")
    frames = {f["name"]: f for f in rep["frames"]}
    for im in ims:
        f, c = frames[im.name], im.model.projection_centre
        if np.hypot(*(np.array([f["X"], f["Y"], f["Z"]]) - c)[:2]) > SAME_EO_M or abs(f["Z"] - c[2]) > SAME_EO_M:
            raise InputError(f"uncertainty: {str(report)!r} is not the adjustment of --eo {str(eo)!r} (frame "
                             f"{im.name!r} is elsewhere there); give the exterior_orientation.txt written with it",
                             option="uncertainty")
    vague = [im.name for im in ims if not np.isfinite(cov[im.name].matrix()).all()]
    if vague:
        raise InputError(f"uncertainty: {str(report)!r} reads the orientation of {', '.join(vague[:10])} as "
                         f"undetermined (σ null in its covariance): no σ can be predicted there; orthorectify them "
                         f"without --uncertainty, or triangulate again with more control", option="uncertainty")
    return {im.name: cov[im.name] for im in ims}


def _read_report(path: Path) -> dict:
    from ...io.report import read_json
    return read_json(path, "--uncertainty: triangulate's report") if path.is_file() else {}


def dem_sigma_for(dem_sigma, heights, crs) -> tuple:
    """``(σ_h in m, rule)``: the value given, else half the DEM's cell measured in the map CRS ``crs`` (module
    docstring); a constant height needs it given."""
    if dem_sigma is not None:
        return float(dem_sigma), "given (--dem-sigma)"
    if np.isscalar(heights):
        raise InputError("--uncertainty with a constant height: give its σ (--dem-sigma, m)", option="dem_sigma")
    from ...crs import pixel_size_in
    from ...geometry.dem import underlying_dem
    from ...geometry.vertical import horizontal_crs
    d = underlying_dem(heights)[0]
    rows, cols = d.data.shape
    cell = pixel_size_in(d.transform, horizontal_crs(d.crs), crs, cols / 2, rows / 2) if d.crs is not None else \
        float(np.sqrt(abs(d.transform.a * d.transform.e - d.transform.b * d.transform.d)))
    return 0.5 * cell, f"half the DEM's cell ({cell:.3g} m)"


class CellGeometry:
    """The ground points of a window of output cells and what the products need of them (module docstring)."""

    def __init__(self, model, heights, size):
        self.model, self.heights, self.size = model, heights, size

    def points(self, transform, r0, c0, h, w):
        """``(P (N, 3), gradient (N, 2), valid (N,))`` of the window's cell centres."""
        XY = centres_to_map(transform, r0, c0, h, w)
        if np.isscalar(self.heights):
            z, g = np.full(len(XY), float(self.heights)), np.zeros((len(XY), 2))
        else:
            z, gx, gy = self.heights.heights_and_gradient(XY)
            g = np.column_stack([gx, gy])
        P = np.column_stack([XY, z])
        valid = np.isfinite(z)
        px = np.full((len(P), 2), np.nan)
        px[valid] = self.model.forward(P[valid])
        with np.errstate(invalid="ignore"):
            valid &= (px[:, 0] >= 0) & (px[:, 0] <= self.size[0]) & (px[:, 1] >= 0) & (px[:, 1] <= self.size[1])
        return P, g, valid

    def sigma(self, cov, dem_sigma: float):
        """A window function of :func:`write_cells`: σ_P (module docstring). The image terms (``J_P`` and
        ``J_q Σ_q J_qᵀ + σ_h² J_Z J_Zᵀ``, smooth over the ground) are computed exactly on a lattice of every
        :data:`LATTICE`-th cell (and the window's last row and column) and interpolated bilinearly between; the
        slope term ``B = J_P T`` and ``B⁻¹ (…) B⁻ᵀ`` per cell, with the DEM's own gradient there."""
        from ...orientation.ground_sigma import image_terms, surface_covariance
        fr = self.model.frame.eo

        def window(transform, r0, c0, h, w):
            P, g, valid = self.points(transform, r0, c0, h, w)
            out = np.full(len(P), np.nan)
            if not valid.any():
                return out[None]
            rows, cols = lattice(h, LATTICE), lattice(w, LATTICE)
            Pl = P.reshape(h, w, 3)[rows][:, cols].reshape(-1, 3)
            Pl[~np.isfinite(Pl[:, 2]), 2] = np.mean(P[valid, 2])  # lattice nodes off the DEM: the window's height
            J_P, inner = image_terms(fr.rotation_cv, fr.centre, self.model.interior, self.model.scale, Pl, cov,
                                     dem_sigma)
            terms = np.concatenate([J_P.reshape(-1, 6), inner.reshape(-1, 4)[:, [0, 1, 3]]], axis=1)
            cell = bilinear(np.moveaxis(terms.reshape(len(rows), len(cols), 9), 2, 0), rows, cols, h, w
                            ).reshape(9, -1)[:, valid].T
            S = surface_covariance(cell[:, :6].reshape(-1, 2, 3), cell[:, [6, 7, 7, 8]].reshape(-1, 2, 2), g[valid])
            out[valid] = np.sqrt(S[:, 0, 0] + S[:, 1, 1])
            return out[None]
        return window

    def view(self, transform, r0, c0, h, w):
        """A window function of :func:`write_cells`: off-nadir angle (°) and distance to the centre (m)."""
        from ...geometry.occlusion import line_of_sight
        P, _, valid = self.points(transform, r0, c0, h, w)
        out = np.full((2, len(P)), np.nan)
        if getattr(self.model, "src_dims", 3) == 2:  # a 2-D fitted model knows no line of sight
            return out
        d = line_of_sight(self.model, P[valid])
        out[0, valid] = np.degrees(np.arctan2(np.hypot(d[:, 0], d[:, 1]), d[:, 2]))
        if getattr(self.model, "projection_centre", None) is not None:
            out[1, valid] = np.linalg.norm(d, axis=1)
        return out


def write_cells(path, window_values, *, crs, transform, width: int, height: int, descriptions, units,
                progress=None, compress: str = "deflate") -> dict:
    """A float32 GeoTIFF of ``len(descriptions)`` bands on the grid, nodata NaN, filled window by window from
    ``window_values(transform, r0, c0, h, w) -> (bands, h·w)``, compressed with ``compress``
    (:mod:`fotogeo.io.compression`); returns ``{"min", "max"}`` of band 1."""
    prof = geotiff_profile(width=width, height=height, count=len(descriptions), dtype="float32", crs=crs,
                           transform=transform, nodata=float("nan"), predictor=True, compress=compress)
    lo, hi = np.inf, -np.inf
    wins = windows_of(height, width, BLOCK)
    with ropen(path, "w", **prof) as ds:
        for k, (r0, c0, h, w) in enumerate(wins):
            v = np.asarray(window_values(transform, r0, c0, h, w), np.float32).reshape(len(descriptions), h, w)
            ds.write(v, window=((r0, r0 + h), (c0, c0 + w)))
            if np.isfinite(v[0]).any():
                lo, hi = min(lo, float(np.nanmin(v[0]))), max(hi, float(np.nanmax(v[0])))
            if progress is not None:
                progress((k + 1) / len(wins), "writing " + Path(path).name)
        for b, (text, unit) in enumerate(zip(descriptions, units), start=1):
            ds.set_band_description(b, text)
            ds.set_band_unit(b, unit)
    return {"min": lo if np.isfinite(lo) else None, "max": hi if np.isfinite(hi) else None}


def write_products(out, paths: dict, im, heights, grid, crs, cov, dem_sigma, compress: str = "deflate") -> dict:
    """Write the rasters ``paths`` (:func:`product_paths`) of one image through ``out``
    (:class:`~fotogeo.io.raster.AtomicOutputs`) on its orthophoto ``grid``, compressed with ``compress``; their
    report entries."""
    cells = CellGeometry(im.model, heights, (im.width, im.height))
    grid_args = {"crs": crs, "transform": grid.transform, "width": grid.width, "height": grid.height,
                 "compress": compress}
    rep = {}
    if "sigma" in paths:
        r = write_cells(out.temp(paths["sigma"]), cells.sigma(cov, dem_sigma[0]),
                        descriptions=("planimetric sigma",), units=("m",), **grid_args)
        rep["sigma"] = {"path": str(paths["sigma"]), "min_m": r["min"], "max_m": r["max"]}
    if "view" in paths:
        r = write_cells(out.temp(paths["view"]), cells.view, descriptions=("off-nadir angle", "distance"),
                        units=("deg", "m"), **grid_args)
        rep["view"] = {"path": str(paths["view"]), "off_nadir_min_deg": r["min"], "off_nadir_max_deg": r["max"]}
    return rep
