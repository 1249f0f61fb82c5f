"""The RPC of an image: from a given RPC file, the image's GDAL RPC metadata, or an RPC file beside it.

:func:`image_rpc` returns the ground -> image RPC00B of the *image's own pixels* (centre of its first pixel
(0, 0); :meth:`~fotogeo.orientation.rpc.Rpc.to_model` gives fotogeo's corner convention), looking in order at

1. ``rpc``, an RPC file given by the caller (any format :func:`fotogeo.io.rpc.read_rpc` reads);
2. the raster's GDAL ``RPC`` metadata (GeoTIFF RPC tags, and what GDAL reads beside the image itself:
   ``.RPB``, ``_RPC.TXT``, DIMAP ``RPC_*.XML`` next to ``IMG_*`` with its tile offsets, DigitalGlobe ``.XML``);
3. a file beside the image, first found of ``<stem>.geom`` (OSSIM/OTB), ``<stem>.RPB``, ``<stem>_RPC.TXT``,
   ``<stem>_rpc.txt``, ``RPC_<name>.XML`` for an ``IMG_<name>_R<i>C<j>`` image, ``<stem>.XML``.

An RPC file (1 or 3) describes the whole product. An image cut out of it by OTB, shareloc or CARS keeps the RPC
file and carries its place in the product as its geotransform, with no CRS: full-product pixel (corner
convention) ``X = a·col + c``, ``Y = e·row + f`` (``a, e > 0``, no rotation). Such a geotransform is applied
to the file's RPC (exactly: ``samp' = (samp + ½ − c) / a − ½`` on the offset, ``SAMP_SCALE / a`` on the scale,
the same for lines), and reported as ``product_window``. GDAL's own RPC metadata (2) describes the dataset's
pixels (GDAL's RPC transformer ignores any geotransform, and ``gdal_translate -srcwin`` shifts ``LINE_OFF`` and
``SAMP_OFF`` into the window) and is used as it is. Two inputs are refused, each with the fix: a georeferenced image
(a CRS) with a separate RPC file (its pixels are not the sensor's), and RPC tags beside a CRS-less geotransform that
is not the identity. That file says two things the reader cannot tell apart: tags already in the window's pixels
(GDAL's reading) or a cut-out that kept the full product's tags (read as GDAL reads them, every pixel lands
``(c, f)`` px off: a DSM kilometres from its place for a window deep in a product, with no error). A geotransform
that also resamples (``a ≠ 1``: ``gdal_translate -outsize``) adds a third reading: tags rescaled by a GDAL older
than 3.9.3, ``(1 − 1/a) / 2`` px off the RPC's centre convention (:func:`_resampled_message`).

One image, one RPC: an RPC file beside the image that GDAL did not read (an OSSIM ``.geom`` beside RPC tags, a
second file beside the first found) is read as it would be alone and compared with the RPC used; more than a
pixel apart (:func:`rpc_gap_px`), the image is refused naming both and how to keep one (:func:`check_one_rpc`);
the same for the image's own RPC tags when GDAL read a file beside it instead (:func:`_check_hidden_tags`).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import InputError, RasterError
from ..orientation.rpc import Rpc
from .rpc import read_rpc, rpc_from_raster


@dataclass(frozen=True)
class ImageRpc:
    """An image's RPC (in its own pixels), where it came from and the product window applied."""

    rpc: Rpc
    source: str  # the RPC file, or "GDAL RPC metadata"
    product_window: tuple | None = None  # (a, c, e, f) of the geotransform applied, or None


def sidecar_rpc_files(image) -> list[Path]:
    """Existing RPC files beside ``image``, in the order of the module docstring (step 3)."""
    image = Path(image)
    stem, folder = image.stem, image.parent
    names = [f"{stem}.geom", f"{stem}.GEOM", f"{stem}.RPB", f"{stem}.rpb", f"{stem}_RPC.TXT", f"{stem}_rpc.txt"]
    m = re.fullmatch(r"IMG_(.+?)(_R\d+C\d+)?", stem, re.IGNORECASE)
    if m:
        names += [f"RPC_{m.group(1)}.XML", f"RPC_{m.group(1)}.xml"]
    names += [f"{stem}.XML", f"{stem}.xml"]
    seen, out = set(), []
    for n in names:
        p = folder / n
        if p.is_file() and p.resolve() not in seen:
            seen.add(p.resolve())
            out.append(p)
    return out


def _pixel_geotransform(image) -> tuple | None:
    """``(a, c, e, f)`` of the image's geotransform when it has no CRS (identity: None)."""
    from .raster import ropen
    try:
        with ropen(image) as ds:
            crs, t = ds.crs, ds.transform
    except Exception as exc:  # noqa: BLE001 -- any GDAL failure is a bad input raster
        raise RasterError(f"cannot read raster {str(image)!r}: {exc}") from None
    if crs is not None:
        return "georeferenced"
    if t.b != 0 or t.d != 0 or t.a <= 0 or t.e <= 0:
        raise InputError(f"image {str(image)!r}: its geotransform {tuple(t)[:6]} has no CRS and is not a sensor "
                         f"window (positive pixel steps, no rotation); remove it or give the image GDAL RPC tags")
    if (t.a, t.c, t.e, t.f) == (1.0, 0.0, 1.0, 0.0):
        return None
    return (t.a, t.c, t.e, t.f)


def _tags_window(image: Path):
    """The affine geotransform of an image with GDAL RPC tags when it has no CRS and is not the identity (the
    ambiguous case of the module docstring), else None."""
    from .raster import ropen
    with ropen(image) as ds:
        crs, t = ds.crs, ds.transform
    if crs is not None or (t.a, t.b, t.c, t.d, t.e, t.f) == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0):
        return None
    return t


def _refuse_tags_with_window(image: Path, t) -> None:
    """Refuse GDAL RPC tags beside a CRS-less geotransform ``t`` that is not the identity (module docstring)."""
    if t.a > 0 and t.e > 0 and (t.a, t.e) != (1.0, 1.0) and t.b == t.d == 0:
        raise InputError(_resampled_message(image, t))
    raise InputError(f"image {str(image)!r} has GDAL RPC tags and a geotransform without a CRS (its pixel (0, 0) at "
                     f"({t.c:g}, {t.f:g}) of the product): GDAL ignores that geotransform, but a cut-out that kept the "
                     f"full product's tags would be {math.hypot(t.c, t.f):.0f} px off; if the tags are this image's "
                     f"own, remove the geotransform (gdal_edit.py -unsetgt {image.name}), if they are the product's, "
                     f"cut the image from the product with gdal_translate -srcwin (it shifts LINE_OFF/SAMP_OFF)")


def _resampled_message(image: Path, t) -> str:
    """The refusal of GDAL RPC tags beside a CRS-less geotransform that scales the pixels (``gdal_translate
    -outsize``/``-tr`` on a sensor image): the tags were rescaled by the GDAL that resampled it, and GDAL before
    3.9.3 rescaled the offsets as corner coordinates, ``LINE_OFF · r``, where the RPC's (0, 0) is the first pixel's
    centre, ``(LINE_OFF + ½) · r − ½`` (GDAL issue 10600, fixed by its pull request 10602): the two differ by
    ``(1 − r) / 2`` pixels, ``r = 1 / a``; the file does not say which GDAL wrote it. Only seen when the source
    carried a CRS-less window geotransform that the resample scaled: GDAL 3.6 writes none for a sensor image
    without one, and such a resample cannot be told from the file (read as its tags say)."""
    off = max(abs(1 - 1 / t.a), abs(1 - 1 / t.e)) / 2
    return (f"image {str(image)!r} has GDAL RPC tags and a geotransform without a CRS that resamples its pixels "
            f"{t.a:g} x {t.e:g} (what gdal_translate -outsize or -tr leaves on a cut-out carrying its window): its tags were "
            f"rescaled by the GDAL that resampled it, and GDAL before 3.9.3 rescaled LINE_OFF and SAMP_OFF from the "
            f"pixel's corner instead of its centre (GDAL issue 10600): {off:.2g} px off here, enough to shift the "
            f"heights of a stereo pair; if GDAL 3.9.3 or later resampled it, remove the geotransform (gdal_edit.py "
            f"-unsetgt {image.name}); otherwise resample the original again with GDAL 3.9.3 or later, or give "
            f"fotogeo the original")


def in_window(rpc: Rpc, a: float, c: float, e: float, f: float) -> Rpc:
    """``rpc`` of a full product moved to an image whose pixel (corner) ``(col, row)`` is the product's
    ``(a·col + c, e·row + f)`` (module docstring; exact)."""
    return replace(rpc, samp_off=(rpc.samp_off + 0.5 - c) / a - 0.5, samp_scale=rpc.samp_scale / a,
                   line_off=(rpc.line_off + 0.5 - f) / e - 0.5, line_scale=rpc.line_scale / e)


def image_rpc(image, rpc=None) -> ImageRpc:
    """The RPC of ``image`` in its own pixels (module docstring), from ``rpc`` (a file) or found."""
    image = Path(image)
    if rpc is None:
        try:
            tags = rpc_from_raster(image)
        except RasterError as exc:
            if "carries no RPC" not in str(exc):
                raise
        else:
            t = _tags_window(image)
            if t is not None:
                _refuse_tags_with_window(image, t)
            used = ImageRpc(tags, "GDAL RPC metadata")
            read = gdal_rpc_files(image)
            if read:
                _check_hidden_tags(image, used, read[0])
            check_one_rpc(image, used, [f for f in sidecar_rpc_files(image) if f not in read])
            return used
        found = sidecar_rpc_files(image)
        if not found:
            s = image.stem
            raise InputError(f"image {str(image)!r} has no RPC: no GDAL RPC metadata and no RPC file beside it; put "
                             f"the RPC of its product beside it as {s}.geom (OSSIM), {s}.RPB or {s}_RPC.TXT")
        used = _file_rpc(image, found[0])
        check_one_rpc(image, used, found[1:])
        return used
    return _file_rpc(image, rpc)


def _file_rpc(image: Path, rpc) -> ImageRpc:
    """The RPC file ``rpc`` moved into ``image``'s pixels by its window geotransform (module docstring)."""
    model = read_rpc(rpc)
    window = _pixel_geotransform(image)
    if window == "georeferenced":
        raise InputError(f"image {str(image)!r} is georeferenced (it has a CRS): its pixels are not those of the "
                         f"RPC {str(rpc)!r}; give the sensor-geometry image")
    if window is not None:
        model = in_window(model, *window)
    return ImageRpc(model, str(rpc), window)


def gdal_rpc_files(image) -> list[Path]:
    """The RPC files beside ``image`` (:func:`sidecar_rpc_files`) that GDAL read as its RPC metadata (it lists
    them among the dataset's files: ``.RPB``, ``_RPC.TXT``, DIMAP or DigitalGlobe XML; never an OSSIM ``.geom``)."""
    from .raster import ropen
    with ropen(image) as ds:
        listed = {Path(f).resolve() for f in (ds.files or [])}
    return [f for f in sidecar_rpc_files(image) if f.resolve() in listed]


def source_label(image, info: ImageRpc) -> str:
    """The RPC source of ``info`` in a user's words: the file's name, the file GDAL read beside the image, or
    "GeoTIFF RPC tags"."""
    if info.source != "GDAL RPC metadata":
        return Path(info.source).name + (" + window geotransform" if info.product_window is not None else "")
    files = gdal_rpc_files(image)
    return f"{files[0].name} (read by GDAL)" if files else "GeoTIFF RPC tags"


def rpc_gap_px(a: Rpc, b: Rpc, width: int, height: int) -> float:
    """The largest distance (px) between the pixels RPCs ``a`` and ``b`` give the same ground points: those ``a``
    sees at a 5 x 5 grid over the ``width`` x ``height`` image at ``HEIGHT_OFF`` and ``HEIGHT_OFF ± ½·HEIGHT_SCALE``
    (inf when ``b`` cannot place them)."""
    import numpy as np
    ma, mb = a.to_model(), b.to_model()
    u, v = np.meshgrid(np.linspace(0, width, 5), np.linspace(0, height, 5))
    px = np.column_stack([u.ravel(), v.ravel()])
    gaps = []
    for z in a.height_off + a.height_scale * np.array([-0.5, 0.0, 0.5]):
        with np.errstate(all="ignore"):
            g = np.asarray(ma.inverse(px, np.full(len(px), z)), float)
            q = np.asarray(mb.forward(np.column_stack([g[:, 0], g[:, 1], np.full(len(px), z)])), float)
        gaps.append(np.hypot(*(q - px).T))
    gap = np.concatenate(gaps)
    return float(gap.max()) if np.isfinite(gap).all() else math.inf


def _check_hidden_tags(image: Path, used: ImageRpc, read: Path) -> None:
    """Refuse ``image`` when GDAL read its RPC from the file ``read`` beside it (a DIMAP ``RPC_*.XML`` next to an
    ``IMG_*`` name, an ``.RPB``) while the file's own RPC tags, which that file hides from GDAL, disagree by more
    than a pixel: a ``gdal_translate -srcwin`` cut of a tagged product, kept under the product's name beside its
    RPC file, carries its window's tags and would be read with the whole product's RPC."""
    import rasterio
    from .raster import ropen
    with rasterio.Env(GDAL_DISABLE_READDIR_ON_OPEN="EMPTY_DIR"), ropen(image) as ds:
        own, w, h = ds.rpcs, ds.width, ds.height
    if own is None:
        return
    d = {k.upper(): v for k, v in own.to_dict().items()}
    gap = rpc_gap_px(used.rpc, Rpc.from_mapping(d, f"RPC tags of {image}"), w, h)
    if gap > 1.0:
        raise InputError(f"image {str(image)!r} has two RPCs that disagree by {gap:.0f} px: {read.name} beside it "
                         f"(GDAL reads it first) and its own GeoTIFF RPC tags; keep one: to keep the tags move "
                         f"{read.name} away, to keep {read.name} remove the tags (gdal_edit.py -unsetrpc {image.name})")


def check_one_rpc(image: Path, used: ImageRpc, others: list) -> None:
    """Refuse ``image`` when an RPC file in ``others`` (beside it, read as :func:`image_rpc` would read it alone)
    disagrees with the RPC ``used`` by more than a pixel: one of them does not describe its pixels."""
    from .raster import ropen
    if not others:
        return
    with ropen(image) as ds:
        w, h = ds.width, ds.height
    name = source_label(image, used)
    for f in others:
        try:
            other = _file_rpc(image, f)
        except InputError:
            continue  # unreadable or refused alone: not a second RPC of this image
        gap = rpc_gap_px(used.rpc, other.rpc, w, h)
        if gap <= 1.0:
            continue
        keep = (f"to keep {f.name} remove the tags (gdal_edit.py -unsetrpc {image.name}), to keep the tags move "
                f"{f.name} away" if name == "GeoTIFF RPC tags" else
                f"fotogeo reads {name.split(' ')[0]} first: move away the one that does not describe this image")
        raise InputError(f"image {str(image)!r} has two RPCs that disagree by {gap:.0f} px: {name} (read first) "
                         f"and {f.name} beside it; keep one: {keep}")
