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
    of, fix = ((f" of {source}", " (resized after the reconstruction?); give the images it was made from, or "
                "--camera with this size's focal length and principal point") if source else
               ("", "; give the camera file of this image (or scale its image size and principal point)"))
    raise InputError(f"the camera{of} is for images of {cw}x{ch} pixels but {str(image)!r} is {width}x{height}{fix}")


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
