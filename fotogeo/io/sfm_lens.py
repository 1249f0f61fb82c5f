"""Whether an SfM model's camera is the camera of the images given, or of their undistorted copies.

SfM tools write two models of one block: the one of the original images, with the lens distortion they
estimated, and one of the **undistorted** images they resample for dense matching — the same poses with a
distortion-free camera: OpenSfM's and ODM's ``opensfm/undistorted/reconstruction.json`` (a ``perspective`` camera
with ``k1 = k2 = 0``, the same size), COLMAP ``image_undistorter``'s ``dense/sparse`` (``PINHOLE``). Each is right
only with its own images; the undistorted model given with the originals leaves every pixel where the lens put it,
up to the distortion's displacement at the frame's edge, and nothing else in the inputs contradicts it (the poses are
the same). The images' own calibration tells (:func:`fotogeo.io.exif_camera.focal_of`): DJI ``DewarpData``
(Brown's k1, k2, p1, p2, k3 of the lens) says the files are distorted, ``DewarpFlag`` 1 that the camera already
undistorted them.

The displacement of Brown's model (OpenCV's convention, on ``x = (u − c_x)/f_x``: :mod:`fotogeo.geometry.brown`) is
measured in pixels at points along the frame's border, where a radial distortion is largest; a camera whose largest
displacement is below :data:`DISTORTION_PX` is distortion-free for this purpose (an orthophoto made with it is off by
less than that many pixels anywhere). An SfM camera below it given with images whose calibration displaces the border by
more than :data:`FAR_BELOW` times both that bound and the camera's own displacement is refused in one line naming both
sources, the files the model belongs with and the model of these images (a self-calibration with a small distortion near
the maker's small one is not a mistaken file); images without a distortion calibration, or at another size than the one
their calibration is written for (a resized or cropped copy: COLMAP's ``dense/images`` keep the originals' tags), cannot
be checked, which is said (an :class:`~fotogeo.errors.InputNote`). A model with distortion is not compared with the
images' calibration: a self-calibration (Brown 1971) differs from the maker's by what it fitted, not by a mistaken file.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry import brown

#: largest border displacement (pixels) of a camera taken as distortion-free (module docstring)
DISTORTION_PX = 1.0
#: how many times both DISTORTION_PX and the SfM camera's own displacement the images' lens must exceed to refuse
FAR_BELOW = 3.0


def border_displacement(w: int, h: int, fx: float, fy: float, pp, distortion: dict) -> float:
    """The largest distance (pixels) between the undistorted and the distorted position of points along the border
    of a ``w`` x ``h`` frame (corner convention), Brown's model (module docstring) with ``distortion``
    ``{k1, k2, k3, p1, p2}`` (missing terms 0) — the pixel's ray read as its undistorted position."""
    t = np.linspace(0.0, 1.0, 33)
    u = np.concatenate([t * w, t * w, np.zeros_like(t), np.full_like(t, w)])
    v = np.concatenate([np.zeros_like(t), np.full_like(t, h), t * h, t * h])
    x, y = (u - pp[0]) / fx, (v - pp[1]) / fy
    _, _, xd, yd = brown.distort(x, y, brown.coefficients(distortion))
    return float(np.max(np.hypot(fx * (xd - x), fy * (yd - y))))


def _images_lens(path: str):
    """``(displacement px or None, source)`` of the distortion the image's own DJI tags state; None: no statement.
    The tags are read as written, in the camera's full-resolution pixels: a file at another size than its EXIF
    ``PixelXDimension`` (a resized or cropped copy) cannot be checked, whatever camera the SfM file gives it."""
    from .exif import read_image_metadata
    from .exif_camera import dewarp_data
    meta = read_image_metadata(path)
    w, h = meta.width, meta.height
    got = dewarp_data(meta)
    if got is None:
        return None, "no DJI DewarpData"
    fx, fy, pp, dist = got
    if not dist:
        return 0.0, "drone-dji:DewarpFlag 1 (undistorted by the camera)"
    full = meta.pixel_dimension
    if full and (full[0], full[1]) != (w, h):
        return None, f"DewarpData of a {full[0]}x{full[1]} frame in a {w}x{h} file"
    d = border_displacement(w, h, fx, fy, pp, dist)
    return d, f"drone-dji:DewarpData (k1 {dist.get('k1', 0.0):g}, up to {d:.1f} px at the frame's edge)"


def _fix(path: Path, source: str) -> str:
    """What to give instead, in the words of the tool that wrote ``path`` (module docstring)."""
    parts = [s.lower() for s in Path(path).parts]
    if "undistorted" in parts:
        return ("it is OpenSfM's/ODM's model of the undistorted images: give opensfm/reconstruction.json with these "
                "images, or the undistorted images from opensfm/undistorted/images with this file")
    if source.startswith("COLMAP") and "PINHOLE" in source:
        return ("a COLMAP PINHOLE model is what image_undistorter writes to dense/sparse: give a model with the "
                "lens distortion (sparse/0, camera model OPENCV) with these images, or the undistorted images from "
                "dense/images with this model")
    return ("give the SfM model made with these images (with their lens distortion), or the undistorted images the "
            "model was made for")


def check_lens(block, images, path) -> str:
    """An :class:`InputError` when ``block`` (read from ``path``) has a distortion-free camera and the ``images``
    given carry a distortion calibration beyond :data:`DISTORTION_PX` (module docstring); else the sentence of a
    note when some images state no distortion calibration (the choice cannot be checked), or ``""``."""
    from .block import frame_key, match_keys
    paths = {frame_key(p): str(p) for p in images or ()}
    keys = match_keys(list(paths), list(block.shots))
    unstated, seen = [], {}
    for name, key in keys.items():
        cid, cam = block.shots[key].camera_id, block.camera_of(key)
        if cid not in seen:
            c = cam.camera
            seen[cid] = border_displacement(*c.image_size, c.fx, c.fy, c.principal_point, cam.distortion)
        own = seen[cid]
        img, src = _images_lens(paths[name])
        if img is None:
            unstated.append((name, src))
        elif own < DISTORTION_PX and img > FAR_BELOW * max(DISTORTION_PX, own):
            what = cam.source if cid in cam.source else f"{cid!r}, {cam.source}"
            raise InputError(f"orientation file {str(path)!r}: its camera's distortion ({what}; up to {own:.2f} px) "
                             f"is far below the lens the images state, as the camera of undistorted images: image "
                             f"{paths[name]!r} states {src}; {_fix(path, cam.source)}")
    if not unstated:
        return ""
    name, src = unstated[0]
    return (f"{len(unstated)} of the {len(keys)} image(s) state no lens distortion calibration ({name}: {src}), so "
            f"whether the file's cameras are of these images or of undistorted copies cannot be checked")
