"""The approximate block: what the images and their files say about a block before any adjustment.

Every source of camera and orientation data — EXIF/XMP inside the images, senseFly's
``geoinfo.txt``, OpenSfM/ODM ``reconstruction.json`` + ``cameras.json``, COLMAP models,
orthority's YAML/CSV, fotogeo's own ``camera.yaml`` + ``exterior_orientation.txt`` — is read by one
small reader in :mod:`fotogeo.io` into this one object (the shape orthority uses: interior
parameters per camera id, and per image its position, angles and camera id, plus a CRS):

* :class:`ApproxCamera` — a :class:`~fotogeo.geometry.camera.FrameCamera` (a focal length in
  pixels is a camera whose ``sensor_size`` is its ``image_size``: ``fx = f·w/sensor_w = f``) with
  Brown's distortion ``{k1, k2, k3, p1, p2}`` (OpenCV's model, the bundle adjustment's) and where
  it came from;
* :class:`ApproxShot` — per image (keyed by the file's stem, :func:`fotogeo.io.block.frame_key`):
  its camera id, the projection centre in the block's CRS and the PATB angles ω, φ, κ (degrees,
  :mod:`fotogeo.geometry.camera`) in that CRS when the source has them, the GNSS σ split into
  horizontal and vertical, an angle σ, the height reference of Z (``"ellipsoid"``, ``"geoid"`` or
  ``None`` when the source does not say) and the source;
* :class:`ApproximateBlock` — the cameras, the shots, the map CRS (projected, metric) and notes
  (what was assumed, e.g. the UTM zone chosen from the GPS, the height reference).

The object holds no file I/O; the readers (``io``) build it, ``tools/triangulate`` consumes it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .brown import TERMS
from .camera import ExteriorOrientation, FrameCamera

#: Brown's distortion terms of an :class:`ApproxCamera`, in the order of ``Block.distortion`` (:mod:`.brown`'s)
DISTORTION_TERMS = TERMS
#: the vertical references a height may be given in
HEIGHT_REFERENCES = ("ellipsoid", "geoid")


@dataclass(frozen=True)
class ApproxCamera:
    """Interior orientation of one camera id (see the module docstring)."""

    camera: FrameCamera
    distortion: dict = field(default_factory=lambda: dict.fromkeys(DISTORTION_TERMS, 0.0))
    source: str = ""

    def distortion_tuple(self) -> tuple:
        """``(k1, k2, k3, p1, p2)``, the order of ``fotogeo.orientation.bundle.Block.distortion``."""
        return tuple(float(self.distortion.get(k, 0.0)) for k in DISTORTION_TERMS)


@dataclass(frozen=True)
class ApproxShot:
    """What is known of one image before the adjustment (see the module docstring).

    ``position`` ``(3,)`` in the block's CRS (Z in metres, ``height_reference``) or ``None``;
    ``angles`` ``(ω, φ, κ)`` PATB degrees in the block's CRS or ``None`` (unknown attitude);
    ``sigma_h`` / ``sigma_v`` the horizontal / vertical σ of the position (m) and ``sigma_angle``
    of the angles (degrees) when the source states them (RTK accuracy tags), else ``None``; ``project_name`` the
    image's name as its SfM project gives it, folders kept (COLMAP's ``flight1/DJI_0001.JPG``), which tells the
    images' own GPS evidence apart when two folders hold the same file name (``""``: the frame name).
    """

    name: str
    camera_id: str
    position: tuple | None = None
    angles: tuple | None = None
    sigma_h: float | None = None
    sigma_v: float | None = None
    sigma_angle: float | None = None
    height_reference: str | None = None
    source: str = ""
    project_name: str = ""

    def __post_init__(self):
        if self.position is not None:
            p = tuple(float(v) for v in self.position)
            if len(p) != 3 or not np.isfinite(p).all():
                raise InputError(f"image {self.name!r}: its position must be three finite numbers; got {self.position}")
            object.__setattr__(self, "position", p)
        if self.angles is not None:
            a = tuple(float(v) for v in self.angles)
            if len(a) != 3 or not np.isfinite(a).all():
                raise InputError(f"image {self.name!r}: its angles must be three finite numbers; got {self.angles}")
            object.__setattr__(self, "angles", a)
        if self.height_reference not in (None, *HEIGHT_REFERENCES):
            raise InputError(f"image {self.name!r}: height reference {self.height_reference!r} is not one of "
                             f"{', '.join(HEIGHT_REFERENCES)}")

    @property
    def exterior(self) -> ExteriorOrientation | None:
        """The PATB :class:`ExteriorOrientation`, when both position and angles are known."""
        if self.position is None or self.angles is None:
            return None
        return ExteriorOrientation(*self.position, *self.angles)


@dataclass(frozen=True)
class ApproximateBlock:
    """Cameras by id, shots by image name, the map CRS (a ``pyproj.CRS`` or ``None``), notes, and
    ``heights``: the positions' height reference and where it was read (the images' EXIF/XMP; "" when the
    source does not say) and ``frame_reading``: how a source's local frame was read and why, when it needed a
    choice (OpenSfM's topocentric or ODM's grid reading, :mod:`fotogeo.io.sfm_frame`; "" otherwise) and ``lost``:
    per frame, what of its metadata could not be read (an XMP packet that is not XML), for the errors that follow."""

    cameras: dict
    shots: dict
    crs: object = None
    notes: tuple = ()
    heights: str = ""
    frame_reading: str = ""
    lost: dict = field(default_factory=dict)  # frame -> what of its metadata could not be read and was lost

    def __post_init__(self):
        missing = sorted({s.camera_id for s in self.shots.values()} - set(self.cameras))
        if missing:
            raise InputError(f"approximate block: shot(s) name camera id(s) {', '.join(missing[:5])} that no "
                             f"camera defines")

    def camera_of(self, name: str) -> ApproxCamera:
        """The camera of the shot ``name``."""
        return self.cameras[self.shots[name].camera_id]

    def with_notes(self, *notes) -> "ApproximateBlock":
        from dataclasses import replace
        return replace(self, notes=self.notes + tuple(n for n in notes if n))
