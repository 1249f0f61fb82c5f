"""The run of ``fotogeo dsm --rpc`` (:mod:`.rpc_pairs` says what each pair goes through).

Pairs: two images make one pair; more are chosen as frames are (:mod:`fotogeo.stereo.pairs`), each image's
"centre" a point 700 km up its line of sight at the scene centre (so the base-to-height ratio is that of the
views). The grid: ``--bounds``, else the union of the pairs' overlaps (their footprints on the plane of the tie
points' median height); the default cell twice the left images' ground sample distance.
"""
from __future__ import annotations


import numpy as np

from ...errors import InputError
from ...io.raster import AtomicOutputs
from ...stereo.pairs import Limits, choose_pairs, overlap_polygon
from ..common.checks import check_output_grid
from ..ortho.crs_rule import map_crs
from ..ortho.inputs import terrain
from . import matching, plan
from . import rpc_dem
from . import rpc_pairs as rp
from .inputs import SourceImage, distinct_images, read_pairs
from .outputs import SPECKLE_CELLS, NoHeight, Products
from .refusal import Attempt

#: the distance up the line of sight standing for a satellite's position in the pair choice (m)
ORBIT = 700_000.0


def _views(ims, z):
    """``(centres, axes, footprints)`` of RPC images for :func:`choose_pairs` (module docstring): the centres and
    axes Earth-centred (:func:`fotogeo.crs.geocentric`), so that a ``--crs`` far from the scene, whose scale and
    planimetry unlike the heights' metres would bend the lines of sight, leaves the pair's measures as they are;
    the footprints in the map CRS."""
    from ...crs import geocentric
    centres, axes, fps = [], [], []
    for im in ims:
        c = np.array([[im.width / 2, im.height / 2]] * 2)  # two points: pyproj's path for arrays, not scalars
        lo, hi = geocentric(im.model.crs, [im.model.inverse(c, z)[0], im.model.inverse(c, z + 1000.0)[0]])
        up = (hi - lo) / np.linalg.norm(hi - lo)
        centres.append(lo + ORBIT * up)
        axes.append(-up)
        fps.append(plan.footprint(im, z))
    return centres, axes, fps


def _choose(ims, names, zlo, zhi, pairs, attempt=None) -> list:
    """The pairs, measured at the height of the RPCs' range where the images overlap most (a small scene may
    overlap at its own height only); given to ``attempt`` (:class:`.refusal.Attempt`) before a refusal."""
    from ...crs import geocentric
    given = read_pairs(pairs, names)
    best = None
    for z in np.linspace(zlo, zhi, 13):
        centres, axes, fps = _views(ims, z)
        choices = choose_pairs(centres, axes, fps, Limits(min_base_height=0.05), given=given,
                               local=lambda P: geocentric(ims[0].model.crs, P))
        score = sum(p.overlap for p in choices)
        if best is None or score > best[0]:
            best = (score, choices)
    choices = best[1]
    if attempt is not None:
        attempt.choices = choices
    if not any(p.kept for p in choices):
        best = max(choices, key=lambda p: p.overlap)
        lost = (_far_apart(ims, best.i, best.j) or _lost_offset(ims, best.i, best.j)
                if best.reason.startswith("overlap") else "")
        raise InputError(f"no stereo pair among the images: {names[best.i]} and {names[best.j]} (the best "
                         f"overlapping): {best.reason}; " + (lost or "give images of the same ground seen from "
                                                                       "different angles"))
    return choices


def _far_apart(ims, i: int, j: int) -> str:
    """The refusal's cause when images ``i`` and ``j`` show different places, "" otherwise: the ground their RPCs
    are valid for (``LONG_OFF ± LONG_SCALE``, ``LAT_OFF ± LAT_SCALE``, the whole product's) does not overlap, so no
    place in a product could make them overlap; each footprint named by its centre (the image's centre at
    ``HEIGHT_OFF``) and their distance on a sphere of 6371 km."""
    r = [ims[k].rpc.rpc for k in (i, j)]
    if (abs(r[0].long_off - r[1].long_off) <= r[0].long_scale + r[1].long_scale
            and abs(r[0].lat_off - r[1].lat_off) <= r[0].lat_scale + r[1].lat_scale):
        return ""
    c = []
    for k, rk in zip((i, j), r):
        px = np.array([[ims[k].width / 2, ims[k].height / 2]] * 2)
        c.append(np.asarray(rk.to_model().inverse(px, np.full(2, rk.height_off)), float)[0, :2])
    (lo1, la1), (lo2, la2) = np.radians(c[0]), np.radians(c[1])
    km = 6371.0 * 2 * np.arcsin(np.sqrt(np.sin((la2 - la1) / 2) ** 2
                                        + np.cos(la1) * np.cos(la2) * np.sin((lo2 - lo1) / 2) ** 2))
    return (f"their footprints do not overlap: {ims[i].name!r} is centred at lon {c[0][0]:.4f}, lat {c[0][1]:.4f} "
            f"and {ims[j].name!r} at lon {c[1][0]:.4f}, lat {c[1][1]:.4f}, {km:.0f} km apart (even their whole "
            f"products' RPCs cover no common ground): give images of the same ground seen from different angles")


def _lost_offset(ims, i: int, j: int) -> str:
    """The likely cause of a pair of RPC images that do not overlap, "" when there is none to name: one of them
    looks cut out of the product its RPC describes without its place (:func:`~fotogeo.io.rpc_place.product_rpc`),
    so its pixel (0, 0) is read as the product's first (:mod:`fotogeo.io.rpc_image`); the other's place, when it
    carries one, is named as what was expected. Every source :func:`~fotogeo.io.rpc_image.image_rpc` reads is
    checked: an RPC file given or beside the image (.geom, .RPB, _RPC.TXT, RPC XML), read by fotogeo or by GDAL, and
    GeoTIFF RPC tags; only the fix differs (a window geotransform for a file, the RPC of its own pixels for tags,
    which the reader keeps without a window)."""
    from ...io.rpc_place import product_rpc
    found = {k: product_rpc(ims[k].path, ims[k].width, ims[k].height, ims[k].rpc) for k in (i, j)}
    for k, o in ((i, j), (j, i)):
        if found[k] is None:
            continue
        info, source = found[k]
        r, im = info.rpc, ims[k]
        w = ims[o].rpc.product_window
        there = (f", while {ims[o].name!r} carries its place in that product (its pixel (0, 0) at ({w[1]:g}, {w[3]:g}))"
                 if w is not None else "")
        what = f"its RPC file {source!r}" if source else "its GeoTIFF RPC tags"
        fix = (f"give it a geotransform without a CRS putting its pixel (0, 0) at its column and row in the product "
               f"(gdal_edit.py -a_ullr COL ROW COL+{im.width} ROW+{im.height}), or the RPC of its own pixels" if source
               else "give it the RPC of its own pixels (gdal_translate -srcwin from the product moves the tags into "
                    "the cut)")
        return (f"{im.name!r} is {im.width} x {im.height} pixels without a geotransform, so its pixel (0, 0) is read "
                f"as the first pixel of the product {what} describe{'s' if source else ''} (about "
                f"{2 * r.samp_scale:.0f} x {2 * r.line_scale:.0f} pixels){there}: if it was cut out of that product "
                f"it lost its place; {fix}")
    return ""


def _check_places(name: str, pair, size: float, large: bool) -> None:
    """Refuse the pair ``name`` when an image of it looks :func:`~fotogeo.io.rpc_place.placeless` and its relative
    pointing error (``size`` px, ``large`` above :data:`~.rpc_pairs.LARGE_POINTING_PX`) is large; warn when it only
    looks so."""
    from ...io.rpc_place import placeless
    lost = [f"{im.name!r} ({why})" for im in pair for why in [placeless(im.path, im.width, im.height, im.rpc)] if why]
    if not lost:
        return
    many = len(lost) > 1
    where = (f"pair {name}: {' and '.join(lost)} {'are' if many else 'is'} read at the first pixel of the "
             f"product {'their RPCs describe' if many else 'its RPC describes'}")
    fix = (f"cut {'them' if many else 'it'} again from the product with gdal_translate -srcwin COL ROW W H (GDAL "
           f"moves the RPC into the cut), or beside an OSSIM .geom without RPC tags give {'each' if many else 'it'} "
           f"a CRS-less geotransform at its place (gdal_edit.py -a_ullr COL ROW COL+W ROW+H), or the RPC of its "
           f"own pixels")
    if large:
        raise InputError(f"{where}, and the pair's RPCs disagree by {size:.0f} px after matching "
                         f"(vendor RPCs: a few): cut-outs that lost their place, whose DSM would lie at the "
                         f"product's corner — {fix}")
    rp.warn(f"{where}: right only if {'they are' if many else 'it is'} that corner of the product; a cut-out "
            f"from elsewhere comes out at the product's corner with wrong heights — {fix}")


def _dem_heights(dem, dem_heights, geoid, crs, ims) -> tuple:
    """``(height source, low, high, notes)``: the DEM read in the RPCs' (ellipsoidal) reference and its range
    (:func:`.plan.dem_range`, a geoid's undulations added) padded by 10 % and 30 m."""
    source, ref, notes = terrain(dem, None, crs, ims, dem_heights=dem_heights, geoid=geoid)
    zlo, zhi = plan.dem_range(source, ims)
    pad = 0.1 * (zhi - zlo) + 30.0
    return source, zlo - pad, zhi + pad, notes


def _pair_setup(p, ims, sources, zlo, zhi, dem) -> dict:
    """The pointing correction and the pair's height range (:func:`.rpc_pairs.pointing`: the range of the tie
    points' heights their neighbours support, widened by half the span of their bulk and 30 m,
    :func:`.plan.supported_range`), with a DEM (``dem``: ``(path, height source)``) its guide of the tiles
    (:mod:`.rpc_dem`) and the range the guide gives."""
    a, b = ims[p.i], ims[p.j]
    pt = rp.pointing(a.model, b.model, (sources[p.i], sources[p.j]), zlo, zhi)
    name = f"{a.name}-{b.name}"
    entry = {"tie_points": pt["n"], "relative_pointing_px": [round(float(v), 3) for v in pt["tau"]],
             "epipolar_residual_px": {"before": round(pt["before_px"], 3), "after": round(pt["after_px"], 3)},
             "height_per_px_along_epipolar_m": round(pt["m_per_px"], 3),
             # an along-line error as large as the across-line one measured: the heights' unseen shift (no warning:
             # ventoux's ordinary Pleiades pair gives 6.9 m, more than the rendered pair's 3.2 m for a true 4.2 m)
             "height_shift_if_along_as_across_m": round(float(np.hypot(*pt["tau"]) * pt["m_per_px"]), 2)}
    z0, z1 = plan.supported_range(pt["p1"], pt["z"], 0.5, 30.0)
    tie = (max(zlo, z0), min(zhi, z1))
    guide = None
    if dem is not None:
        guide, said = rpc_dem.pair_guide(p, name, ims, pt, dem[1], (zlo, zhi))
        if said:
            rp.warn(f"DEM {str(dem[0])!r} (--dem): " + "; ".join(said))
        tie = tie if guide is None else guide.pair_range(tie, (zlo, zhi))
    entry["relative_pointing_large"] = bool(np.hypot(*pt["tau"]) > rp.LARGE_POINTING_PX)
    _check_places(name, (a, b), float(np.hypot(*pt["tau"])), entry["relative_pointing_large"])
    rp.warn(rp.pointing_warning(name, pt, dem is not None))
    return {"tau": pt["tau"], "zlo": float(tie[0]), "zhi": float(tie[1]), "entry": entry,
            "zmed": float(np.median(pt["z"])), "dem": guide}


def _no_vertical_part(crs) -> None:
    """Refuse a ``--crs`` with a vertical part: an RPC's heights are above the ellipsoid, and the DSM keeps them so
    (its CRS is the horizontal part); EPSG:32631+5773 gave ellipsoidal heights under a plain EPSG:32631 without a
    word, 50 m from the EGM96 heights asked for at Ventoux."""
    from ...crs import parse_crs
    c = parse_crs(crs, "--crs")
    if c.is_compound:
        raise InputError(f"crs {crs!r} has a vertical part ({c.sub_crs_list[-1].name}), but the heights of RPC "
                         f"images are above the ellipsoid and the DSM keeps them so: give the horizontal CRS alone "
                         f"({c.sub_crs_list[0].name}) and convert the heights afterwards if needed", option="crs")


def rpc_images(images, crs, dem) -> tuple:
    """``(OrthoImage list, map CRS, rule)``: each image's RPC wherever it is (:func:`fotogeo.io.rpc_image.image_rpc`:
    GDAL RPC metadata, else a .geom/.RPB/_RPC.TXT/XML beside it, moved into a crop's pixels) in the map CRS of
    ``ortho``'s rule (:func:`~fotogeo.tools.ortho.crs_rule.map_crs`; else the UTM zone of the first image's RPC)."""
    from ...crs import utm_crs_for
    from ...geometry.lonlat_model import LonLatModel
    from ...geometry.vertical import as_pyproj
    from ...io.block import frame_key
    from ...io.raster import open_raster
    from ...io.rpc_image import image_rpc
    from ..ortho.inputs import OrthoImage
    found = [image_rpc(p) for p in images]  # read once: the run's steps take each image's from its OrthoImage
    r0 = found[0].rpc
    map_c, rule = utm_crs_for(r0.long_off, r0.lat_off), "the UTM zone of the image centre (RPC)"
    given = crs and str(crs).strip().lower() != "auto"
    if given:
        _no_vertical_part(crs)
    if given or dem is not None:
        try:
            map_c, rule = map_crs(crs, dem, None, list(images), True, rpc_of=lambda p: found[0],  # its first's
                                  crs_option="crs")
            map_c = as_pyproj(map_c)  # a DEM's CRS comes as rasterio's; the DSM's steps ask pyproj's
        except InputError:
            if given:
                raise  # a DEM in geographic coordinates: the UTM zone stays
    out = []
    for p, f in zip(images, found):
        info = open_raster(p, "image")
        out.append(OrthoImage(str(p), frame_key(p), LonLatModel(f.rpc.to_model(), map_c), "rpc", info.width,
                              info.height, "ellipsoid", rpc=f))
    return out, map_c, rule


def _rpc_sources(ims) -> list:
    """Where each image's RPC was read (:func:`fotogeo.io.rpc_image.source_label`), for the console and report."""
    from ...io.rpc_image import source_label
    return [source_label(im.path, im.rpc) for im in ims]


def rpc_dsm(images, output, *, dem, dem_heights, geoid=None, pairs, resolution, crs, bounds, refine, fill,
            point_cloud, report, overwrite, prog, t0, dask=(None, None), bands=None, style=None,
            attempt=None) -> dict:
    """``fotogeo dsm --rpc`` (module docstring); the report as :func:`fotogeo.tools.dsm.dsm`'s; ``dask``:
    ``(scheduler, workers)`` of the tiles (:func:`.matching.match_tiles`); ``style`` the QGIS style's path;
    ``attempt`` the :class:`.refusal.Attempt` the run fills for the report of a refusal."""
    ims, map_c, rule = rpc_images(images, crs, dem)
    names = [im.name for im in ims]
    attempt = attempt or Attempt()
    attempt.names, attempt.crs, attempt.crs_rule = names, map_c, rule
    zlo, zhi = rp.rpc_height_range(ims)
    distinct_images(ims, (zlo, zhi))
    guide, ref = None, "ellipsoid"
    notes = ["heights above the ellipsoid (RPC)", "planimetry halfway between the pair's RPC geolocations"]
    origins = _rpc_sources(ims)
    notes.append("RPCs: " + "; ".join(f"{n} from {o}" for n, o in zip(names, origins)))
    if dem is not None:  # the RPCs' range with the DEM's: a DEM in another vertical reference must not cut it
        source, dlo, dhi, more = _dem_heights(dem, dem_heights, geoid, map_c, ims)
        zlo, zhi, guide = min(zlo, dlo), max(zhi, dhi), (dem, source)
        notes += more + ["height range from the DEM and the tie points"]
    choices = _choose(ims, names, zlo, zhi, pairs, attempt)
    for p in choices:
        p.extra["rpc_sources"] = [origins[p.i], origins[p.j]]
    sources = [SourceImage(im.path, bands) for im in ims]
    kept = [p for p in choices if p.kept]
    setups = {}
    for p in kept:
        setups[(p.i, p.j)] = s = _pair_setup(p, ims, sources, zlo, zhi, guide)
        p.extra.update(s["entry"], height_range=[round(s["zlo"], 2), round(s["zhi"], 2)])
    prog(0.1, "pointing corrected")
    return _match_and_write(ims, sources, names, choices, kept, setups, output, map_c, rule, ref, notes, zlo, zhi,
                            resolution=resolution, bounds=bounds, refine=refine, fill=fill, point_cloud=point_cloud,
                            report=report, overwrite=overwrite, prog=prog, t0=t0, dask=dask, style=style)


def _gsd(im, z) -> float:
    c = np.array([[im.width / 2, im.height / 2], [im.width / 2 + 1, im.height / 2], [im.width / 2, im.height / 2 + 1]])
    g = im.model.inverse(c, z)[:, :2]
    u, v = g[1] - g[0], g[2] - g[0]
    return float(np.sqrt(abs(u[0] * v[1] - u[1] * v[0])))


def _empty(kept, names, setups) -> NoHeight:
    """The refusal when no cell got a height; pairs whose relative pointing error was large named (an RPC that does
    not describe its image's pixels: the image rotated, flipped or resampled after it, matches nothing)."""
    large = [f"{names[p.i]}-{names[p.j]} ({np.hypot(*setups[(p.i, p.j)]['tau']):.0f} px)" for p in kept
             if setups[(p.i, p.j)]["entry"]["relative_pointing_large"]]
    why = "the images may be textureless or cloud-covered"
    if large:
        why += (f", or their RPCs may not describe their pixels: the relative pointing error was large for "
                f"{', '.join(large)} (an image rotated, flipped, resampled or cut after its RPC was made?)")
    return NoHeight("no height was matched in any pair", why)


def _match_and_write(ims, sources, names, choices, kept, setups, output, crs, rule, ref, notes, zlo, zhi, *,
                     resolution, bounds, refine, fill, point_cloud, report, overwrite, prog, t0, dask,
                     style=None) -> dict:
    gsd = float(np.median([_gsd(ims[p.i], 0.5 * (zlo + zhi)) for p in kept]))
    res = float(resolution or float(f"{2 * gsd:.2g}"))
    polys = []
    for p in kept:  # the pair's overlap: the two footprints on the plane of its tie points' median height
        z = setups[(p.i, p.j)]["zmed"]
        polys.append(overlap_polygon(plan.footprint(ims[p.i], z), plan.footprint(ims[p.j], z)))
        p.extra["overlap_polygon"] = polys[-1]
    grid = plan.grid_for(polys, res, bounds, SPECKLE_CELLS)
    check_output_grid(output, grid.width, grid.height, bands=4, dtype="float32",
                      source_pixels=sum(im.width * im.height for im in ims), resolution=res,
                      what=f"the DSM {str(output)!r}")
    timings = {}
    matches = [rp.RpcPairMatch(p, f"{names[p.i]}-{names[p.j]}", (ims[p.i].model, ims[p.j].model),
                               (sources[p.i], sources[p.j]), (setups[(p.i, p.j)]["zlo"], setups[(p.i, p.j)]["zhi"]),
                               setups[(p.i, p.j)]["tau"], refine, dem=setups[(p.i, p.j)]["dem"]) for p in kept]
    seen = lambda g, h: plan.stereo_mask(g, h, kept, ims)  # noqa: E731
    with AtomicOutputs(overwrite) as out:
        products = Products(out, output, grid, crs, fill=fill, point_cloud=point_cloud, report=report, seen=seen,
                            height_reference=ref, style=style, gsd=gsd)
        try:
            matching.match_tiles(grid, matches, products, prog.stage(0.1, 0.95, "matching"), timings, *dask)
            for m in matches:
                m.report()
            rep = products.finish(choices, names, rule, ref, notes, zlo, zhi, t0, timings, _empty(kept, names, setups))
        finally:
            products.close()
        out.commit()
    products.warn_coverage()
    prog(1.0, "done")
    return rep
