"""RPC00B rational polynomial coefficients: read vendor files, convert to/from fotogeo RFMs.

An :class:`Rpc` holds the RPC00B ground -> image model: offsets and scales of line, sample,
latitude, longitude and height, and the 20 coefficients of the line and sample numerators
and denominators in the RPC00B term order (see :func:`fotogeo.models.polynomial.terms_3d`,
with ``L`` = normalised longitude, ``P`` = latitude, ``H`` = height)::

    samp = SAMP_OFF + SAMP_SCALE · (SAMP_NUM · t) / (SAMP_DEN · t)
    line = LINE_OFF + LINE_SCALE · (LINE_NUM · t) / (LINE_DEN · t)

Line/sample are in the RPC's own pixel convention: the *centre* of the first pixel is
(0, 0) (checked: GDAL's RPC transformer reports ``(samp, line) + 0.5``), so fotogeo's GDAL-corner
pixels are ``(samp, line) + 0.5`` (:func:`fotogeo.pixels.from_centre`). :meth:`Rpc.project`
returns RPC-convention values; :meth:`Rpc.to_model` and :meth:`Rpc.from_model` convert to and
from fotogeo models in the corner convention. Vendor files in another convention are converted by
their reader (DIMAP numbers pixels from 1: :mod:`fotogeo.io.rpc_xml` subtracts 1 from its offsets).

Readers (one per format, :func:`fotogeo.io.rpc.read_rpc` picks by content): ``KEY: value`` text
(IKONOS, Planet, SkySat), DIMAP and DigitalGlobe XML, OSSIM ``.geom``, ``.RPB``, GDAL RPC metadata.
:meth:`Rpc.to_model` gives a :class:`fotogeo.models.rfm.RFM` with ``src = (lon, lat, h)`` ->
``dst = (samp, line)`` that evaluates identically (and inverts with ``inverse(dst, heights)``), and
:meth:`Rpc.from_model` goes back.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..models.base import Normalisation
from ..models.polynomial import terms_3d
from ..pixels import from_centre, to_centre

_SCALARS = ("LINE_OFF", "SAMP_OFF", "LAT_OFF", "LONG_OFF", "HEIGHT_OFF",
            "LINE_SCALE", "SAMP_SCALE", "LAT_SCALE", "LONG_SCALE", "HEIGHT_SCALE")
_ARRAYS = ("LINE_NUM_COEFF", "LINE_DEN_COEFF", "SAMP_NUM_COEFF", "SAMP_DEN_COEFF")


@dataclass(frozen=True)
class Rpc:
    """RPC00B model (see the module docstring); coefficient arrays have 20 values each."""

    line_off: float
    samp_off: float
    lat_off: float
    long_off: float
    height_off: float
    line_scale: float
    samp_scale: float
    lat_scale: float
    long_scale: float
    height_scale: float
    line_num: np.ndarray
    line_den: np.ndarray
    samp_num: np.ndarray
    samp_den: np.ndarray

    @classmethod
    def from_mapping(cls, d: dict, source: str = "RPC") -> Rpc:
        """Build from a ``{KEY: value}`` mapping with RPC00B keys (arrays as 20 ``KEY_i`` or one list)."""
        try:
            scal = [float(d[k]) for k in _SCALARS]
            arrs = []
            for k in _ARRAYS:
                if k in d:
                    a = np.asarray(d[k], dtype=np.float64).reshape(-1)
                else:
                    a = np.array([float(d[f"{k}_{i}"]) for i in range(1, 21)])
                if a.size != 20:
                    raise InputError(f"{source}: {k} must have 20 values; got {a.size}")
                arrs.append(a)
        except InputError:
            raise
        except KeyError as exc:
            raise InputError(f"{source}: missing RPC00B key {exc.args[0]}; is this an RPC file?") from None
        except (ValueError, TypeError) as exc:
            raise InputError(f"{source}: non-numeric RPC value ({exc})") from None
        return cls(*scal, *arrs)

    def project(self, lon, lat, h) -> np.ndarray:
        """Ground (lon, lat, h) -> ``(N, 2)`` (samp, line) in the RPC's pixel convention."""
        L = (np.asarray(lon, float).reshape(-1) - self.long_off) / self.long_scale
        P = (np.asarray(lat, float).reshape(-1) - self.lat_off) / self.lat_scale
        H = (np.asarray(h, float).reshape(-1) - self.height_off) / self.height_scale
        T = terms_3d(np.column_stack(np.broadcast_arrays(L, P, H)))
        samp = self.samp_off + self.samp_scale * (T @ self.samp_num) / (T @ self.samp_den)
        line = self.line_off + self.line_scale * (T @ self.line_num) / (T @ self.line_den)
        return np.column_stack([samp, line])

    def to_model(self):
        """The same mapping as a fotogeo ``rfm`` model: (lon, lat, h) -> (col, row), corner convention."""
        from ..models.rfm import RFM

        params = np.concatenate([self.samp_num, self.samp_den, self.line_num, self.line_den])
        src = Normalisation(np.array([self.long_off, self.lat_off, self.height_off]),
                            np.array([self.long_scale, self.lat_scale, self.height_scale]))
        dst = Normalisation(from_centre(np.array([self.samp_off, self.line_off])),
                            np.array([self.samp_scale, self.line_scale]))
        return RFM(params, src, dst, {"source": "RPC00B"})

    @classmethod
    def from_model(cls, model) -> Rpc:
        """RPC00B from a fotogeo ground -> image RFM fitted with src = (lon, lat, h), dst = (col, row)
        in the corner convention.

        The denominators are scaled so that their constant term is 1 (RPC00B requires it).
        """
        if getattr(model, "src_dims", 2) != 3 or not hasattr(model, "coefficients"):
            raise InputError(f"RPC export needs an RFM model ('rfm', 'rfm-common', 'rfm-poly'); got {model.name!r}")
        if getattr(model, "direction", "") != "ground-to-image":
            raise InputError(f"RPC00B is ground -> image; model {model.name!r} was fitted {model.direction}")
        nx, dx, ny, dy = model.coefficients
        nx, dx, ny, dy = nx / dx[0], dx / dx[0], ny / dy[0], dy / dy[0]
        so, ss = model.src_norm.offset, model.src_norm.scale
        do, ds = to_centre(model.dst_norm.offset), model.dst_norm.scale
        return cls(do[1], do[0], so[1], so[0], so[2], ds[1], ds[0], ss[1], ss[0], ss[2], ny, dy, nx, dx)

    def to_gdal_metadata(self) -> dict[str, str]:
        """GDAL ``RPC`` metadata domain (values as GDAL writes them)."""
        f = "{:.15g}".format
        md = {k: f(getattr(self, k.lower())) for k in _SCALARS}
        for k, a in zip(_ARRAYS, (self.line_num, self.line_den, self.samp_num, self.samp_den)):
            md[k] = " ".join(f"{v:.15e}" for v in a)
        return md


# -- fitting and GDAL export -----------------------------------------------------------------

def fit_rpc(ground, pixels, crs, *, model: str = "rfm") -> tuple[Rpc, object]:
    """Fit a ground -> image RFM in (lon, lat, h) and return it as RPC00B with the fitted model.

    ``ground`` ``(N, 3)`` are X, Y, h in ``crs`` (any pyproj-readable CRS; converted to WGS 84
    longitude/latitude, the RPC00B ground space; ``h`` is kept as given — use the vertical datum
    of the DEM that will be used with the RPC), ``pixels`` ``(N, 2)`` the corner-convention
    image coordinates. Returns ``(rpc, rfm_model)``.
    """
    from pyproj import CRS, Transformer

    from ..models import get_model

    g = np.asarray(ground, dtype=np.float64)
    tr = Transformer.from_crs(CRS.from_user_input(crs), CRS.from_epsg(4326), always_xy=True)
    lon, lat = tr.transform(g[:, 0], g[:, 1])
    m = get_model(model).estimate(np.column_stack([lon, lat, g[:, 2]]), pixels)
    return Rpc.from_model(m), m


def frame_rpc(frame, crs, z_range, *, grid: int = 15, levels: int = 7, model: str = "rfm"):
    """RPC00B of an :class:`~fotogeo.geometry.camera.OrientedFrame`: sample a ``grid`` x ``grid`` pixel grid
    (corner to corner) at ``levels`` heights spanning ``z_range`` = (zmin, zmax), lift the pixels
    to ground with the exact geometry and fit with :func:`fit_rpc`. Returns ``(rpc, rfm_model)``."""
    w, h = frame.camera.image_size
    cols, rows = np.meshgrid(np.linspace(0, w, grid), np.linspace(0, h, grid))
    px = np.column_stack([cols.ravel(), rows.ravel()])
    zs = np.linspace(float(z_range[0]), float(z_range[1]), levels)
    ground = np.vstack([frame.pixel_to_world_at(px, z) for z in zs])
    return fit_rpc(ground, np.tile(px, (levels, 1)), crs, model=model)
