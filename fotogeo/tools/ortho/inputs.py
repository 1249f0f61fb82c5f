"""What ``fotogeo ortho`` reads: each image's ground → image model, the map CRS and the heights.

**Models** (:func:`image_models`), one per image, all taking map ``(X, Y, Z)`` → pixel (corner convention):

* frame cameras — ``--camera`` (orthority YAML, ``pinhole`` or ``brown``: triangulate's ``camera.yaml``) and
  ``--eo``: fotogeo's ``name X Y Z omega phi kappa`` lines (triangulate's ``exterior_orientation.txt``) or any
  file :func:`fotogeo.io.orientation_file.read_orientation_file` reads (OpenSfM/ODM ``reconstruction.json``,
  a COLMAP model (text or binary), orthority ``.geojson``/``.csv``; their cameras unless ``--camera``); the model is
  triangulate's :class:`~fotogeo.orientation.adjusted_frame.AdjustedFrame` (collinearity with Brown's distortion);
  images resized after the reconstruction by an exact factor take the file's camera scaled
  (:func:`fotogeo.tools.common.checks.camera_for_image`), with a note;
* RPC images (``--rpc``) — the RPC00B in the image's GDAL ``RPC`` metadata (a vendor's, or ``rpc-bias``'s
  corrected copy), in ``(lon, lat, h)``, wrapped by :class:`~fotogeo.geometry.lonlat_model.LonLatModel`;
* a fitted ``orient`` model (``--model``: orient's JSON report, one image) — used as fitted, ground → image in
  the CRS of its GCPs (:class:`FittedGroundModel`; a 2-D model ignores the heights); a model fitted image →
  ground (``*-i2g``) is refused.

**Map CRS** (:func:`fotogeo.tools.ortho.crs_rule.map_crs`, the rule ``dsm`` shares).

**Heights** (:func:`terrain`): the DEM (or a constant ``--height``), bilinear, queried in the map CRS. Its
height reference is what ``--dem-heights`` says, else what its CRS states
(:func:`fotogeo.geometry.vertical.crs_height_reference`). An RPC needs ellipsoidal heights: a DEM of geoid
heights is shifted by ``--geoid`` (undulations ``N``, ``h = H + N``) or refused; a DEM that does not state its
reference is used as ellipsoidal with a warning. Frame orientations are used in the DEM's own vertical frame
unless their file states another reference (then the same rule) or ``--geoid`` is given (it asks for ellipsoidal
heights: a geoid DEM is shifted by it, any other refused, as under an RPC).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import partial

import numpy as np

from ...crs import same_crs
from ...errors import FotogeoWarning, InputError, InputNote
from ...geometry.vertical import ShiftedHeights, as_pyproj, horizontal_crs
from ...io.block import frame_key, match_keys, unmatched_reasons
from ...io.camera import exterior_orientation_crs
from ...io.orientation_file import cameras_from_camera_file
from ...io.raster import open_raster, read_dem, stated_height_reference
from ..common.checks import camera_for_image, distinct_files


@dataclass(frozen=True)
class OrthoImage:
    """One image to orthorectify: its path, name (file stem), ground → image model and size."""
    path: str
    name: str
    model: object
    kind: str  # "frame" or "rpc"
    width: int
    height: int
    height_reference: str | None = None  # what the orientation states for its Z (frames), "ellipsoid" for RPC
    count: int | None = None  # the file's bands and pixel type, when its reader opened it (else plan_grid does)
    dtype: str | None = None
    rpc: object = None  # the ImageRpc read (RPC images: fotogeo.io.rpc_image), so that no step reads it again


class FittedGroundModel:
    """A fitted ``orient`` model (ground → image, :mod:`fotogeo.models`) taking map ``(X, Y, Z)``: a 2-D one sees XY."""

    def __init__(self, model):
        self.model, self.src_dims = model, model.src_dims

    def forward(self, XYZ) -> np.ndarray:
        return self.model.forward(np.asarray(XYZ, np.float64)[:, :self.src_dims])

    def inverse(self, pixel, heights=None, **kw) -> np.ndarray:
        return self.model.inverse(pixel, heights, **kw) if self.src_dims == 3 else self.model.inverse(pixel)


def read_fitted_model(path) -> tuple:
    """``(model, CRS text)`` of orient's JSON report ``path``; anything else, or an image → ground model, refused."""
    from ...io.report import read_json
    from ...models.base import model_from_dict
    rep = read_json(path, "--model")
    if rep.get("fotogeo") != "orient" or not isinstance(rep.get("model"), dict) or not rep.get("crs"):
        raise InputError(f"model {str(path)!r} is not a report of fotogeo orient (its JSON --report, with the "
                         f"fitted model and the GCPs' CRS)", option="model")
    try:
        model = model_from_dict(rep["model"])
    except (KeyError, ValueError, TypeError) as exc:
        raise InputError(f"model {str(path)!r}: the fitted model cannot be rebuilt ({exc})", option="model") from None
    if getattr(model, "direction", "ground-to-image") != "ground-to-image":
        raise InputError(f"model {str(path)!r}: {model.name} was fitted image → ground; orthorectification needs a "
                         f"ground → image model (refit with orient --model {model.name.replace('-i2g', '')})",
                         option="model")
    return model, rep["crs"]


def image_models(images, crs, *, camera=None, eo=None, rpc=False, model=None, sfm_frame="auto", said=None,
                 rpc_of=None) -> list:
    """The :class:`OrthoImage` of every image (module docstring); an image without an orientation is named. How an
    SfM ``eo`` file was read (:mod:`fotogeo.io.sfm_frame`) goes to ``said``; ``rpc_of``: the run's image_rpc."""
    names = [frame_key(p) for p in images]
    distinct_files(images, names)
    if model is not None:
        if rpc or camera is not None or eo is not None or len(images) != 1:
            raise InputError("--model orthorectifies one image through its fitted orient model: give one image and "
                             "no --camera, --eo or --rpc", option="model")
        info = open_raster(images[0], "image")
        return [OrthoImage(str(images[0]), names[0], FittedGroundModel(read_fitted_model(model)[0]), "fitted",
                           info.width, info.height, count=info.count, dtype=info.dtype)]
    if rpc:
        if camera is not None or eo is not None:
            raise InputError("give either --rpc (images carrying RPC metadata) or --camera/--eo (frame cameras), "
                             "not both")
        no_sfm_frame_with_rpc(sfm_frame)
        return [_rpc_image(p, n, crs, rpc_of) for p, n in zip(images, names)]
    if eo is None:
        _no_orientation(names)
    return _frame_images(images, names, camera, eo, crs, sfm_frame, said)


def no_sfm_frame_with_rpc(sfm_frame) -> None:
    """Refuse a local frame of an SfM reconstruction (``sfm_frame`` other than its default "auto") given with
    ``rpc``: each image's orientation is then its RPC, and the choice would be ignored without a word."""
    if sfm_frame not in (None, "auto"):
        raise InputError(f"sfm_frame {sfm_frame!r} reads an OpenSfM/ODM reconstruction given as the frames' "
                         f"orientation, but with rpc=True each image's orientation is its RPC: leave one of them out",
                         option="sfm_frame", also=("rpc",))


def _no_orientation(names) -> None:
    """Refuse images given without any orientation (no ``--eo``, ``--rpc`` or ``--model``)."""
    raise InputError(f"no orientation for the image(s) {', '.join(names[:10])}: give the exterior orientation "
                     f"(--eo, with --camera) of frame cameras, or --rpc for images carrying an RPC")


def _rpc_image(path, name, crs, rpc_of=None) -> OrthoImage:
    from ...geometry.lonlat_model import LonLatModel
    from ...io.rpc_image import image_rpc  # function level: the RPC reader imports the models (scipy)
    info = open_raster(path, "image")
    found = (rpc_of or image_rpc)(path)  # GDAL RPC metadata, else an RPC file beside the image
    _warn_placeless(path, info.width, info.height, found)
    return OrthoImage(str(path), name, LonLatModel(found.rpc.to_model(), crs), "rpc", info.width, info.height,
                      "ellipsoid", info.count, info.dtype, found)


def _warn_placeless(path, width: int, height: int, found) -> None:
    """Warn about an RPC image that looks cut out of its product without its place (``rpc_place.placeless`` of its
    RPC read, ``found``): orthorectified, such a cut-out lies at the product's corner. The file alone cannot tell it
    from a crop ``gdal_translate -srcwin`` made near the product's corner (GDAL moves the offsets by the crop's place,
    small beside the scales), which is right: a warning (``dsm --rpc`` decides by the pair's relative pointing)."""
    from ...io.rpc_place import placeless
    why = placeless(path, width, height, found)
    if why:
        warnings.warn(f"RPC image {str(path)!r} ({why}) is read at the first pixel of that product: right for a "
                      f"crop gdal_translate -srcwin cut near the product's corner, but a cut-out from elsewhere "
                      f"that kept the product's RPC is orthorectified at the product's corner, kilometres off; "
                      f"check the orthophoto against a map, and give such a cut-out its place (beside an OSSIM "
                      f".geom without RPC tags, a CRS-less geotransform: gdal_edit.py -a_ullr COL ROW COL+W ROW+H)",
                      FotogeoWarning, stacklevel=3)


def orientation_block(eo, crs, camera, sfm_frame="auto", images=()):
    """The :class:`~fotogeo.geometry.approx_block.ApproximateBlock` of an SfM/orthority ``eo`` file, None for
    fotogeo's ``.txt`` lines; a file in another CRS than ``crs`` is refused (mixed CRSs). orthority's files may
    state their CRS (``world_crs``, a ``.prj`` beside a CSV): it is read first, never overridden by ``crs``;
    OpenSfM and COLMAP positions are expressed in ``crs``; the ``images``' own GPS is evidence for the reading of an
    OpenSfM file (``sfm_frame``) and a check of every file (:mod:`fotogeo.io.orientation_file`)."""
    from ...io.orientation_file import read_orientation_file
    block = None
    if cameras_from_camera_file(eo) and camera is not None:
        try:
            block = read_orientation_file(eo, crs=None, camera=camera, images=images)  # the file's own CRS
        except InputError as exc:
            if "states no CRS" not in str(exc):
                raise
    block = block or read_orientation_file(eo, crs=crs, camera=camera, sfm_frame=sfm_frame, images=images)
    stated = block.crs if block is not None else exterior_orientation_crs(eo)
    if crs is not None and stated is not None and not same_crs(stated, crs):
        from ...crs import short_name
        raise InputError(f"--eo {str(eo)!r} is in {short_name(stated)} but the map CRS is {short_name(crs)}; "
                         f"give --crs {short_name(stated)} (and a DEM in it or any CRS) or an orientation file in "
                         f"the map CRS")
    return block


def _frame_images(images, names, camera, eo, crs, sfm_frame="auto", said=None) -> list:
    from ...io.camera import exterior_for, read_camera_with_distortion, read_exterior_orientation
    from ...orientation.adjusted_frame import AdjustedFrame
    block = orientation_block(eo, crs, camera, sfm_frame, images)
    if block is not None and said is not None:
        said += [n for n in block.notes if ("local frame" in n or "own GPS" in n) and n not in said]
    if block is None:
        if camera is None:
            raise InputError(f"--eo {str(eo)!r} ('name X Y Z omega phi kappa' lines) needs the camera (--camera)")
        table = read_exterior_orientation(eo)
        cam, dist = read_camera_with_distortion(camera)
        poses = {n: (exterior_for(table, n), cam, dist, None, "") for n in names}
    else:
        from ...io.orientation_file import cameras_from_camera_file
        own = cameras_from_camera_file(eo)  # orthority's: the block's cameras ARE --camera's
        given = read_camera_with_distortion(camera) if camera is not None and not own else None
        poses, keys = {}, match_keys(names, block.shots)
        other = sorted(f"{n} as {k!r}" for n, k in keys.items() if n != k)
        if other:
            note = (f"--eo {str(eo)!r} names image(s) otherwise than the files: {', '.join(other[:5])} (matched "
                    f"ignoring case and Windows folders, each to its only such name)")
            warnings.warn(note, InputNote, stacklevel=3)
            if said is not None:
                said.append(note)
        for n in names:
            shot = block.shots.get(keys.get(n, n))
            if shot is None or shot.exterior is None:
                poses[n] = (None, None, None, None, "")
                continue
            cam, dist = given or (block.camera_of(keys[n]).camera, block.camera_of(keys[n]).distortion)
            poses[n] = (shot.exterior, cam, dist, shot.height_reference, "" if given else f"--eo {str(eo)!r}")
    missing = [n for n in names if poses[n][0] is None]
    if missing:
        why = unmatched_reasons(names, block.shots) if block is not None else {}
        said_why = [f"{n} ({why[n]})" if n in why else n for n in missing[:10]]
        raise InputError(f"--eo {str(eo)!r} has no orientation for the image(s) {', '.join(said_why)}; give a "
                         f"file with one pose per image, named by the image file's name (with or without its extension)")
    out, scaled = [], set()
    for path, n in zip(images, names):
        ext, cam, dist, ref, source = poses[n]
        info = open_raster(path, "image")
        size = (tuple(cam.image_size), info.width, info.height)
        cam, note = camera_for_image(cam, info.width, info.height, path, source)
        if note and size not in scaled:  # said once per size change, naming its first image
            scaled.add(size)
            warnings.warn(note, InputNote, stacklevel=3)
            if said is not None:
                said.append(note)
        out.append(OrthoImage(str(path), n, AdjustedFrame(cam, ext, dist, n), "frame", info.width, info.height, ref,
                              info.count, info.dtype))
    return out


def terrain(dem, height, crs, images, *, dem_heights="auto", geoid=None):
    """``(height source or number, height reference used, notes)`` (module docstring)."""
    kinds = {im.kind for im in images}
    if dem is None:
        require_heights([im.name for im in images], dem, height, "rpc" in kinds)
        return float(height), None, [f"constant height {float(height):g}"]
    d = read_dem_under(dem, images, crs)
    source = _as_map_source(d, crs)
    stated, said = stated_height_reference(dem, d.crs)
    ref = stated if dem_heights in (None, "auto") else dem_heights
    wanted = {im.height_reference for im in images} - {None}
    if len(wanted) > 1:
        raise InputError(f"the orientations mix height references ({', '.join(sorted(wanted))}); orthorectify "
                         f"the images of each reference separately")
    notes = [f"DEM heights: {ref or 'reference not stated'}" + (f" (from its {said})" if ref == stated and ref else "")]
    if geoid is not None and ref != "geoid":
        raise InputError(f"--geoid {str(geoid)!r} is given but the heights of DEM {str(dem)!r} are "
                         f"{ref or 'of unstated reference'}; give --dem-heights geoid if they are geoid heights")
    if not wanted and geoid is None:
        return source, ref, notes + ["DEM heights used as they are, in the vertical frame of the orientations"]
    target = wanted.pop() if wanted else "ellipsoid"  # --geoid asks for ellipsoidal heights
    if ref is None:
        warnings.warn(f"DEM {str(dem)!r} does not state its height reference; its heights are taken as {target} "
                      f"heights, as the {'RPC needs' if 'rpc' in kinds else 'orientation states'} (give --dem-heights "
                      f"to state it)", FotogeoWarning, stacklevel=3)
        return source, target, notes + [f"DEM heights assumed {target}"]
    if ref == target:
        return source, ref, notes
    if ref == "geoid" and target == "ellipsoid" and geoid is not None:
        und = _as_map_source(read_dem(geoid), crs)
        return ShiftedHeights(source, und), "ellipsoid", notes + [f"geoid undulations of {str(geoid)!r} added"]
    need = "the RPC needs" if "rpc" in kinds else "the orientations are in"
    raise InputError(f"DEM {str(dem)!r} holds {ref} heights but {need} {target} heights: give the geoid "
                     f"undulations (--geoid, e.g. PROJ's egm96_15.gtx) or --dem-heights {target} if the DEM's "
                     f"heights are in fact {target}")


#: pixels of the decimated read that bounds a DEM's heights before its window is chosen
_RANGE_PIXELS = 1_000_000
#: the fix of a DEM that misses the images (a caller that read the orientations in a CRS it was given names it)
SAME_CRS = "check the DEM's extent and that the orientation and the DEM are in the same CRS"


def read_dem_under(path, images, crs):
    """The part of the DEM ``path`` under the images, as a :class:`~fotogeo.geometry.dem.Dem` (memory bounded by
    the images' ground area, not the DEM's): each image's outline on the planes of the lowest and highest height
    (every line of sight between them lies inside their bounding box), read by :func:`read_dem_around`."""
    from ...pixels import outline

    def corners(lo, hi):
        return [im.model.inverse(outline(im.width, im.height, 9), h)[:, :2] for im in images for h in (lo, hi)]
    return read_dem_around(path, crs, corners, partial(_not_under, path, images))


def read_dem_around(path, crs, corners, refusal):
    """The window of the DEM ``path`` around the points ``corners(lowest, highest)`` gives (a list of ``(N, 2)``
    arrays in the map CRS ``crs``, NaN rows ignored), as a :class:`~fotogeo.geometry.dem.Dem` whose memory follows
    that area, not the DEM's: the heights' range comes from a decimated read (at most :data:`_RANGE_PIXELS`),
    padded by 10 % and the 100 m a geoid shift may add; the points' bounding box in the DEM's CRS plus two cells is
    read. The whole DEM when no point is finite; ``refusal(dem_crs, why)``: the message when the box misses the DEM
    or holds no height (None: return None then)."""
    import math

    from rasterio.windows import Window

    from ...crs import transform_points
    from ...geometry.dem import Dem
    from ...io.raster import dem_height_scale, ropen
    with ropen(path) as ds:
        if ds.crs is None:
            raise InputError(f"DEM {str(path)!r} has no CRS; assign one (gdal_edit.py -a_srs)")
        dcrs = ds.crs  # GDAL's parse (rasterio), carried by the Dem: pyproj parses it only if a transformation needs it
        scale = dem_height_scale(ds, crs=dcrs)
        f = max(1, math.ceil(math.sqrt(ds.width * ds.height / _RANGE_PIXELS)))
        small = ds.read(1, out_shape=(max(2, ds.height // f), max(2, ds.width // f)), masked=True)
        z = small.compressed().astype(float) * scale
        z = z[np.isfinite(z)]
        if not z.size:
            raise InputError(f"DEM {str(path)!r} holds no valid height")
        pad = 0.1 * float(z.max() - z.min()) + 100.0
        xy = np.vstack([np.asarray(c, float).reshape(-1, 2) for c in corners(float(z.min()) - pad,
                                                                              float(z.max()) + pad)])
        xy = transform_points(crs, horizontal_crs(dcrs), xy[np.isfinite(xy).all(axis=1)])
        if not len(xy):
            return read_dem(path)
        inv = ~ds.transform
        cr = np.array([inv * tuple(p) for p in xy])
        c0, r0 = np.floor(cr.min(axis=0)).astype(int) - 2
        c1, r1 = np.ceil(cr.max(axis=0)).astype(int) + 2
        c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1, ds.width), min(r1, ds.height)
        if c1 - c0 < 2 or r1 - r0 < 2:
            if refusal is None:
                return None
            raise InputError(refusal(dcrs, "the images' ground lies outside it"))
        win = Window(c0, r0, c1 - c0, r1 - r0)
        data = ds.read(1, window=win, masked=True).astype(np.float64) * scale
        if not np.isfinite(data.filled(np.nan)).any():
            if refusal is None:
                return None
            raise InputError(refusal(dcrs, "it holds no height under the images"))
        return Dem(data.filled(np.nan), ds.window_transform(win), dcrs, str(path))


def _not_under(path, images, dem_crs, why: str) -> str:
    """The one-line refusal of a DEM that misses every image (dsm took the NaN heights into a traceback)."""
    names = ", ".join(repr(im.name) for im in images[:3]) + (" …" if len(images) > 3 else "")
    crs = as_pyproj(horizontal_crs(dem_crs))
    return (f"DEM {str(path)!r} does not cover image{'s' if len(images) > 1 else ''} {names}: {why}; {SAME_CRS} "
            f"({crs.to_string() if crs.to_epsg() else crs.name})")


def require_heights(names, dem, height, rpc: bool) -> None:
    """Refuse images without heights: no DEM and no constant height (asked for knowingly)."""
    if dem is None and height is None:
        what = "RPC image(s)" if rpc else "frame(s)"
        raise InputError(f"{what} {', '.join(names[:5])}: orthorectification needs heights: give a DEM (--dem) or, "
                         f"knowingly, a constant height (--height)")


def _as_map_source(d, crs):
    """The Dem ``d`` as a height source at points in ``crs`` (itself when its horizontal CRS is ``crs``)."""
    from ...geometry.dem import DemSampler
    return d if same_crs(horizontal_crs(d.crs), crs) else DemSampler(d, crs)


def holes(d) -> float:
    """Fraction of a DEM's cells that are nodata *inside* its valid area (holes, not the outer margin): the nodata
    regions (4-connected, as ``scipy.ndimage.binary_fill_holes`` fills) that do not touch the array's edge."""
    import cv2
    invalid = (~np.isfinite(d.data)).astype(np.uint8)
    if not invalid.any():
        return 0.0
    _, labels = cv2.connectedComponents(invalid, connectivity=4)
    outer = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    inside = (labels > 0) & ~np.isin(labels, outer[outer > 0])
    return float(inside.sum()) / max(1, int(invalid.size - invalid.sum() + inside.sum()))
