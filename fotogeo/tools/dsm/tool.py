"""``fotogeo dsm``: a surface model from oriented images (the run; the package docstring says what it does)."""
from __future__ import annotations

import functools
import time
import warnings
from pathlib import Path

import numpy as np

from ...errors import FotogeoWarning, InputError, ModelError, OutputError
from ...geometry.vertical import as_pyproj
from ...io.output_checks import GEOTIFF_SUFFIXES, check_outputs
from ...io.qml import check_style, check_styles_no_input, dsm_style_path, warn_earlier_style
from ...io.raster import AtomicOutputs
from ...options.dsm import DSM
from ...progress import as_progress
from ...stereo.pairs import Limits, choose_pairs
from ...stereo.rectify import rectify
from ..common.boundary import tool
from ..common.checks import check_output_grid
from ..ortho.crs_rule import map_crs
from ..ortho.inputs import image_models, no_sfm_frame_with_rpc, terrain
from . import dem_guide, frames, local, matching, plan, refill
from .inputs import (SourceImage, centres_in_area_of_use, check_crs, distinct_images, orientation_files,
                     orientation_inputs, parse_bounds, read_pairs)
from .outputs import SPECKLE_CELLS, NoHeight, Products, with_dem_vertical
from ..common.refusal import reporting_refusal
from .refusal import Attempt

#: a pair whose sparse matches' median row difference exceeds this (rectified px) is left out: its orientation
#: does not fit the images well enough for matching along rows
MAX_EPIPOLAR_PX = 2.0
#: below this share of its overlap matched, a pair is named in a warning
LOW_DENSITY = 0.5
#: above this share of the DSM's heights from a single pair, the pairs left out for their views are named
THIN = 0.5
#: a DEM whose heights at the sparse matches differ from theirs by more than this in the median (m; more than the
#: geoid departs from the ellipsoid anywhere) is refused (:func:`_dem_fits_orientation`)
DEM_MISFIT_M = 150.0
#: metres per foot (international, US survey): a DEM this many times the matches' heights is named as in feet
FEET = (0.3048, 1200.0 / 3937.0)


@tool(DSM, rasters={"dem": None, "geoid": None}, outputs=("output", "point_cloud", "report"))
def dsm(images, output, *, camera=None, eo=None, sfm_frame: str = "auto", orientation=None, rpc: bool = False,
        dem=None, dem_heights: str = "auto", geoid=None, pairs=None, resolution=None, crs="auto", bounds=None,
        refine: bool = False, fill: bool = False, fill_max_distance: float | None = None, bands=None,
        qgis_style: bool = True, scheduler=None, workers=None, point_cloud=None, report=None, overwrite: bool = False,
        progress=None) -> dict:
    """Match the oriented ``images`` pair by pair and fuse their points into the DSM ``output`` (GeoTIFF, COG
    layout: band 1 heights, 2 the number of pairs, 3 the spread of the points' heights, 4 with ``fill`` the
    filled cells, none over ``fill_max_distance`` cells from a matched one: 4 when not given; given without
    ``fill`` it is refused) and beside it, with ``qgis_style``, its QGIS style ``<name>.qml`` (band 1 in pseudocolour;
    one fotogeo did not write replaced only with ``overwrite``, :mod:`fotogeo.io.qml`); ``point_cloud`` a LAS/LAZ
    of every point, ``report`` a JSON report. Returns the report. The output tiles run as Dask tasks with
    ``scheduler`` (a running cluster) or ``workers`` (a local cluster of that many processes), else in this process
    (:mod:`.matching`)."""
    images = [str(p) for p in ([images] if isinstance(images, (str, Path)) else images)]
    prog = as_progress(progress)
    t0 = time.process_time(), time.perf_counter()
    style = dsm_style_path(output) if qgis_style else None
    if qgis_style:
        check_style(output, overwrite)
    check_outputs(((output, "DSM", GEOTIFF_SUFFIXES), (style, "QGIS style of the DSM", None),
                   (point_cloud, "point cloud", (".las", ".laz")), (report, "report", None)),
                  [*images, *orientation_inputs(orientation, camera, eo), dem, geoid,
                   pairs if isinstance(pairs, (str, Path)) else None], overwrite)
    given = {"images": images, "camera": camera, "eo": eo, "orientation": orientation, "rpc": rpc, "dem": dem,
             "geoid": geoid, "crs": crs, "pairs": pairs, "resolution": resolution, "bounds": bounds,
             "output": output}
    attempt = Attempt()  # a refusal from here on, the report's path checked, still writes the report (.refusal)
    with reporting_refusal(report, "dsm", given, attempt.entries):
        return _checked_run(images, output, given, attempt, sfm_frame=sfm_frame, dem_heights=dem_heights,
                            refine=refine, fill=fill, fill_max_distance=fill_max_distance, bands=bands,
                            qgis_style=qgis_style, scheduler=scheduler, workers=workers, point_cloud=point_cloud,
                            report=report, overwrite=overwrite, prog=prog, t0=t0, style=style)


def _checked_run(images, output, given, attempt, *, sfm_frame, dem_heights, refine, fill, fill_max_distance, bands,
                 qgis_style, scheduler, workers, point_cloud, report, overwrite, prog, t0, style) -> dict:
    """:func:`dsm` once its outputs were checked: the inputs' own checks, then the run (``given``: the inputs as
    given, the orientation files found put in it for the report)."""
    rpc, dem, geoid, crs, pairs, resolution, bounds, camera, eo, orientation = map(given.get, (
        "rpc", "dem", "geoid", "crs", "pairs", "resolution", "bounds", "camera", "eo", "orientation"))
    if len(images) < 2:
        raise InputError("a surface model needs at least two overlapping images; give two or more images",
                         option="images")  # the command line's usage error, as before
    if rpc and (camera, eo, orientation) != (None, None, None):
        named = next(k for k, v in (("orientation", orientation), ("eo", eo), ("camera", camera)) if v is not None)
        raise InputError(f"--rpc takes each image's orientation from its RPC: give either --rpc or the frames' "
                         f"orientation (--{named}), not both", option=named)
    if rpc:
        no_sfm_frame_with_rpc(sfm_frame)
    camera, eo = orientation_files(orientation, camera, eo)
    given.update(camera=camera, eo=eo)
    check_crs(crs)
    # below: the filling's reach in cells (the table's default when not given), None for no filling
    fill = (DSM["fill_max_distance"].default if fill_max_distance is None else fill_max_distance) if fill else None
    if qgis_style:
        check_styles_no_input(output, [*images, dem, geoid])
    else:  # after the outputs' checks: a run refused leaves the style with its own DSM
        warn_earlier_style(output)
    if point_cloud is not None:
        from ...io.las import check_writable
        check_writable(point_cloud)
    if rpc:
        from .rpc_tool import rpc_dsm
        return rpc_dsm(images, output, dem=dem, dem_heights=dem_heights, geoid=geoid, pairs=pairs,
                       resolution=resolution, crs=crs, bounds=parse_bounds(bounds), refine=refine, fill=fill,
                       point_cloud=point_cloud, report=report, overwrite=overwrite, prog=prog, t0=t0,
                       dask=(scheduler, workers), bands=bands, style=style, attempt=attempt)
    map_c, rule = map_crs(crs, dem, eo, images, False, camera, sfm_frame=sfm_frame, crs_option="crs")
    map_c = as_pyproj(map_c)  # a DEM's CRS comes as rasterio's (ortho's cold start); the steps ask pyproj's
    attempt.crs, attempt.crs_rule = map_c, rule
    ims = image_models(images, map_c, camera=camera, eo=eo, sfm_frame=sfm_frame)
    return _frames(ims, output, map_c, rule, dem=dem, dem_heights=dem_heights, geoid=geoid, pairs=pairs,
                   resolution=resolution, bounds=parse_bounds(bounds), refine=refine, fill=fill,
                   point_cloud=point_cloud, report=report, overwrite=overwrite, prog=prog, t0=t0,
                   dask=(scheduler, workers), bands=bands, style=style, attempt=attempt)


def _heights(ims, views, sources, dem, dem_heights, geoid, crs, features) -> tuple:
    """``(zlo, zhi, height reference, notes, DEM)`` of the terrain (plan module docstring); ``DEM`` None without
    one, else ``(height source, its fit at the nearest pair's matches or None, the padding of its range)``: its
    heights shifted by the fit's offset (:mod:`.dem_guide`)."""
    if dem is not None:
        source, ref, notes = terrain(dem, None, crs, ims, dem_heights=dem_heights, geoid=geoid)
        zlo, zhi = plan.dem_range(source, ims)
        pad = 0.1 * (zhi - zlo) + 20.0
        f = _dem_fits_orientation(dem, source, views, sources, features)
        o = 0.0 if f is None else f.offset
        said = dem_heights not in (None, "auto") or geoid is not None
        ref, why = dem_guide.heights_reference(ims, ref, f, said)
        return (zlo - pad - o, zhi + pad - o, ref, notes + ["height range from the DEM"] + why,
                (source, f, pad))
    check = functools.partial(frames.sparse_check, cache=features)
    zlo, zhi = plan.sparse_heights(views, sources, check, frames.sparse_problem, MAX_EPIPOLAR_PX, ims,
                                   Limits().min_overlap)
    pad = 0.25 * (zhi - zlo) + 10.0
    refs = {im.height_reference for im in ims} - {None}
    return zlo - pad, zhi + pad, (refs.pop() if len(refs) == 1 else None), ["height range from sparse matches"], None


def _dem_fits_orientation(dem, source, views, sources, features):
    """The DEM's :class:`.dem_guide.DemFit` at the nearest pair's sparse matches (:func:`.plan.sparse_heights`'s
    pair); refused when they differ from the heights the orientation gives those matches by more than
    ``DEM_MISFIT_M`` in the median: a DEM in feet read as metres, or a DEM or an orientation in another vertical
    datum. Its range would set the footprints' plane and the disparity search, and the run fail later for a wrong
    cause (a small overlap). None when the matches are too few or cannot be trusted (no evidence either way)."""
    i, j = plan.nearest_pair(views)
    rp = rectify(views[i], views[j], min(1.0, 1500.0 / max(max(views[i].size), 1)))
    sp = frames.sparse_check(rp, (views[i], views[j]), (sources[i], sources[j]), cache=features, ids=(i, j))
    if sp["n"] < dem_guide.DEM_MIN_MATCHES or frames.sparse_problem(sp, MAX_EPIPOLAR_PX):
        return None
    P = sp["points"][plan.plausible_heights(sp["points"][:, 2], min(views[i].centre[2], views[j].centre[2]))]
    f = dem_guide.fit(source, P)
    if f is None or abs(f.offset) <= DEM_MISFIT_M:
        return f
    from ...geometry.dem import heights_at
    h = heights_at(source, P[:, :2])
    ok = np.isfinite(h)
    h, z = h[ok], P[ok, 2]
    ratio = float(np.median(h) / np.median(z)) if np.median(z) > 0 else 0.0
    unit = next((f" ({ratio:.2f} times theirs: are the DEM's heights in feet? convert them to metres, e.g. "
                 f"gdal_calc.py -A DEM --calc=\"A*{m:.6g}\" --outfile DEM_m.tif)" for m in FEET
                 if abs(ratio * m - 1.0) < 0.03), "")
    raise InputError(
        f"DEM {str(dem)!r} (dem) does not fit the orientation: at {len(z)} sparse matches of {views[i].name!r} and "
        f"{views[j].name!r} it gives heights {np.percentile(h, 1):.0f} to {np.percentile(h, 99):.0f} (1st-99th "
        f"percentile) where the orientation puts them at {np.percentile(z, 1):.0f} to {np.percentile(z, 99):.0f}, "
        f"{f.offset:+.0f} m apart{unit}; check the DEM's vertical unit and reference and the orientation's heights",
        option="dem")


def _choose(ims, views, names, zmid, pairs, resolution=None, refused=None, memo=None, attempt=None) -> list:
    """The candidate pairs, kept or left out (plan module docstring); none kept is refused naming the best.
    ``refused``: ``{(i, j): reason}`` of pairs refused when set up, left out as well (:mod:`.refill`); ``memo``: a
    dict keeping the pairs' measures between the choices of one run (``"reasons"``: the other reasons to leave a
    pair out, ``"stretch"``: the rectified stretch of a pair left in; :func:`.plan.choice_measures`); ``attempt``:
    the run's :class:`.refusal.Attempt`, given the choice before a refusal."""
    fps = [plan.footprint(im, zmid) for im in ims]
    axes = [v.axis for v in views]
    memo = {} if memo is None else memo
    refused, reasons, stretches = refused or {}, memo.setdefault("reasons", {}), memo.setdefault("stretch", {})

    def leave_out(p):
        if (p.i, p.j) not in reasons:
            reasons[(p.i, p.j)], s = plan.choice_measures(p, views, resolution)
            if s is not None:
                stretches[(p.i, p.j)] = s
        return refused.get((p.i, p.j)) or reasons[(p.i, p.j)]

    def stretch(p):
        if (p.i, p.j) not in stretches:
            stretches[(p.i, p.j)] = plan.rectified_stretch(p, views)
        return stretches[(p.i, p.j)]
    choices = choose_pairs([v.centre for v in views], axes, fps, Limits(), given=read_pairs(pairs, names),
                           leave_out=leave_out, stretch=stretch)
    if attempt is not None:
        attempt.choices = choices
    if not any(p.kept for p in choices) and not refused:
        best = max(choices, key=lambda p: p.overlap)
        raise InputError(f"no stereo pair among the images: {names[best.i]} and {names[best.j]} (the best "
                         f"overlapping): {best.reason}; give images that overlap by at least 20 % and were taken "
                         f"from different positions")
    return choices


def _grid(kept, res, bounds, output, ims):
    """The output grid over the overlaps of the ``kept`` pairs (:func:`.plan.grid_for`), refused when too large."""
    grid = plan.grid_for([p.extra["overlap_polygon"] for p in kept], res, bounds, SPECKLE_CELLS)
    check_output_grid(output, grid.width, grid.height, bands=4, dtype="float32",
                      source_pixels=sum(im.width * im.height for im in ims), resolution=res,
                      what=f"the DSM {str(output)!r}")
    return grid


def _widen(first, added, setups, res, bounds, output, ims, names):
    """The output grid over the ``first`` choice's kept pairs and the refill's ``added`` ones (:mod:`.refill`); an
    added pair whose overlap would make it too large (:func:`_grid` refuses) is left out with that reason and its
    set-up dropped from ``setups``, so the refill never refuses a run the first choice's grid fits."""
    try:
        return _grid(first + added, res, bounds, output, ims)
    except OutputError:
        pass
    kept = list(first)
    for p in added:
        try:
            _grid(kept + [p], res, bounds, output, ims)
        except OutputError as e:
            p.kept, p.reason = False, f"its overlap would widen the output grid too far ({e})"
            setups.pop((p.i, p.j), None)
            warnings.warn(f"pair {names[p.i]}-{names[p.j]} left out: {p.reason}", FotogeoWarning, stacklevel=3)
        else:
            kept.append(p)
    return _grid(kept, res, bounds, output, ims)


def _pair_setup(p, views, sources, zlo, zhi, dem, scale, features, ims, fine=1.0) -> tuple:
    """``(rectified pair, disparity range, height range, None, sparse matches, DEM guide)`` of one kept pair (the
    matches :func:`.local.guides` that give each pixel's expected disparity, :func:`.local.expected_disparity`,
    and bound each strip's range, :func:`.local.local_range`; the :class:`.dem_guide.DemGuide` that does both where
    the DEM has heights, None without ``dem``, :func:`_heights`'s), or ``(…, reason, None, None)`` to leave it out;
    ``features`` the images' sparse features (:func:`.frames.sparse_check`'s cache); a pair :func:`.rectify`
    refuses is left out (:func:`.plan.size_reason`, ``fine`` the resolution at scale 1, naming the one that fits)."""
    try:
        rp = rectify(views[p.i], views[p.j], scale)
    except ModelError as e:
        return None, None, None, plan.size_reason(views[p.i], views[p.j], scale, fine) or str(e), None, None
    sp = frames.sparse_check(rp, (views[p.i], views[p.j]), (sources[p.i], sources[p.j]), cache=features,
                             ids=(p.i, p.j))
    p.extra.update(sparse_matches=sp["n"])
    if sp["n"] >= 8:
        p.extra.update(epipolar_residual_px={"median": float(np.median(np.abs(sp["dy"]))),
                                             "p95": float(np.percentile(np.abs(sp["dy"]), 95))},
                       ray_miss_m={"median": float(np.median(sp["miss"])),
                                   "p95": float(np.percentile(sp["miss"], 95))})
    why = frames.sparse_problem(sp, MAX_EPIPOLAR_PX)
    if why:
        return rp, None, None, why, None, None
    ceiling = min(views[p.i].centre[2], views[p.j].centre[2])
    guide = _pair_dem(p, sp, dem, ims, zlo, zhi, ceiling) if dem is not None else None
    # the DEM guides, or too few matches to go without its range; else (a DEM they disagree with or have no height
    # on) the matches' heights, as without --dem
    if dem is not None and (guide is not None or sp["n"] < dem_guide.DEM_MIN_MATCHES):
        # the run's range (the DEM's valid heights) joined with the matches' (plan.matched_heights, the RPC tie
        # points' rule): ground in a void of the DEM above or below its valid heights is searched; above it up to
        # the DEM's margin above (what stands on it), below the lower camera as the matches' range
        run = plan.with_matches(sp, (zlo, zhi), ceiling, dem_guide.DEM_MIN_MATCHES)
        reach = (run[0], max(run[1], zhi + 0.75 * max(ceiling - zhi, 0.0)))
        zlim = run if guide is None else guide.pair_range(run, reach)
        return rp, plan.disparity_bounds(rp, *zlim), zlim, None, local.guides(sp, ceiling), guide
    if sp["n"] < dem_guide.DEM_MIN_MATCHES:
        return rp, None, None, (f"only {sp['n']} sparse matches (textureless, cloud-covered or changed between "
                                f"the images?); give a coarse DEM (--dem) to bound the search"), None, None
    zlim = plan.matched_heights(sp["points"], ceiling, widen=0.5, pad=10.0)
    # the heights, not the matches' disparities: over an oblique pair the disparity of one height varies across
    # the image, and the sparse matches need not reach its edges
    return rp, plan.disparity_bounds(rp, *zlim), zlim, None, local.guides(sp, ceiling), None


def _pair_dem(p, sp, dem, ims, zlo, zhi, ceiling):
    """The pair's :class:`.dem_guide.DemGuide` (``dem`` :func:`_heights`'s ``(source, run's fit, padding)``): the
    DEM over its footprints at ``zlo`` and ``zhi``, fitted to its sparse matches (the run's fit when the pair has too
    few; with neither, unchecked: searched ± max(``DEM_UNMEASURED_M``, the run's padding), and named by
    :func:`_warn_dem`);
    None when its spread says it does not show this ground (:data:`.dem_guide.DEM_MAX_SPREAD_M`), or when the pair
    has matches but none on the DEM (a void under them: nothing checks it). The fit goes into the pair's report."""
    source, run_fit, pad = dem
    pts = sp["points"][plan.plausible_heights(sp["points"][:, 2], ceiling)] if sp["n"] else np.zeros((0, 3))
    unmeasured = run_fit or dem_guide.DemFit(0.0, 0.0, max(dem_guide.DEM_UNMEASURED_M, pad), 0)
    guide, p.extra["dem"], _ = dem_guide.pair_guide(source, pts, sp["n"], unmeasured,
                                                    plan.pair_footprints(ims, p, (zlo, zhi)))
    return guide


def _frames(ims, output, crs, rule, *, dem, dem_heights, geoid, pairs, resolution, bounds, refine, fill, point_cloud,
            report, overwrite, prog, t0, dask=(None, None), bands=None, style=None, attempt=None) -> dict:
    """The frame pipeline (package docstring); ``dask``: ``(scheduler, workers)`` of the tiles; ``bands`` the
    bands matched (:class:`.inputs.SourceImage`); ``style`` the QGIS style's path (None: none written);
    ``attempt`` the :class:`.refusal.Attempt` the run fills for the report of a refusal."""
    names = [im.name for im in ims]
    attempt = attempt or Attempt()
    attempt.names = names
    views = [frames.frame_view(im) for im in ims]
    low = min(v.centre[2] for v in views)
    distinct_images(ims, (low - 10.0, low - 100.0))  # two planes under every camera
    if rule == "given (--crs)":
        centres_in_area_of_use(views, crs)
    sources = [SourceImage(im.path, bands) for im in ims]
    features = {}
    zlo, zhi, ref, notes, heights = _heights(ims, views, sources, dem, dem_heights, geoid, crs, features)
    prog(0.05, f"heights {zlo:.1f} to {zhi:.1f}")
    memo = {}
    choose = functools.partial(_choose, ims, views, names, 0.5 * (zlo + zhi), pairs, resolution, memo=memo,
                               attempt=attempt)
    initial = choose()
    first = [p for p in initial if p.kept]
    gsd = float(np.median([p.extra["distance"] / views[p.i].focal for p in first]))
    res = float(resolution or float(f"{2 * gsd:.2g}"))
    grid = _grid(first, res, bounds, output, ims)
    timings = {}

    def set_up(p):
        prog(0.05 + 0.05 * min(1.0, len(timings) / len(first)), f"checking {names[p.i]} with {names[p.j]}")
        t = time.perf_counter()
        rp, drange, zlim, why, near, guide = _pair_setup(p, views, sources, zlo, zhi, heights,
                                                         min(1.0, 2.0 * gsd / res), features, ims, 2.0 * gsd)
        timings[f"{names[p.i]}-{names[p.j]}"] = time.perf_counter() - t
        if why:
            warnings.warn(f"pair {names[p.i]}-{names[p.j]} left out: {why}", FotogeoWarning, stacklevel=4)
            return why
        pv, ps = (views[p.i], views[p.j]), (sources[p.i], sources[p.j])
        return matching.PairMatch(p, rp, drange, zlim, pv, ps, refine, near, frames.pair_penalty(rp, pv, ps),
                                  dem=guide, noise=frames.pair_noise(ps))
    choices, setups, tried = refill.settle(lambda refused: choose(refused=refused) if refused else initial, set_up,
                                           names)
    attempt.choices = choices
    if dem is not None:
        _warn_dem(dem, [(f"{names[p.i]}-{names[p.j]}", p.extra["dem"], p.extra["sparse_matches"]) for p in tried
                        if "dem" in p.extra])
    if not setups:
        raise InputError("no pair could be matched: " + "; ".join(
            f"{names[p.i]}-{names[p.j]}: {p.reason}" for p in tried))
    added = [p for p in tried if "replaces" in p.extra and p.kept]
    if added:  # the pairs the refill chose and could set up widen the grid as the first choice's did
        grid = _widen(first, added, setups, res, bounds, output, ims, names)
    seen = lambda g, h: plan.stereo_mask(g, h, [p for p in tried if p.kept], ims)  # noqa: E731
    with AtomicOutputs(overwrite) as out:
        products = Products(out, output, grid, with_dem_vertical(crs, ref, dem), fill=fill, point_cloud=point_cloud,
                            report=report, seen=seen, height_reference=ref, style=style, gsd=gsd)
        try:
            matching.match_tiles(grid, list(setups.values()), products, prog.stage(0.1, 0.95, "matching"), timings,
                                 *dask)
            for m in setups.values():  # the pairs' entries before the report is written
                m.report(LOW_DENSITY)
            rep = products.finish(choices, names, rule, ref, notes, zlo, zhi, t0, timings, NoHeight(
                "no height was matched in any pair (" + ", ".join(f"{names[p.i]}-{names[p.j]}" for p in tried
                                                                   if p.kept) + ")",
                "the images may be textureless or cloud-covered where they overlap"))
        finally:
            products.close()
        out.commit()
    products.warn_coverage()
    _warn_thin(choices, names, rep["single_pair_share"])
    prog(1.0, "done")
    return rep


def _warn_dem(dem, fits) -> None:
    """One warning naming what the pairs' fits of the DEM ``dem`` (``(pair, report entry, sparse matches)``,
    :mod:`.dem_guide`) say: the first pair's problems, and how many pairs share them; a pair whose search the DEM
    guides unchecked (no fit measured) is a problem too."""
    said = [(name, dem_guide.problems(dem_guide.DemFit(f.get("offset_m", 0.0), f.get("nmad_m", 0.0),
                                                       f.get("margin_m", 0.0), f["matches"]), name, n,
                                      f["guides_strips"])) for name, f, n in fits]
    said = [(name, why) for name, why in said if why]
    if said:
        more = f" (and {len(said) - 1} more pair(s) alike)" if len(said) > 1 else ""
        warnings.warn(f"DEM {str(dem)!r} (--dem): " + "; ".join(said[0][1]) + more, FotogeoWarning, stacklevel=4)


def _warn_thin(choices, names, single: float) -> None:
    """Name the pairs left out because their views differ too much (:class:`~fotogeo.stereo.pairs.Limits`
    ``max_view_angle``) when more than :data:`THIN` of the heights come from one pair: nothing checks those, and
    the views left out are what would (e.g. one pair per strip of an oblique flight, strips 90 degrees apart)."""
    wide = [p for p in choices if not p.kept and p.view_angle > Limits().max_view_angle]
    if wide and single > THIN:
        listed = ", ".join(f"{names[p.i]}-{names[p.j]}" for p in wide[:6]) + (", ..." if len(wide) > 6 else "")
        warnings.warn(f"{100 * single:.0f} % of the DSM's heights come from a single pair: {len(wide)} pairs were "
                      f"left out because their views differ by more than {Limits().max_view_angle:g} degrees "
                      f"({listed}); the surface is thin there (no second pair checks it). Fly more frames per strip "
                      "or give such pairs with --pairs to match them anyway", FotogeoWarning, stacklevel=3)
