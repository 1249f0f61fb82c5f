"""Checks the tools run on their inputs before any heavy work, and on every output grid.

Each raises a :class:`~fotogeo.errors.FotogeoError` whose one-line message names the input
and the fix: a camera file made for another image size, GCPs whose CRS cannot be theirs, an
output grid too large for the source or for the free disk space.
"""
from __future__ import annotations

import os
from pathlib import Path

from ...crs import check_lonlat_range, require_planar
from ...errors import InputError, VectorError
from ...io.output_checks import check_grid, check_space, grid_bytes


def check_camera_size(camera, width: int, height: int, image, source: str = "") -> None:
    """Refuse a camera whose image size differs from the image's (``width`` x ``height``).

    The focal length in pixels is ``f · image_size / sensor_size``: a camera file written for
    another size (a decimated copy, another scan) scales every ray and no model can absorb it.
    ``source``: the orientation file the camera came from (an SfM project), named in the refusal.
    """
    if camera is None:
        return
    cw, ch = (int(v) for v in camera.image_size)
    if (cw, ch) == (int(width), int(height)):
        return
    of, fix = ((f" of {source}", " (resized after the reconstruction? only an enlargement, a reduction by a "
                "whole number or to a long side of 512, 1024, 2048, 4096 or 8192 px is scaled; other sizes may be "
                "crops); give the images it was made from, or --camera with this size's focal length and principal "
                "point") if source else
               ("", "; give the camera file of this image (or scale its image size and principal point)"))
    raise InputError(f"the camera{of} is for images of {cw}x{ch} pixels but {str(image)!r} is {width}x{height}{fix}")


#: the largest factor between the size an SfM project's camera was made for and the image's that is scaled
MAX_RESIZE = 16
#: long sides (px) that resizing tools reduce images to: powers of two, ODM's ``--resize-to`` and WebODM's
#: upload resize default (2048) among them
RESIZE_LONG_SIDES = (512, 1024, 2048, 4096, 8192)


def _resize_of(big, small) -> str | None:
    """How ``small`` ``(long, short)`` is a resize of ``big``, or None: its short side within 1 px of the long
    side's factor (every resize writes whole pixels: ODM ``int(w·r)``, OpenCV ``round``) and either a whole
    fraction ``1/k`` (each side within 1 px of ``big/k``) or a long side of :data:`RESIZE_LONG_SIDES`."""
    if abs(small[1] - big[1] * small[0] / big[0]) >= 1.0 or big[0] > MAX_RESIZE * small[0]:
        return None
    k = round(big[0] / small[0])
    if k > 1 and all(abs(a / k - b) < 1.0 for a, b in zip(big, small)):
        return f"1/{k}"
    return f"a long side of {small[0]} px" if small[0] in RESIZE_LONG_SIDES else None


def resize_factor(camera_size, width: int, height: int):
    """``(sx, sy, how)``: the per-axis factors by which an image of ``camera_size`` became ``width`` x ``height``
    in a resize, and how it is read, or None. A resize maps the image's corners to corners, each side to a whole
    number of pixels: ``sx = width/w0``, ``sy = height/h0``, which differ by less than a pixel over the short side.
    Read as a resize, the smaller of the two sizes being the larger resized (:func:`_resize_of`):

    * a reduction by a whole number ``k ≤`` :data:`MAX_RESIZE` (each side within 1 px of ``w0/k``, ``h0/k``), or to a
      long side of :data:`RESIZE_LONG_SIDES` (ODM's 2048: 5472x3648 -> 2048x1365);
    * an enlargement, the camera's size being such a resize of the image's (the reconstruction was made on reduced
      copies: 2048x1365 -> 5472x3648), or one exact factor on both sides (``1 < s ≤`` :data:`MAX_RESIZE`).

    An aspect change is not a resize. Any other reduction (``15/16``: 640x480 -> 600x450) is what a crop of the same
    aspect also gives: None. The sizes cannot tell a crop to a whole fraction or to a long side of
    :data:`RESIZE_LONG_SIDES` (keeping the aspect to 1 px) from a resize: those are taken as the resizes they
    usually are."""
    from fractions import Fraction
    w0, h0 = (int(v) for v in camera_size)
    w, h = int(width), int(height)
    if min(w, h, w0, h0) <= 0:
        return None
    cam, img = ((w0, h0), (w, h)) if w0 >= h0 else ((h0, w0), (h, w))  # (long, short)
    sx, sy = w / w0, h / h0
    if img[0] > cam[0] and img[1] >= cam[1]:
        how = _resize_of(img, cam)
        exact = Fraction(w, w0) == Fraction(h, h0) and sx <= MAX_RESIZE
        return (sx, sy, f"enlarged by {sx:.6g} x {sy:.6g}") if how or exact else None
    if img[0] < cam[0] and (how := _resize_of(cam, img)):
        exact = "exactly " if how.startswith("1/") and w0 == w * int(how[2:]) and h0 == h * int(how[2:]) else ""
        return sx, sy, f"reduced {'by ' + exact if how.startswith('1/') else 'to '}{how}"
    return None


def camera_for_image(camera, width: int, height: int, image, source: str) -> tuple:
    """``(camera, note)``: the camera of the SfM project ``source`` for an image of ``width`` x ``height``.

    When the image was resized after the reconstruction (:func:`resize_factor`: per axis ``sx``, ``sy``), the
    interior orientation is scaled as ODM's own resize does (``opendm/osfm.py``): a resize maps the image's corner to
    corner, so in the corner convention every pixel coordinate and the principal point take ``(sx, sy)``; Brown's
    distortion, acting on ``(x/z, y/z)``, is unchanged; the sensor size is kept, so ``fx = f·w/sensor_w`` and
    ``fy = f·h/sensor_h`` follow the new width and height. Any other size (a crop, an aspect change) is refused by
    :func:`check_camera_size`."""
    from dataclasses import replace
    r = resize_factor(camera.image_size, width, height) if source else None
    if r is None:
        check_camera_size(camera, width, height, image, source)
        return camera, ""
    sx, sy, how = r
    w0, h0 = (int(v) for v in camera.image_size)
    pp = (float(camera.principal_point[0]) * sx, float(camera.principal_point[1]) * sy)
    note = (f"the camera of {source} is for {w0}x{h0} images; {str(image)!r} (and any image of its size) is "
            f"{width}x{height}, the same image {how}: the interior orientation is scaled by {sx:.6g} across, "
            f"{sy:.6g} down")
    return replace(camera, image_size=(int(width), int(height)), principal_point=pp), note


def check_gcp_crs(gcps, source) -> None:
    """Refuse GCPs in a geocentric CRS, or labelled geographic while their coordinates are metres."""
    require_planar(gcps.crs, f"CRS of the GCPs {str(source)!r}")
    check_lonlat_range(gcps.crs, gcps.ground[:, :2], f"the GCPs of {str(source)!r}")


def check_output_grid(path, width: int, height: int, *, bands: int, dtype, source_pixels: int, what: str,
                      resolution: float | None = None, compress: str = "deflate") -> None:
    """The size guard of every output grid: pixel count against an absolute limit and against
    the source's pixel count (:func:`~fotogeo.io.output_checks.check_grid`), then the free space of
    the output folder against the grid's uncompressed size (:func:`~fotogeo.io.output_checks.check_space`, written
    with ``compress``)."""
    check_grid(width, height, source_pixels=source_pixels, what=what, resolution=resolution)
    check_space(Path(path).resolve().parent, grid_bytes(width, height, bands, dtype), what, compress)


def check_window_fits(half_window: int, images: dict) -> None:
    """Refuse a matching window ``(2·half_window + 1)²`` larger than an image of ``images`` (role →
    opened raster): every point would be reported outside the image instead of the option being wrong.

    The error names the option (``option="half_window"``), so the command line calls it by its flag.
    """
    size = 2 * int(half_window) + 1
    for role, info in images.items():
        side = min(info.width, info.height)
        if size > side:
            raise InputError(f"half_window {half_window} makes a {size} x {size} px window, larger than the {role} "
                             f"{str(info.path)!r} ({info.width} x {info.height} px); give at most "
                             f"{max((side - 1) // 2, 0)}", option="half_window")


def check_has_points(table, what: str, columns) -> None:
    """Refuse a point table without a single point (the tools would report "0 of 0" and write an empty file)."""
    if len(table) == 0:
        raise VectorError(f"{what} holds no points; give one point per line with the columns {', '.join(columns)}")


def check_unique_ids(table, id_field: str, what: str) -> None:
    """Refuse a point table whose ``id_field`` names a point twice: its output rows (one per input row) could
    not be told apart, and a join on the id keeps one of them silently. Names each id and its data rows
    (1-based; for a CSV, line = row + 1 after the header)."""
    from ...io.tables import duplicate_ids, find_column
    column = find_column(table, id_field)
    if column is None:
        return
    twice = duplicate_ids(table[column].astype(str).to_numpy())
    if twice:
        listed = "; ".join(f"{i!r} (rows {', '.join(map(str, rows))})" for i, rows in list(twice.items())[:10])
        raise VectorError(f"{what}: id(s) used more than once in field {str(column)!r}: {listed}"
                          f"{' and more' if len(twice) > 10 else ''}; give each point its own id")


def distinct_files(paths, names, what: str = "images") -> None:
    """Refuse an image given twice among ``paths`` (``names``: their names, the file stems pairs, reports and
    orientation files know them by): one file by two paths (same device and inode), or two images of one name;
    both paths named (``what``: the inputs' word in the message)."""
    files, seen = {}, {}
    for i, (path, name) in enumerate(zip(paths, names)):
        path = str(path)
        st = os.stat(path) if os.path.exists(path) else None
        j = files.setdefault((st.st_dev, st.st_ino) if st is not None else os.path.abspath(path), (i, path))
        if j[0] != i:
            raise InputError(f"{what}: {j[1]!r} and {path!r} are the same file; give each image once" if j[1] != path
                             else f"{what}: {path!r} is given twice; give each image once")
        j = seen.setdefault(name, (i, path))
        if j[0] != i:
            raise InputError(f"{what}: the name {name} occurs twice ({j[1]!r}, {path!r}); every image needs its "
                             f"own file name: rename one")


def inside_fitted(g, width: int, height: int, what: str, needed: int, needed_by: str, fit):
    """:func:`~fotogeo.io.gcps.inside_image` of the GCPs ``g`` after :func:`copy_check` (GCPs without heights are
    not fitted: the span rule stays). ``fit``: ``(rms(ground, pixel), the fit's least number of points, the image σ
    in px)`` — :func:`camera_fit` for a frame camera."""
    from ...io.gcps import inside_image
    if not g.has_heights:
        return inside_image(g, width, height, what, needed, needed_by)
    span = copy_check(g.ground, g.pixel, g.role == "control", width, height, f"GCP file {what!r}", fit)
    return inside_image(g, width, height, what, needed, needed_by, span=span)


def copy_check(ground, pixel, control, width: int, height: int, what: str, fit) -> bool:
    """The one check of every command reading GCP pixels with a fit of fixed scale (orient, compare-models with a
    camera, rpc-bias, triangulate per frame): positions read on a copy of another size or turned are refused naming
    it (:mod:`fotogeo.orientation.copy_reading`; ``what`` opens the message), as are GCPs that fit both as a crop's
    and as a copy's (flat terrain). Returns whether the span rule of :func:`~fotogeo.io.gcps.skip_outside` (most
    outside, spanning more than the image) stays: false only where the fit confirms a crop."""
    from ...io.gcps import another_size, outside_image
    from ...orientation.copy_reading import copy_reading, crop_reading, describe, describe_undecided
    rms, least, sigma = fit
    found = copy_reading(ground, pixel, control, width, height, rms, sigma, least)
    if found:
        raise InputError(f"{what}: {describe(found)}")
    out = outside_image(pixel, width, height)
    scale = another_size(pixel, out, width, height)
    if scale is None:
        return True
    told = crop_reading(ground, pixel, control, width, height, rms, sigma, least, scale)
    if told["reading"] == "either":
        raise InputError(f"{what}: {describe_undecided(told, int(out.sum()), len(out))}")
    return told["reading"] != "crop"


def camera_fit(camera, image_sigma=None, distortion=None) -> tuple:
    """The ``fit`` of :func:`copy_check` for a frame camera: the collinearity resection's RMS
    (:func:`~fotogeo.orientation.copy_reading.collinearity_rms`), its least number of points, and the image σ
    (``image_sigma``, else the click precision
    :data:`~fotogeo.orientation.copy_reading.CLICK_SIGMA_PX`)."""
    from ...models import get_model
    from ...orientation.copy_reading import CLICK_SIGMA_PX, collinearity_rms
    return (collinearity_rms(camera, distortion), get_model("collinearity").min_points,
            image_sigma or CLICK_SIGMA_PX)
