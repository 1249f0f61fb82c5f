"""Which reading of an SfM local frame the evidence supports, and whether an SfM file agrees with the images' GPS.

An OpenSfM ``reconstruction.json`` holds local coordinates that OpenSfM reads as a topocentric frame and
ODM as offsets parallel to the UTM grid from UTM(``reference_lla``) (GUIDE.md §7). The two readings agree
at the reference and part with the distance from it: by the meridian convergence γ (≈ Δλ·sin φ, largest
at high latitude far from the zone's central meridian) and the grid's scale. Nothing in the file says which
(``gps_position`` is the image GPS converted by the same reading as the centres), so the reading is
decided by **evidence**, in this order:

1. ``gps_position`` of the shots against the absolute GPS of the same images — the images' own EXIF when
   they are given, else OpenSfM's ``exif/<image>.exif`` beside the reconstruction: both are the same
   numbers, so the right reading reproduces them to the precision of the EXIF tags (σ :data:`TAG_SIGMA`);
2. the shots' centres against the images' own EXIF GPS, with the σ of their accuracy tags (DJI RTK,
   senseFly) or :data:`DEFAULT_SIGMA_H` (a consumer receiver).

With horizontal residuals ``r_i`` and σ ``s_i`` of each reading, ``χ² = Σ |r_i|²/s_i²``: a reading is
chosen when it fits (``χ²/(2n) ≤ 9``, RMS within 3σ) and the other fits worse by ``Δχ² ≥ 25`` (a 5σ
separation). When the two readings place every camera within :data:`SAME_M` and :data:`SAME_DEG` of each
other the choice is immaterial (topocentric is taken and said). Otherwise the file is refused, naming the
option ``sfm_frame``. Heights are not compared (the GPS altitude's reference is often unknown).

:func:`check_gps` is the same test for any SfM block (COLMAP, orthority, OpenSfM after its reading): the
block's centres must agree with the images' own GPS within 3σ horizontally (RMS), else it is refused by name.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: σ (m) of a consumer receiver's horizontal GPS position, when the image carries no accuracy tag
DEFAULT_SIGMA_H = 5.0
#: σ (m) to which the same GPS written twice (EXIF rationals, OpenSfM's exif JSON) agrees with itself
TAG_SIGMA = 0.05
#: readings closer than these everywhere are the same for every purpose
SAME_M, SAME_DEG = 0.005, 2e-4
READINGS = ("topocentric", "grid")
_WHAT = {"topocentric": "OpenSfM's topocentric frame", "grid": "ODM's offsets along the UTM grid"}


@dataclass(frozen=True)
class GpsFix:
    """An image's own GPS: lon, lat (degrees), altitude (m) and the σ of its horizontal position (m)."""

    lon: float
    lat: float
    alt: float
    sigma_h: float
    tagged: bool  # the σ comes from the image's accuracy tags (else DEFAULT_SIGMA_H)


def images_gps(paths) -> dict:
    """``{frame key: GpsFix}`` of the images in ``paths`` that carry an EXIF/XMP GPS position."""
    from .block import frame_key
    from .exif import read_image_metadata
    from .exif_block import position_sigmas
    out = {}
    for p in paths or ():
        m = read_image_metadata(str(p))
        if m.lon is None or m.lat is None:
            continue
        sh = position_sigmas(m)[0]
        out[frame_key(p)] = GpsFix(float(m.lon), float(m.lat), float(m.altitude or 0.0),
                                   float(sh) if sh else DEFAULT_SIGMA_H, bool(sh))
    return out


def _map_xy(crs, lon, lat) -> np.ndarray:
    from ..crs import transform_points
    return transform_points("EPSG:4326", crs, np.column_stack([np.asarray(lon, float), np.asarray(lat, float)]))


def _chi2(res, sigma) -> float:
    return float(np.sum(np.sum(res ** 2, axis=1) / sigma ** 2))


def _rms(res) -> float:
    return float(np.sqrt(np.mean(np.sum(res ** 2, axis=1))))


def separation(ref, crs, centres) -> tuple[float, float]:
    """``(metres, degrees)``: the largest distance and turn between the two readings of ``centres`` (local)."""
    from ..geometry.local_frames import LocalFrame
    (pa, ma), (pb, mb) = (LocalFrame(k, ref, crs).to_map(centres) for k in READINGS)
    turn = np.einsum("nij,nkj->nik", ma, mb)
    ang = np.degrees(np.arccos(np.clip((np.trace(turn, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)))
    return float(np.max(np.linalg.norm(pa - pb, axis=1))), float(np.max(ang))


def decide(local: dict, gps: dict, ref, crs, source: str):
    """``(reading, sentence)`` from ``local`` ``{name: local xyz}`` against ``gps`` ``{name: (lon, lat, σ)}``
    (module docstring), or ``(None, sentence)`` when they cannot tell or contradict both readings."""
    from ..geometry.local_frames import LocalFrame
    names = sorted(set(local) & set(gps))
    if not names:
        return None, f"none of the images with {source} is a shot of the reconstruction"
    xyz = np.array([local[n] for n in names], float)
    ev = np.array([gps[n] for n in names], float)
    want, sigma = _map_xy(crs, ev[:, 0], ev[:, 1]), ev[:, 2]
    res = {k: LocalFrame(k, ref, crs).to_map(xyz)[0][:, :2] - want for k in READINGS}
    chi = {k: _chi2(r, sigma) for k, r in res.items()}
    best = min(chi, key=chi.get)
    other = READINGS[1 - READINGS.index(best)]
    said = (f"{source} ({len(names)} image(s), σ {np.median(sigma):.3g} m): {_rms(res[best]):.3f} m RMS "
            f"horizontally as {best}, {_rms(res[other]):.3f} m as {other}")
    if chi[best] / (2 * len(names)) > 9.0:
        return None, f"neither reading fits the {said}"
    if chi[other] - chi[best] < 25.0:
        return None, f"the {said}: too close to tell"
    return best, f"read as {best}: {_WHAT[best]} fits the {said}"


def check_gps(block, gps: dict, what: str, option: str | None = None) -> str:
    """The sentence saying how ``block``'s centres agree with the images' own ``gps`` ({name: GpsFix}); an
    :class:`InputError` naming ``what`` and the frames furthest off when the horizontal RMS exceeds 3σ."""
    names = sorted(n for n in gps if n in block.shots and block.shots[n].position is not None)
    if not names or block.crs is None:
        return ""
    pos = np.array([block.shots[n].position[:2] for n in names], float)
    want = _map_xy(block.crs, [gps[n].lon for n in names], [gps[n].lat for n in names])
    sigma = np.array([max(gps[n].sigma_h, TAG_SIGMA) for n in names])
    off = np.linalg.norm(pos - want, axis=1)
    rms, s = _rms(pos - want), float(np.sqrt(np.mean(sigma ** 2)))
    if rms > 3.0 * s:
        worst = [f"{names[i]} {off[i]:.2f} m" for i in np.argsort(-off)[:3]]
        raise InputError(f"{what}: its camera centres are {rms:.2f} m RMS (horizontally) from the images' own GPS, "
                         f"more than 3 x their sigma {s:.3g} m ({', '.join(worst)}); the file was made in another "
                         f"frame or CRS than it is read in, or for other images — check its CRS"
                         + (f" and {option}" if option else ""), option=option)
    return (f"camera centres {rms:.3f} m RMS horizontally from the images' own GPS of {len(names)} image(s) "
            f"(σ {s:.3g} m)")


def refusal(where: str, why: str, sep: tuple) -> InputError:
    """The refusal of an undecided reading (module docstring), naming ``sfm_frame``."""
    m, deg = sep
    return InputError(f"{where}: its local coordinates may be OpenSfM's topocentric frame or ODM's offsets along the "
                      f"UTM grid, which place the cameras up to {m:.2f} m and {deg:.2f}° apart here, and {why}; "
                      f"give the images themselves (their EXIF GPS decides), or say which with sfm_frame topocentric "
                      f"(OpenSfM) or grid (ODM)", option="sfm_frame")


def immaterial(sep: tuple) -> bool:
    return sep[0] <= SAME_M and sep[1] <= SAME_DEG and all(map(math.isfinite, sep))
