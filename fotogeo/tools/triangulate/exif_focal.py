"""A camera guessed from EXIF ``FocalLength × FocalPlaneXResolution`` checked against the adjustment's residuals.

``FocalPlaneXResolution`` (pixels per millimetre on the sensor) is written for the camera's full-resolution frame;
:mod:`fotogeo.io.exif_camera` scales it to a resized file by ``width / PixelXDimension``. A tool that rewrites
``PixelXDimension``/``PixelYDimension`` to the new size (Photoshop/Lightroom exports) leaves it describing the full
frame, so the focal length in pixels comes out ``1/s`` times too long; a camera that writes no
``FocalLengthIn35mmFilm`` (the senseFly eBee's Canon IXUS 125 HS) leaves only the other records of the size the camera
wrote to contradict it (:mod:`fotogeo.io.exif_sizes`, checked when the file is read); this check is what is left
when the resizing tool rewrote or dropped those too.

The focal length cannot be told from the flying height in a near-nadir block over gentle terrain (its multiple
correlation exceeds ``--max-correlation``, so the self-calibration holds it fixed), so the adjustment bends the other
unknowns to fit and the tie points' residuals grow. Least-squares matching gives each tie point a formal σ (Grün 1985,
from the LSM normal equations); the image group's a-posteriori σ₀ with those σ (before the image variance component
rescales them, :func:`fotogeo.orientation.bundle._image_variance`) is how many times the residuals exceed the matcher's
precision: a few with the right camera, several times more with a focal length twice too long
(docs/benchmarks/dsm.md, "eBee flight", has the values measured by ``benchmarks/resized_frames_bench.py`` and the
command). Above :data:`MAX_IMAGE_SIGMA0` with such a camera the run is refused, naming the camera's source, the
sensor width it implies (``PixelXDimension / FocalPlaneXResolution``) and the fix; ``--self-calibration`` given
explicitly (``none`` included) takes the camera as the user's and skips the check.
"""
from __future__ import annotations

import numpy as np

from ...errors import ModelError

#: the image group's σ₀ with least-squares matching's formal σ above which a camera from FocalPlaneXResolution
#: is refused: between what the right camera and a focal length twice too long give (module docstring)
MAX_IMAGE_SIGMA0 = 4.0
FOCAL_PLANE = "FocalPlaneXResolution"


def image_sigma0_given(stats: dict) -> float | None:
    """The image group's σ₀ with the σ the matcher gave (before any variance component), None if unknown."""
    image = (stats.get("variance_components") or {}).get("image") or {}
    s0 = image.get("sigma0_given", image.get("sigma0"))
    return float(s0) if s0 is not None and np.isfinite(s0) else None


def check_exif_focal(camera_source: str, camera, stats: dict, given: bool) -> None:
    """Refuse (:class:`ModelError`) a camera whose focal length comes from EXIF ``FocalPlaneXResolution`` when the
    tie points' residuals are more than :data:`MAX_IMAGE_SIGMA0` times the matcher's precision (module docstring).
    ``camera_source``: how the focal length was read (:func:`fotogeo.io.exif_camera.focal_of`'s source, "" for a
    camera file); ``given``: ``--self-calibration`` was given."""
    s0 = image_sigma0_given(stats)
    if given or FOCAL_PLANE not in camera_source or s0 is None or s0 <= MAX_IMAGE_SIGMA0:
        return
    w, h = camera.image_size
    f = camera.focal_length * w / camera.sensor_size[0]
    ppmm = f / _focal_mm(camera_source) if _focal_mm(camera_source) else None
    sensor = f" and a sensor {w / ppmm:.2f} x {h / ppmm:.2f} mm" if ppmm else ""
    raise ModelError(f"the tie points' residuals are {s0:.1f} times least-squares matching's precision (more than "
                     f"{MAX_IMAGE_SIGMA0:g}) with the camera guessed from the images' EXIF: focal {f:.0f} px at "
                     f"{w}x{h} px from {camera_source}{sensor}; FocalPlaneXResolution describes the camera's full "
                     f"frame, so a copy resized with its EXIF PixelXDimension rewritten to the new size gets a focal "
                     f"length too long by the resize factor; give the camera (--camera), triangulate the originals, "
                     f"or, if the camera is right, --self-calibration none (or the parameters to estimate)",
                     option="--camera")


def _focal_mm(source: str) -> float | None:
    """The focal length in mm at the start of a ``"4.3 mm x FocalPlaneXResolution (…)"`` source."""
    head = source.split(" mm x ", 1)[0]
    try:
        return float(head)
    except ValueError:
        return None
