"""The live model: the picker's GCPs refitted in fotogeo's worker session, and the prediction grids.

Each change sends every GCP to the session's ``fit_gcps`` (:mod:`processing_provider.session`;
the same fitting code as ``fotogeo orient``, a few milliseconds a round trip) and gets the model's
residuals, the control/check RMS and two grids: pixel → map over the image and map → pixel over the
GCPs' extent. :class:`Grid` interpolates them bilinearly, so the predicted position of the next
point follows the cursor without a round trip per mouse move.

Heights (``HeightSource``): ``field`` uses the layer's ``z`` values; ``dem`` samples a DEM raster
(bilinear, in the DEM's CRS) for every point; ``constant`` gives every point the same height.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from fotogeo.options import in_labels  # standard library only

#: command-line flags the picker's messages may carry → the dock's own fields
PICKER_WORDS = {"--camera": "the camera file (Model row)", "--dem": "a DEM layer (Heights: dem)",
                "--height": "a constant height (Heights: constant)", "--crs": "the GCP layer's CRS"}

HEIGHT_SOURCES = ("field", "dem", "constant")


@dataclass(frozen=True)
class FitSettings:
    """What the dock's controls say about the fit (``crs`` is the GCP layer's CRS as WKT)."""

    model: str = "auto"
    crs: str = ""
    height_source: str = "field"
    dem: str | None = None
    height: float | None = None
    camera: str | None = None
    image: str | None = None
    width: int | None = None
    height_px: int | None = None
    image_sigma: float | None = None  # the click precision (px): the blunder test's a priori σ; None: estimated

    def request(self, gcps) -> dict:
        """The keyword arguments of ``fit_gcps`` for ``gcps`` (a list of :class:`~.gcp_layer.Gcp`)."""
        points = [g.request() for g in gcps]
        if self.height_source != "field":
            points = [{**p, "z": None} for p in points]
        kwargs = {"gcps": points, "model": self.model, "crs": self.crs, "image": self.image,
                  "width": self.width, "height": self.height_px, "image_sigma": self.image_sigma or None}
        if self.height_source == "dem" and self.dem:
            kwargs["dem"] = self.dem
        if self.height_source == "constant" and self.height is not None:
            kwargs["default_height"] = float(self.height)
        if self.model == "collinearity" or (self.model == "auto" and self.camera):
            kwargs["camera"] = self.camera
        return {k: v for k, v in kwargs.items() if v is not None}


def fit(session, gcps, settings: FitSettings, timeout: float = 20) -> dict:
    """``fit_gcps`` of ``gcps`` in ``session``; a tool error becomes a result with ``ok`` False and its message."""
    from ..session import SessionError
    if not gcps:
        return {"ok": False, "message": "no GCPs yet: click a point on the image, then the same point on the map",
                "needed": None, "points": [], "rms": {}}
    try:
        return session.call("fit_gcps", timeout=timeout, **settings.request(gcps))
    except SessionError as e:
        return {"ok": False, "message": str(e), "needed": None, "points": [], "rms": {}}


#: the flag of a point the others cannot check (its redundancy is too low): a fact about the geometry, no alarm
NOT_TESTABLE = "not testable"


def alarming(flag) -> bool:
    """Whether a point's flag is a warning to act on (a blunder, a suspect, no height) rather than "not testable".

    >>> alarming("blunder"), alarming("suspect"), alarming("not testable"), alarming(None)
    (True, True, False, False)
    """
    return bool(flag) and flag != NOT_TESTABLE


def _number(v):
    return float(v) if v is not None and isinstance(v, (int, float)) and math.isfinite(v) else None


class Grid:
    """Bilinear interpolation of two value grids ``a[i][j]``, ``b[i][j]`` at ``(u = us[j], v = vs[i])``.

    Both axes ascending or descending (as the session sends them); None outside the grid or where a
    corner value is undefined (null/NaN).
    """

    def __init__(self, us, vs, a, b):
        self.us, self.vs, self.a, self.b = list(us), list(vs), a, b

    @classmethod
    def forward(cls, fit: dict):
        """pixel (col, row) → map (x, y), or None when the fit has no grid."""
        g = (fit or {}).get("forward")
        return cls(g["cols"], g["rows"], g["x"], g["y"]) if g and g.get("cols") else None

    @classmethod
    def inverse(cls, fit: dict):
        """map (x, y) → pixel (col, row), or None when the fit has no grid."""
        g = (fit or {}).get("inverse")
        return cls(g["xs"], g["ys"], g["col"], g["row"]) if g and g.get("xs") else None

    @staticmethod
    def _cell(axis, value):
        """``(index, fraction)`` of ``value`` between axis[index] and axis[index + 1], or None outside."""
        if len(axis) < 2:
            return None
        step = 1 if axis[-1] >= axis[0] else -1
        lo, hi = (axis[0], axis[-1]) if step == 1 else (axis[-1], axis[0])
        if not lo <= value <= hi:
            return None
        for i in range(len(axis) - 1):
            a0, a1 = axis[i], axis[i + 1]
            if min(a0, a1) <= value <= max(a0, a1) and a1 != a0:
                return i, (value - a0) / (a1 - a0)
        return None

    def __call__(self, u: float, v: float):
        cu, cv = self._cell(self.us, u), self._cell(self.vs, v)
        if cu is None or cv is None:
            return None
        (j, fu), (i, fv) = cu, cv
        out = []
        for grid in (self.a, self.b):
            corners = [_number(grid[i][j]), _number(grid[i][j + 1]), _number(grid[i + 1][j]), _number(grid[i + 1][j + 1])]
            if None in corners:
                return None
            top = corners[0] * (1 - fu) + corners[1] * fu
            bottom = corners[2] * (1 - fu) + corners[3] * fu
            out.append(top * (1 - fv) + bottom * fv)
        return tuple(out)


def summary(fit: dict) -> str:
    """One line for the dock: the model and its RMS, or why there is no fit (how many more points)."""
    if not fit.get("ok"):  # in the dock's words: its camera field, not the command line's --camera
        return in_labels(fit.get("message") or "no fit", extra=PICKER_WORDS)
    rms = fit.get("rms") or {}

    def part(kind):
        n = rms.get(f"n_{kind}") or 0
        if not n:
            return f"{kind}: none"
        px, mp = _number(rms.get(f"{kind}_px")), _number(rms.get(f"{kind}_map"))
        return f"{kind} ({n}): RMS {px:.3f} px / {mp:.3f} map units" if px is not None and mp is not None \
            else f"{kind} ({n}): RMS n/a"
    flags = sum(1 for p in fit.get("points", []) if "blunder" in (p.get("flag") or ""))
    tail = f"; {flags} suspected blunder{'s' if flags > 1 else ''}" if flags else ""
    if "not testable" in (fit.get("blunder_test") or ""):
        tail += "; blunders not testable (too few points for this model)"
    return f"{fit.get('model', '?')}: {part('control')}; {part('check')}{tail}"


#: words in a layer name that say "heights"
DEM_WORDS = ("dem", "dtm", "dsm", "elev", "height", "srtm", "terrain", "lidar")


def guess_dem(layers, exclude=()):
    """The layer of ``layers`` (``(name, band count)`` pairs, in layer-tree order) most likely to be a DEM:
    a one-band raster, one whose name says so first; None when no one-band raster is left after ``exclude``.

    >>> guess_dem([("frame", 3), ("slope", 1), ("ngi dem", 1)]), guess_dem([("frame", 3)])
    ('ngi dem', None)
    >>> guess_dem([("ortho", 1), ("heights", 1)], exclude=("heights",))
    'ortho'
    """
    single = [name for name, bands in layers if bands == 1 and name not in exclude]
    named = [name for name in single if any(w in name.lower() for w in DEM_WORDS)]
    return (named or single or [None])[0]
