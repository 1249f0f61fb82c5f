"""Whether an RPC image may be a cut-out that lost its place in the product its RPC describes.

A whole product's RPC has its offsets at the centre of the image its scales span (``OFF ≈ SCALE``, within 10 %,
as in the vendors' files: rpcm's differ by at most 7.3 %). A crop's own RPC (``gdal_translate -srcwin``, which
moves GeoTIFF RPC tags and writes RPB/_RPC.TXT in the window's pixels) has its offsets moved by the crop's corner
(``OFF − SCALE ≈ −COL``). An image much smaller than its product (at most ``SCALE`` pixels a side, half the
product), without a window geotransform (:mod:`fotogeo.io.rpc_image`), carrying a whole product's RPC is read
with its pixel (0, 0) at the product's first pixel: a cut-out from elsewhere in the product is placed
kilometres off with no error. Only the product's own top-left corner, cut without moving the RPC, reads right.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .rpc import read_rpc
from .rpc_image import image_rpc, sidecar_rpc_files


def describes_whole_product(r) -> bool:
    """Whether RPC ``r``'s offsets sit at the centre of the image its scales span (module docstring)."""
    return (abs(r.samp_off - r.samp_scale) <= 0.1 * r.samp_scale
            and abs(r.line_off - r.line_scale) <= 0.1 * r.line_scale)


def same_rpc(a, b) -> bool:
    """Whether RPCs ``a`` and ``b`` have the same offsets and scales (``a`` None: no)."""
    keys = ("line_off", "samp_off", "line_scale", "samp_scale", "lat_off", "long_off")
    return a is not None and all(np.isclose(getattr(a, k), getattr(b, k), rtol=1e-9, atol=1e-9) for k in keys)


def _try_read(path):
    try:
        return read_rpc(path)
    except InputError:
        return None


def product_rpc(image, width: int, height: int, info=None):
    """``(ImageRpc, file)`` when the ``width`` x ``height`` ``image`` may be a cut-out that lost its place in its
    product (module docstring), else None. ``file``: the RPC file (fotogeo's reading, or the one beside the image
    GDAL read as its metadata), None for GeoTIFF RPC tags. ``info``: the image's
    :class:`~fotogeo.io.rpc_image.ImageRpc` when already read (else read here)."""
    info = image_rpc(image) if info is None else info
    r = info.rpc
    if (info.product_window is not None or width > r.samp_scale or height > r.line_scale
            or not describes_whole_product(r)):
        return None
    if info.source != "GDAL RPC metadata":
        return info, info.source
    files = [f for f in sidecar_rpc_files(image) if same_rpc(_try_read(f), r)]
    return info, (str(files[0]) if files else None)


def placeless(image, width: int, height: int, info=None) -> str:
    """Why ``image`` may be a cut-out that lost its place ("" when not, :func:`product_rpc`, ``info`` as there): its
    size, no geotransform, its RPC's source and the size of the product that RPC describes."""
    found = product_rpc(image, width, height, info)
    if found is None:
        return ""
    r = found[0].rpc
    what = Path(found[1]).name if found[1] is not None else "GeoTIFF RPC tags"
    return (f"{width} x {height} px, no geotransform; {what}: a product of about "
            f"{2 * r.samp_scale:.0f} x {2 * r.line_scale:.0f}")
