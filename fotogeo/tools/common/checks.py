"""Checks the tools run on their inputs before any heavy work, and on every output grid.

Each raises a :class:`~fotogeo.errors.FotogeoError` whose one-line message names the input
and the fix: a camera file made for another image size, GCPs whose CRS cannot be theirs, an
output grid too large for the source or for the free disk space.
"""
from __future__ import annotations

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
    of, fix = ((f" of {source}", " (resized after the reconstruction? only an exact reduction by a whole number "
                "or an exact enlargement of both sides is scaled; other sizes may be crops); give the images it "
                "was made from, or --camera with this size's focal length and principal point") if source else
               ("", "; give the camera file of this image (or scale its image size and principal point)"))
    raise InputError(f"the camera{of} is for images of {cw}x{ch} pixels but {str(image)!r} is {width}x{height}{fix}")


#: the largest factor between the size an SfM project's camera was made for and the image's that is scaled
MAX_RESIZE = 16


def resize_factor(camera_size, width: int, height: int):
    """The exact factor ``s`` (a :class:`~fractions.Fraction`) by which an image of ``camera_size`` became
    ``width`` x ``height``, or None: ``s`` the same on both sides, and either an enlargement (``1 < s ≤``
    :data:`MAX_RESIZE`: the reconstruction was made on reduced copies; a crop cannot enlarge) or a reduction by a
    whole number (``s = 1/k``, ``k ≤`` :data:`MAX_RESIZE`). Another reduction (``s = 15/16``) is also what a crop of
    the same aspect gives, which the sizes cannot tell from a resize: None."""
    from fractions import Fraction
    w0, h0 = (int(v) for v in camera_size)
    s = Fraction(int(width), w0)
    if Fraction(int(height), h0) != s or s == 1:
        return None
    if 1 < s <= MAX_RESIZE or (s.numerator == 1 and s.denominator <= MAX_RESIZE):
        return s
    return None


def camera_for_image(camera, width: int, height: int, image, source: str) -> tuple:
    """``(camera, note)``: the camera of the SfM project ``source`` for an image of ``width`` x ``height``.

    When the image was resized after the reconstruction by an exact factor ``s`` (:func:`resize_factor`), the
    interior orientation is scaled as ODM's own resize does (``opendm/osfm.py``): a resize maps the image's corner to
    corner, so in the corner convention every pixel coordinate, the principal point and the focal length in pixels
    take the factor ``s``, and Brown's distortion, acting on ``(x/z, y/z)``, is unchanged; the sensor size is kept,
    so ``f_px = f·w/sensor_w`` follows the new width. Any other size (a crop, an aspect change) is refused by
    :func:`check_camera_size`."""
    from dataclasses import replace
    s = resize_factor(camera.image_size, width, height) if source else None
    if s is None:
        check_camera_size(camera, width, height, image, source)
        return camera, ""
    w0, h0 = (int(v) for v in camera.image_size)
    pp = tuple(float(v) * float(s) for v in camera.principal_point)
    note = (f"the camera of {source} is for {w0}x{h0} images; {str(image)!r} (and any image of its size) is "
            f"{width}x{height}, the same image {'enlarged' if s > 1 else 'reduced'} by exactly {s}: the interior "
            f"orientation is scaled by {float(s):.6g}")
    return replace(camera, image_size=(int(width), int(height)), principal_point=pp), note


def check_gcp_crs(gcps, source) -> None:
    """Refuse GCPs in a geocentric CRS, or labelled geographic while their coordinates are metres."""
    require_planar(gcps.crs, f"CRS of the GCPs {str(source)!r}")
    check_lonlat_range(gcps.crs, gcps.ground[:, :2], f"the GCPs of {str(source)!r}")


def check_output_grid(path, width: int, height: int, *, bands: int, dtype, source_pixels: int, what: str,
                      resolution: float | None = None) -> None:
    """The size guard of every output grid: pixel count against an absolute limit and against
    the source's pixel count (:func:`~fotogeo.io.output_checks.check_grid`), then the free space of
    the output folder against the grid's uncompressed size (:func:`~fotogeo.io.output_checks.check_space`)."""
    check_grid(width, height, source_pixels=source_pixels, what=what, resolution=resolution)
    check_space(Path(path).resolve().parent, grid_bytes(width, height, bands, dtype), what)


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
