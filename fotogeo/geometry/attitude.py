"""Drone attitude (yaw, pitch, roll) -> PATB ω, φ, κ in a projected map CRS.

Frames and conventions (every rotation here maps camera axes to world axes):

* **ENU** — local East, North, Up at the camera, north being *true* north.
* **NED** — North, East, Down; aerospace Euler angles in the ZYX order::

      R_body→NED = Rz(yaw) · Ry(pitch) · Rx(roll)

  ``Rz``, ``Ry``, ``Rx`` are right-handed rotations of a vector about the NED axes, so yaw turns
  the body's x axis clockwise from north seen from above (90° = east), a positive pitch lifts x
  (nose up) and a positive roll lowers the body's y axis (right side down). DJI states this for its
  XMP angles: "NED coordinate system, the rotation order is ZYX" (``GimbalRoll/Pitch/YawDegree`` and
  ``FlightRoll/Pitch/YawDegree``; DJI Mavic 3E/3T user manual 2022 and Mavic 3M user manual 2023,
  "Photo file" XMP table).
* **OpenCV camera axes** — x right, y down (image rows), z forward along the optical axis; the
  ``R_cv`` of :mod:`fotogeo.geometry.camera` (``R_patb · diag(1, −1, −1)``).

Two attitude conventions are converted:

:func:`rotation_from_ypr` — a **gimbal** (DJI ``drone-dji:Gimbal*Degree``, Parrot
  ``drone-parrot:Camera*Degree``): the body is the camera itself, x = optical axis, y = image right,
  z = image down. Pitch 0 looks at the horizon, −90 straight down (nadir); yaw is the heading of the
  optical axis (or, at nadir, of the image top) clockwise from true north; roll turns the image about
  the optical axis, positive = the image's right side down. Sequence: yaw about the vertical
  (clockwise seen from above), then pitch about the camera's right axis, then roll about the
  optical axis. Sources: the DJI manuals above; Pix4D's article below (for DJI: pitch + 90).

:func:`rotation_from_body_ypr` — an **aircraft body** with a camera looking straight down, the
  image top towards the nose (Pix4D's definition, support article "Yaw, Pitch, Roll and Omega,
  Phi, Kappa angles", for Pix4D's XMP ``Camera:Yaw/Pitch/Roll``): yaw 0 at nadir = image top north,
  yaw 90 = image top east, pitch 0 = nadir, pitch 90 = looking forward; body axes x = nose,
  y = right wing, z = down, and the camera's axes in them x_cv = y, y_cv = −x, z_cv = z. senseFly
  documents no convention for its ``sensefly:Yaw/Pitch/Roll`` tags and ``geoinfo.txt``; fotogeo
  assumes Pix4D's (Pix4D reads these files) and checked it on the eBee frames of
  ``../shared/data`` (tests/test_io_exif.py): between consecutive frames of a strip the ground
  moves ~960 px towards the image bottom (image top = flight direction), 0.4° and 24° from the
  direction nadir + heading predicts (162° and 175° with the image top backwards). The
  autopilot's pitch and roll (up to 12°) do not improve that prediction (median misfit of the
  matched points over four pairs: 313 px with nadir + heading, 416 px with them, 143 px with half
  of them; their signs as above fit better than any other sign choice): they are the aircraft's,
  not the camera's exact attitude at the exposure.
  The difference between the two conventions is the roll axis (optical axis for a gimbal, the
  aircraft's nose for a body); with roll 0, body pitch = gimbal pitch + 90.

:func:`patb_in_map` turns a camera→ENU rotation into PATB angles in a projected CRS: the map grid
is ENU turned about Up by the meridian convergence γ (pyproj's ``meridian_convergence``: the angle
from true north to grid north, positive clockwise, e.g. +1.77° at 143.9°E 37.5°N in UTM 54N,
east of the central meridian), so ``R_map = Rz(γ)·R_enu`` with ``Rz`` counter-clockwise about Up,
and ``PATB = R_map · diag(1, −1, −1)``. The map's scale distortion is ignored (conformal CRSs
keep angles; the convergence is taken at the camera's position).
"""
from __future__ import annotations

import math

import numpy as np

from .camera import angles_patb, rotation_patb

#: PATB camera axes (x right, y up, z back) <-> OpenCV camera axes (x right, y down, z forward)
_D = np.diag([1.0, -1.0, -1.0])
#: NED -> ENU (swap north and east, flip down)
_NED_TO_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: OpenCV camera axes in a gimbal's body (x optical axis, y right, z down): columns x_cv, y_cv, z_cv
_CV_IN_GIMBAL = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
#: OpenCV camera axes in an aircraft body with a nadir camera, image top to the nose
_CV_IN_BODY = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def rotation_angle(Ra, Rb) -> float:
    """The angle (degrees) of the rotation between two rotation matrices: ``arccos((tr(Raᵀ Rb) − 1) / 2)``.

    >>> round(rotation_angle(np.eye(3), _rz(np.radians(30))), 9)
    30.0
    """
    c = (np.trace(np.asarray(Ra).T @ np.asarray(Rb)) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def body_to_ned(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """``Rz(yaw)·Ry(pitch)·Rx(roll)`` (degrees), the aerospace ZYX sequence in NED (module docstring)."""
    y, p, r = np.radians([yaw, pitch, roll])
    return _rz(y) @ _ry(p) @ _rx(r)


def rotation_from_ypr(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """Camera (OpenCV axes) -> ENU rotation of a gimbal camera (DJI convention, degrees).

    ``R = NED→ENU · Rz(yaw)·Ry(pitch)·Rx(roll) · C`` where ``C`` puts the OpenCV axes in the
    gimbal's (x right = gimbal y, y down = gimbal z, z forward = gimbal x).

    >>> R = rotation_from_ypr(0.0, -90.0, 0.0)  # nadir, image top north
    >>> (R[:, 2].round(6) + 0.0).tolist(), (-R[:, 1].round(6) + 0.0).tolist()  # optical axis, image up
    ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0])
    """
    return _NED_TO_ENU @ body_to_ned(yaw, pitch, roll) @ _CV_IN_GIMBAL


def ypr_from_rotation(R_cv_enu) -> tuple[float, float, float]:
    """Inverse of :func:`rotation_from_ypr`: (yaw in (−180, 180], pitch in [−90, 90], roll), degrees.

    At pitch ±90 (gimbal lock) yaw and roll are not separable: roll is returned as 0 and yaw
    carries the whole turn about the vertical (the image-top heading at nadir).
    """
    M = _NED_TO_ENU.T @ np.asarray(R_cv_enu, dtype=np.float64) @ _CV_IN_GIMBAL.T
    pitch = math.asin(max(-1.0, min(1.0, -M[2, 0])))
    if abs(M[2, 0]) > 1 - 1e-12:
        # M = Rz(y)·Ry(±90)·Rx(r): only y ∓ r is defined; report it all as yaw (roll 0)
        yaw = math.atan2(-M[0, 1], M[1, 1])
        return math.degrees(yaw), math.degrees(pitch), 0.0
    yaw = math.atan2(M[1, 0], M[0, 0])
    roll = math.atan2(M[2, 1], M[2, 2])
    return math.degrees(yaw), math.degrees(pitch), math.degrees(roll)


def rotation_from_body_ypr(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """Camera (OpenCV axes) -> ENU rotation of a nadir camera fixed in an aircraft body (degrees).

    Pix4D's / senseFly's convention (module docstring): ``R = NED→ENU · Rz(yaw)·Ry(pitch)·Rx(roll)
    · C`` with the camera looking along the body's z (down) and the image top towards the nose.

    >>> R = rotation_from_body_ypr(90.0, 0.0, 0.0)  # level flight towards east
    >>> (R[:, 2].round(6) + 0.0).tolist(), (-R[:, 1].round(6) + 0.0).tolist()  # optical axis, image up
    ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0])
    """
    return _NED_TO_ENU @ body_to_ned(yaw, pitch, roll) @ _CV_IN_BODY


def meridian_convergence(lon: float, lat: float, map_crs) -> float:
    """γ in degrees: the angle from true north to grid north of ``map_crs`` at (lon, lat), positive
    clockwise (:func:`fotogeo.geometry.local_frames.grid_angle`; 0 for a geographic CRS)."""
    from pyproj import CRS

    from .local_frames import grid_angle
    crs = CRS.from_user_input(map_crs)
    if not crs.is_projected:
        return 0.0
    return float(np.degrees(grid_angle(crs, lon, lat))[0])


def enu_to_map(lon: float, lat: float, map_crs) -> np.ndarray:
    """The 3x3 rotation ENU -> map grid axes (E_grid, N_grid, Up) at (lon, lat): ``Rz(γ)``."""
    return _rz(math.radians(meridian_convergence(lon, lat, map_crs)))


def patb_in_map(R_cam_cv_to_enu, lon: float, lat: float, map_crs) -> tuple[float, float, float]:
    """PATB (ω, φ, κ) in degrees, in ``map_crs`` at (lon, lat), of a camera (OpenCV axes) -> ENU rotation.

    ``R_patb = Rz(γ) · R_cv→ENU · diag(1, −1, −1)`` (:func:`enu_to_map`,
    :func:`fotogeo.geometry.camera.angles_patb`).

    >>> [round(a, 4) + 0.0 for a in patb_in_map(rotation_from_ypr(0, -90, 0), 139.0, 37.5, "EPSG:32654")]
    [0.0, 0.0, -1.2178]
    """
    R_map = enu_to_map(lon, lat, map_crs) @ np.asarray(R_cam_cv_to_enu, dtype=np.float64)
    return angles_patb(R_map @ _D)


def enu_rotation_from_patb(angles, lon: float, lat: float, map_crs) -> np.ndarray:
    """Inverse of :func:`patb_in_map`: the camera (OpenCV axes) -> ENU rotation of PATB ``angles``."""
    return enu_to_map(lon, lat, map_crs).T @ rotation_patb(*angles) @ _D
