"""A rendered satellite stereo pair with a known surface: pushbroom-like along-track views from 700 km, RPCs fitted
to the exact geometry, 12-bit uint16 images — the held-out twin of the Pleiades pair ``rpc/ventoux``.

**Surface** (:func:`surface`): on a grid of half a ground sample distance, fractal relief of ``relief`` m standard
deviation (the fractal of :func:`fotogeo.orientation.block_render._fractal`, five octaves: hills down to
wavelengths of 1/64 of the scene) plus 0.15 m of white-ish roughness, a tilted
plane (a valley side), and flat-roofed "buildings" — rectangles 8–40 m a side, 4–20 m high, one per 5000 m² —
whose walls are the steps a satellite DSM meets in towns. Heights are ellipsoidal (what an RPC uses).

**Sensor** (:class:`Pushbroom`, corner convention: pixel ``(i, j)`` covers ``[i, i+1) x [j, j+1)``): a line array
at ``ALTITUDE`` above the scene looking ``incidence`` along track (steady pitch), the track turned ``heading`` from
north. In track axes (``a`` across, ``b`` along, from the view's centre at height ``z0``) a ground point
``(a, b, z)`` lies on the line ``u = row - n/2`` with ``b + (z - z0)·tan θ = -g·(u + q·u²/n)`` (its scan plane;
``q`` a slow along-track rate drift of 1.5 px at the image's ends) and on the column
``col = n/2 + f·a / D``, ``D = (ALTITUDE + z0 - z) / cos θ``, ``f = ALTITUDE / (g·cos θ)`` (a perspective across
track). Two views at incidences ``±atan(B/H / 2)`` give the base-to-height ratio B/H.

**Rendering** by inverse mapping: each pixel (2 x 2 sub-samples, an area average) follows its line of sight down
from above the highest ground in steps of one surface cell horizontally; the first step under the surface is
refined by bisection (walls and occlusions come out as a satellite sees them). The ground texture (one texel per
surface cell: ``rendered_pair._texture``, the statistics per texel of
:func:`fotogeo.orientation.block_render.texture` at any size; that one's patches and octaves follow the tile's
size, and a 2048² pair had 9 % of its ground in uniform patches up to 36 m wide) is sampled bilinearly, blurred by a
Gaussian MTF (σ 0.45 px), turned into 12-bit counts with a different gain, offset and gamma per view, and given
shot noise and 3 counts of read noise.

**RPC**: fitted to the exact geometry (:func:`fotogeo.orientation.rpc.fit_rpc`, 21 x 21 pixels at 7 heights
over the surface's range ± 60 m); its largest error on an independent 33 x 33 x 9 grid is returned
(``rpc_check_px``). ``pointing`` (col, row) px is added to the *second* image's RPC offsets only: a relative
pointing error (the image stays exact). ``rpc_format``: ``"gdal"`` (GeoTIFF RPC tags), ``"rpb"`` (a DigitalGlobe
``.RPB`` beside the image, 0-based), ``"dimap"`` (``IMG_<name>_R1C1.tif`` with a DIMAP v2 ``RPC_<name>.XML``
beside it, 1-based offsets, as Pleiades products are delivered).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

ALTITUDE = 700_000.0
CRS = "EPSG:32633"
CENTRE = np.array([452_000.0, 5_121_000.0])  # UTM 33N (Austria): another place than ventoux (31N)
Z0 = 850.0


@dataclass(frozen=True)
class Pushbroom:
    """One along-track view (module docstring)."""

    n: int
    gsd: float
    incidence: float  # radians, + looks ahead (towards +b)
    heading: float  # radians, the track's azimuth from north
    centre: tuple  # (x, y) map position of the image centre at height Z0
    q: float = 1.5  # along-track drift at the ends (px)

    def _axes(self):
        s, c = np.sin(self.heading), np.cos(self.heading)
        return np.array([c, -s]), np.array([s, c])  # unit across (a) and along (b) track in map (x, y)

    def ground_to_image(self, x, y, z):
        """Map ``x, y`` and height ``z`` -> ``(col, row)`` (corner convention)."""
        ea, eb = self._axes()
        dx, dy = np.asarray(x, float) - self.centre[0], np.asarray(y, float) - self.centre[1]
        a, b = dx * ea[0] + dy * ea[1], dx * eb[0] + dy * eb[1]
        t = np.tan(self.incidence)
        br = -(b + (np.asarray(z, float) - Z0) * t) / self.gsd  # = u + k u²
        k = 4 * self.q / self.n ** 2
        u = 2 * br / (1 + np.sqrt(1 + 4 * k * br))
        f = ALTITUDE / (self.gsd * np.cos(self.incidence))
        d = (ALTITUDE + Z0 - np.asarray(z, float)) / np.cos(self.incidence)
        return self.n / 2 + f * a / d, self.n / 2 + u

    def image_to_ground(self, col, row, z):
        """``(col, row)`` at height ``z`` -> map ``(x, y)``."""
        ea, eb = self._axes()
        u = np.asarray(row, float) - self.n / 2
        k = 4 * self.q / self.n ** 2
        t = np.tan(self.incidence)
        b = -self.gsd * (u + k * u * u) - (np.asarray(z, float) - Z0) * t
        f = ALTITUDE / (self.gsd * np.cos(self.incidence))
        a = (np.asarray(col, float) - self.n / 2) * (ALTITUDE + Z0 - np.asarray(z, float)) / np.cos(self.incidence) / f
        return self.centre[0] + a * ea[0] + b * eb[0], self.centre[1] + a * ea[1] + b * eb[1]


def surface(n_cells: int, cell: float, seed: int = 0, relief: float = 25.0):
    """``(heights, transform)``: the truth surface (module docstring), ``n_cells`` x ``n_cells`` of ``cell`` m
    centred on ``CENTRE``."""
    from affine import Affine

    from fotogeo.orientation.block_render import _fractal
    rng = np.random.default_rng(seed + 1000)
    z = Z0 + relief * _fractal(rng, (n_cells, n_cells), octaves=5, persistence=0.45).astype(np.float64)
    z += 0.15 * _fractal(rng, (n_cells, n_cells), octaves=10, persistence=1.0)  # roughness (vegetation, rubble)
    jj, ii = np.meshgrid(np.arange(n_cells), np.arange(n_cells))
    z += 0.08 * cell * (jj - n_cells / 2) - 0.05 * cell * (ii - n_cells / 2)
    side = n_cells * cell
    for _ in range(int(side * side / 5000)):
        w, h = rng.uniform(8, 40, 2) / cell
        r, c = rng.uniform(0, n_cells, 2)
        r0, r1, c0, c1 = int(r), int(min(n_cells, r + h)), int(c), int(min(n_cells, c + w))
        z[r0:r1, c0:c1] = np.median(z[r0:r1, c0:c1]) + rng.uniform(4, 20)
    t = Affine(cell, 0, CENTRE[0] - side / 2, 0, -cell, CENTRE[1] + side / 2)
    return z.astype(np.float32), t


def _sample(img, t, x, y):
    """Bilinear sample of the grid ``img`` (transform ``t``) at map ``x, y`` (outside: the edge)."""
    import cv2
    x, y = np.broadcast_arrays(x, y)
    mx = ((x - t.c) / t.a - 0.5).astype(np.float32).reshape(-1)
    my = ((y - t.f) / t.e - 0.5).astype(np.float32).reshape(-1)
    pad = -len(mx) % 4096  # remap's maps are 2-D, below 32767 a side
    mx, my = (np.pad(m, (0, pad)).reshape(-1, 4096) for m in (mx, my))
    out = cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(-1)[:x.size].reshape(x.shape)


def _first_hit(cam: Pushbroom, z_grid, t, col, row):
    """Map ``(x, y, z)`` where each pixel's line of sight first meets the surface (module docstring)."""
    zmax, zmin = float(z_grid.max()) + 1, float(z_grid.min()) - 1
    slope = max(abs(np.tan(cam.incidence)), 1e-3)
    dz = t.a / slope  # one cell of horizontal travel
    hi = np.full(col.shape, zmax)  # above the ground
    lo = np.full(col.shape, np.nan)
    z = zmax
    while z > zmin and np.isnan(lo).any():
        z = max(z - dz, zmin)
        x, y = cam.image_to_ground(col, row, z)
        below = np.isnan(lo) & (z <= _sample(z_grid, t, x, y))
        lo[below] = z
        hi[np.isnan(lo)] = z
    lo[np.isnan(lo)] = zmin
    for _ in range(8):  # bisection between the last point above and the first below
        mid = 0.5 * (hi + lo)
        x, y = cam.image_to_ground(col, row, mid)
        under = mid <= _sample(z_grid, t, x, y)
        lo, hi = np.where(under, mid, lo), np.where(under, hi, mid)
    z = 0.5 * (hi + lo)
    return (*cam.image_to_ground(col, row, z), z)


def _render(cam: Pushbroom, z_grid, t, tex, gain, offset, gamma, rng):
    import cv2
    out = np.zeros((cam.n, cam.n), np.float32)
    for r0 in range(0, cam.n, 128):
        rows = min(128, cam.n - r0)
        acc = np.zeros((rows, cam.n), np.float32)
        for du, dv in ((0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)):
            c, r = np.meshgrid(np.arange(cam.n) + du, np.arange(r0, r0 + rows) + dv)
            x, y, _ = _first_hit(cam, z_grid, t, c, r)
            acc += _sample(tex, t, x, y)
        out[r0:r0 + rows] = acc / 4
    out = cv2.GaussianBlur(out, (0, 0), 0.45)
    dn = offset + gain * 255.0 * (out / 255.0) ** gamma
    dn = dn + rng.normal(0, 1, dn.shape) * np.sqrt(dn / 4 + 9.0)  # shot noise (4 e-/count) + read noise 3
    return np.clip(np.round(dn), 1, 4095).astype(np.uint16)


def _fit(cam: Pushbroom, zr):
    from fotogeo.orientation.rpc import fit_rpc
    from pyproj import Transformer
    g = np.linspace(0, cam.n, 21)
    cc, rr = np.meshgrid(g, g)
    ground, px = [], []
    for z in np.linspace(*zr, 7):
        x, y = cam.image_to_ground(cc.ravel(), rr.ravel(), z)
        ground.append(np.column_stack([x, y, np.full(x.shape, z)]))
        px.append(np.column_stack([cc.ravel(), rr.ravel()]))
    rpc, model = fit_rpc(np.vstack(ground), np.vstack(px), CRS)
    rng = np.random.default_rng(7)
    cc, rr = rng.uniform(0, cam.n, (2, 33 * 33 * 9))
    zz = rng.uniform(*zr, cc.size)
    x, y = cam.image_to_ground(cc, rr, zz)
    lon, lat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(x, y)
    err = model.forward(np.column_stack([lon, lat, zz])) - np.column_stack([cc, rr])
    return rpc, float(np.abs(err).max())


def _write_rpc(path: Path, rpc, fmt: str):
    import rasterio
    if fmt == "gdal":
        with rasterio.open(path, "r+") as ds:
            ds.update_tags(ns="RPC", **rpc.to_gdal_metadata())
        return
    md = rpc.to_gdal_metadata()
    if fmt == "rpb":
        names = {"LINE_OFF": "lineOffset", "SAMP_OFF": "sampOffset", "LAT_OFF": "latOffset",
                 "LONG_OFF": "longOffset", "HEIGHT_OFF": "heightOffset", "LINE_SCALE": "lineScale",
                 "SAMP_SCALE": "sampScale", "LAT_SCALE": "latScale", "LONG_SCALE": "longScale",
                 "HEIGHT_SCALE": "heightScale"}
        lines = ['satId = "SIM";', 'bandId = "P";', 'SpecId = "RPC00B";', "BEGIN_GROUP = IMAGE",
                 "\terrBias = 1.0;", "\terrRand = 0.0;"]
        lines += [f"\t{v} = {md[k]};" for k, v in names.items()]
        for k, v in (("LINE_NUM_COEFF", "lineNumCoef"), ("LINE_DEN_COEFF", "lineDenCoef"),
                     ("SAMP_NUM_COEFF", "sampNumCoef"), ("SAMP_DEN_COEFF", "sampDenCoef")):
            lines.append(f"\t{v} = (\n\t\t\t" + ",\n\t\t\t".join(md[k].split()) + ");")
        lines += ["END_GROUP = IMAGE", "END;"]
        path.with_suffix(".RPB").write_text("\n".join(lines) + "\n")
        return
    # DIMAP v2: 1-based pixel numbers (the first pixel's centre is (1, 1))
    md["LINE_OFF"], md["SAMP_OFF"] = f"{rpc.line_off + 1:.15g}", f"{rpc.samp_off + 1:.15g}"
    inv = "".join(f"<{k}_{i + 1}>{v}</{k}_{i + 1}>" for k in ("LINE_NUM_COEFF", "LINE_DEN_COEFF", "SAMP_NUM_COEFF",
                                                              "SAMP_DEN_COEFF") for i, v in enumerate(md[k].split()))
    val = "".join(f"<{k}>{md[k]}</{k}>" for k in ("LONG_SCALE", "LONG_OFF", "LAT_SCALE", "LAT_OFF", "HEIGHT_SCALE",
                                                   "HEIGHT_OFF", "SAMP_SCALE", "SAMP_OFF", "LINE_SCALE", "LINE_OFF"))
    name = path.stem[4:].rsplit("_R1C1", 1)[0]
    (path.parent / f"RPC_{name}.XML").write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<Dimap_Document name="RPC">'
        "<Metadata_Identification><METADATA_FORMAT>DIMAP</METADATA_FORMAT><METADATA_PROFILE>PHR_SENSOR"
        "</METADATA_PROFILE></Metadata_Identification><Rational_Function_Model><Global_RFM>"
        f"<Inverse_Model>{inv}</Inverse_Model><RFM_Validity>{val}</RFM_Validity>"
        "</Global_RFM></Rational_Function_Model></Dimap_Document>\n")


def render_rpc_pair(folder, size: int = 1024, *, base_height: float = 0.4, gsd: float = 0.7, seed: int = 0,
                    pointing=(0.0, 0.0), rpc_format: str = "gdal", relief: float = 25.0) -> dict:
    """Write the pair (module docstring) into ``folder``: ``{"images", "truth", "truth_transform", "gsd",
    "rpc_check_px", "crs", "cameras"}``; ``truth`` the surface heights on their grid (``truth_transform``),
    ``cameras`` the two exact :class:`Pushbroom` views."""
    import rasterio
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    cell = gsd / 2
    n_cells = int(np.ceil(1.5 * size * gsd / cell))
    z_grid, t = surface(n_cells, cell, seed, relief)
    from rendered_pair import _texture
    tex = _texture(rng, n_cells)  # block_render.texture's statistics per texel at any size
    inc = np.arctan(base_height / 2)
    hd = np.radians(-13.0)  # a descending sun-synchronous track (98° inclination) near 47° N
    cams = [Pushbroom(size, gsd, -inc, hd, tuple(CENTRE + [-6.0, 9.0])),
            Pushbroom(size, gsd * 1.02, inc, hd + np.radians(0.3), tuple(CENTRE + [11.0, -14.0]))]
    zr = (float(z_grid.min()) - 60, float(z_grid.max()) + 60)
    radiometry = ((14.0, 180.0, 1.0), (12.0, 260.0, 0.92))
    paths, worst, rpcs = [], 0.0, []
    for i, (cam, (gain, off, gamma)) in enumerate(zip(cams, radiometry)):
        img = _render(cam, z_grid, t, tex, gain, off, gamma, rng)
        name = f"sim_{'ab'[i]}"
        p = folder / (f"IMG_{name}_R1C1.tif" if rpc_format == "dimap" else f"{name}.tif")
        with rasterio.open(p, "w", driver="GTiff", width=size, height=size, count=1, dtype="uint16", tiled=True,
                           blockxsize=256, blockysize=256, compress="deflate", nbits=12) as ds:
            ds.write(img[None])
        rpc, err = _fit(cam, zr)
        worst = max(worst, err)
        rpcs.append(rpc)
        _write_rpc(p, _offset(rpc, pointing) if i == 1 else rpc, rpc_format)
        paths.append(str(p))
    return {"images": paths, "truth": z_grid, "truth_transform": t, "gsd": gsd, "rpc_check_px": worst, "crs": CRS,
            "cameras": cams, "rpcs": rpcs, "pointing": tuple(pointing)}


def _offset(rpc, pointing):
    from dataclasses import replace
    return replace(rpc, samp_off=rpc.samp_off + pointing[0], line_off=rpc.line_off + pointing[1])


def with_pointing(scene: dict, folder, pointing) -> dict:
    """A copy of ``scene`` (GeoTIFF RPC tags) in ``folder`` whose second RPC is off by ``pointing`` (col, row) px."""
    import shutil
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    images = [str(shutil.copy(p, folder / Path(p).name)) for p in scene["images"]]
    _write_rpc(Path(images[1]), _offset(scene["rpcs"][1], pointing), "gdal")
    return {**scene, "images": images, "pointing": tuple(pointing)}


def pointing_height_bias(scene: dict) -> float:
    """The height error (m) a row (along-track, i.e. along-epipolar) pointing error of the second RPC gives: no
    relative orientation can tell it from a height (it moves a point along its epipolar line), so the DSM's
    heights shift by it, CARS's and s2p's as fotogeo's. ``dz = −Δrow / (∂(row_b − row_a)/∂z)`` at the scene
    centre."""
    a, b = scene["cameras"]
    x, y = CENTRE
    rate = (b.ground_to_image(x, y, Z0 + 1)[1] - a.ground_to_image(x, y, Z0 + 1)[1]) \
        - (b.ground_to_image(x, y, Z0)[1] - a.ground_to_image(x, y, Z0)[1])
    return float(-scene["pointing"][1] / rate)


def _same_horizontal_crs(crs, expected) -> bool:
    """``crs`` (a raster's) is ``expected``, or a compound CRS of it and a vertical CRS (CARS writes UTM + WGS 84
    ellipsoidal height)."""
    from pyproj import CRS as PCRS
    c = PCRS.from_wkt(crs.to_wkt())
    return (c.sub_crs_list[0] if c.is_compound else c).equals(PCRS.from_user_input(expected))


def compare(dsm_path, scene: dict, bias: float = 0.0, shift: bool = False) -> dict:
    """DSM − truth at the DSM's cell centres (the truth sampled bilinearly): RMSE, NMAD, median (m), the share
    within 1 m of ``bias`` (:func:`pointing_height_bias`), cells with a height, and ``completeness``: the share of
    the cells seen by both images (their exact geometry at the truth's heights) that have a height. ``shift``: the
    truth first moved by the horizontal shift ``(dx, dy)`` that best explains the differences
    (``Δ = dx·∂z/∂x + dy·∂z/∂y + c`` by least squares over the cells within 3 NMAD; Nuth and Kääb 2011, once),
    returned as ``shift_m`` — what a relative pointing error moves a surface by."""
    import rasterio
    with rasterio.open(dsm_path) as ds:
        if not _same_horizontal_crs(ds.crs, scene["crs"]):
            raise ValueError(f"DSM CRS {ds.crs} is not the scene's {scene['crs']}")
        h = ds.read(1).astype(np.float32)
        h[h == ds.nodata] = np.nan
        dt = ds.transform
    rr, cc = np.mgrid[0:h.shape[0], 0:h.shape[1]]
    x, y = (np.asarray(v) for v in dt * (cc + 0.5, rr + 0.5))
    z, t = scene["truth"], scene["truth_transform"]
    truth = _sample(z, t, x, y)
    v = np.isfinite(h)
    out = {}
    if shift:
        d = h[v] - truth[v]
        med = np.median(d)
        ok = np.abs(d - med) < 3 * 1.4826 * np.median(np.abs(d - med))
        gx = (_sample(z, t, x[v] + 0.5, y[v]) - _sample(z, t, x[v] - 0.5, y[v]))
        gy = (_sample(z, t, x[v], y[v] + 0.5) - _sample(z, t, x[v], y[v] - 0.5))
        A = np.column_stack([gx, gy, np.ones_like(gx)])[ok]
        a, b, _ = np.linalg.lstsq(A, d[ok], rcond=None)[0]  # h(x) = z(x - s) + c: Δ ≈ -s·∇z + c
        truth = _sample(z, t, x + a, y + b)
        out["shift_m"] = [-float(a), -float(b)]
    seen = np.ones(h.shape, bool)
    for cam in scene["cameras"]:
        c, r = cam.ground_to_image(x, y, truth)
        seen &= (c >= 0) & (c < cam.n) & (r >= 0) & (r < cam.n)
    d = (h[v] - truth[v]).astype(np.float64)
    med = float(np.median(d))
    return {"rmse_m": float(np.sqrt(np.mean(d ** 2))), "nmad_m": float(1.4826 * np.median(np.abs(d - med))),
            "median_m": med, "within_1m": float(np.mean(np.abs(d - bias) <= 1.0)), "cells_with_height": int(v.sum()),
            "completeness": float((v & seen).sum() / max(seen.sum(), 1)), **out}
