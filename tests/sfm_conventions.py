"""The conventions the held-out SfM projects (tests/sfm_projects.py) are written in: the truth's CRS and camera axes
(:func:`pose_cv`), each tool's camera equations (:func:`tool_pixel`), map / geographic / ECEF / OpenSfM-topocentric
conversions (pyproj only) and the GPS an image carries (:func:`gps_of`)."""
from __future__ import annotations

import math

import numpy as np

TRUTH_CRS = "EPSG:32633"
D = np.diag([1.0, -1.0, -1.0])


def gps_of(path) -> tuple:
    from fotogeo.io.exif import read_image_metadata
    m = read_image_metadata(str(path))
    assert m.altitude is not None, f"{path} carries no GPS altitude: a test project needs one (never taken as 0)"
    return float(m.lon), float(m.lat), float(m.altitude)


def pose_cv(eo) -> tuple:
    """``(C, R_wc)``: centre and world -> OpenCV-camera rotation in the map CRS of a PATB orientation."""
    return np.array([eo.X, eo.Y, eo.Z]), (eo.rotation @ D).T


# -- the cameras, each with its tool's equations -------------------------------------------------------------------
def brown(u, v, k1=0.0, k2=0.0, k3=0.0, p1=0.0, p2=0.0, k4=0.0, k5=0.0, k6=0.0):
    """OpenCV's distortion (COLMAP OPENCV/FULL_OPENCV, OpenSfM brown, orthority brown/opencv) of
    ``(u, v) = (x/z, y/z)``."""
    r2 = u * u + v * v
    rad = (1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3) / (1 + k4 * r2 + k5 * r2 ** 2 + k6 * r2 ** 3)
    return u * rad + 2 * p1 * u * v + p2 * (r2 + 2 * u * u), v * rad + p1 * (r2 + 2 * v * v) + 2 * p2 * u * v


def tool_pixel(cam: dict, xc: np.ndarray) -> np.ndarray:
    """Pixels (top-left corner at (0, 0)) of camera points ``xc`` (OpenCV axes) through ``cam`` as its tool defines it:
    ``{"tool": "colmap", "model", "params"}``, ``{"tool": "opensfm", ...camera dict}`` or
    ``{"tool": "orthority", ...}``."""
    u, v = xc[:, 0] / xc[:, 2], xc[:, 1] / xc[:, 2]
    if cam["tool"] == "colmap":
        p = cam["params"]
        m = cam["model"]
        if m in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
            f, cx, cy = p[:3]
            k = list(p[3:]) + [0.0, 0.0]
            r2 = u * u + v * v
            rad = 1 + k[0] * r2 + k[1] * r2 ** 2
            return np.column_stack([f * u * rad + cx, f * v * rad + cy])
        fx, fy, cx, cy = p[:4]
        names = {"PINHOLE": (), "OPENCV": ("k1", "k2", "p1", "p2"),
                 "FULL_OPENCV": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")}[m]
        du, dv = brown(u, v, **dict(zip(names, p[4:])))
        return np.column_stack([fx * du + cx, fy * dv + cy])
    w, h = cam["width"], cam["height"]
    m = max(w, h)
    if cam["tool"] == "opensfm":  # normalised coordinates, (0, 0) at the centre, pixel centres at (i - (w-1)/2)/m
        fx = cam.get("focal_x", cam.get("focal"))
        fy = cam.get("focal_y", fx)
        du, dv = brown(u, v, *(cam.get(k, 0.0) for k in ("k1", "k2", "k3", "p1", "p2")))
        xn, yn = fx * du + cam.get("c_x", 0.0), fy * dv + cam.get("c_y", 0.0)
        return np.column_stack([xn * m + (w - 1) / 2 + 0.5, yn * m + (h - 1) / 2 + 0.5])
    # orthority: focal_len over max(w, h) without sensor_size; principal point w/2 + cx·max(w, h)
    f = cam["focal_len"] * m
    du, dv = brown(u, v, *(cam.get(k, 0.0) for k in ("k1", "k2", "k3", "p1", "p2")))
    return np.column_stack([f * du + w / 2 + cam.get("cx", 0.0) * m, f * dv + h / 2 + cam.get("cy", 0.0) * m])


# -- geodesy (pyproj only) -----------------------------------------------------------------------------------------
def _t(src, dst):
    from pyproj import Transformer
    return Transformer.from_crs(src, dst, always_xy=True)


def map_to_llh(P, crs=TRUTH_CRS):
    lon, lat = _t(crs, 4326).transform(P[:, 0], P[:, 1])
    return np.column_stack([lon, lat, P[:, 2]])


def llh_to_map(L, crs=TRUTH_CRS):
    x, y = _t(4326, crs).transform(L[:, 0], L[:, 1])
    return np.column_stack([x, y, L[:, 2]])


def llh_to_ecef(L):
    return np.column_stack(_t(4979, 4978).transform(L[:, 0], L[:, 1], L[:, 2]))


def ecef_to_llh(X):
    return np.column_stack(_t(4978, 4979).transform(X[:, 0], X[:, 1], X[:, 2]))


def enu_axes(lat, lon) -> np.ndarray:
    """Rows: east, north, up unit vectors in ECEF at ``lat, lon``."""
    la, lo = math.radians(lat), math.radians(lon)
    return np.array([[-math.sin(lo), math.cos(lo), 0], [-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo),
                                                          math.cos(la)],
                     [math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la)]])


def to_topo(P_map, ref, crs=TRUTH_CRS):
    """Map positions -> OpenSfM topocentric at ``ref = (lat, lon, alt)``."""
    X0 = llh_to_ecef(np.array([[ref[1], ref[0], ref[2]]]))[0]
    return (llh_to_ecef(map_to_llh(P_map, crs)) - X0) @ enu_axes(ref[0], ref[1]).T


def from_topo(T, ref, crs=TRUTH_CRS):
    X0 = llh_to_ecef(np.array([[ref[1], ref[0], ref[2]]]))[0]
    return llh_to_map(ecef_to_llh(X0 + T @ enu_axes(ref[0], ref[1])), crs)


def _jacobian(f, x, h=1.0) -> np.ndarray:
    """Rotation part (polar decomposition) of the Jacobian of ``f`` at ``x`` (3-vector -> 3-vector)."""
    J = np.column_stack([(f((x + h * e)[None])[0] - f((x - h * e)[None])[0]) / (2 * h) for e in np.eye(3)])
    U, _, Vt = np.linalg.svd(J)
    return U @ Vt


def topo_pose(C, R, ref, crs=TRUTH_CRS):
    """A map pose in OpenSfM's topocentric frame at ``ref``: ``(C_topo, R_wc_topo)``."""
    J = _jacobian(lambda P: to_topo(P, ref, crs), C)  # map vectors -> topocentric vectors
    return to_topo(C[None], ref, crs)[0], R @ J.T
