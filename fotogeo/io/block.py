"""Files of an aerial-triangulation block: image observations, ODM ground control, orientations.

* **Image observations** (``read_image_observations``): a table (CSV or any vector layer,
  :func:`fotogeo.io.tables.read_table`) with one row per measurement of a point in a frame:
  fields ``frame`` (the frame's file name or stem), ``point`` (any id), ``col``, ``row``
  (pixels, GDAL corner convention) and an optional ``sigma`` (px).
* **Ground control in ODM/OpenSfM's** ``gcp_list.txt`` (``read_gcp_list``): the first line is
  the CRS (``EPSG:32635``, ``WGS84 UTM 35N``, a PROJ string), then one line per measurement
  ``geo_x geo_y geo_z im_x im_y image_name [gcp_name]`` (``write_gcp_list`` writes it). ODM's
  ``WGS84 UTM <zone><N|S>`` line is read as the EPSG code of that zone. OpenSfM's pixel coordinates put the
  centre of the top-left pixel at (0, 0) (its normalisation adds 0.5), so fotogeo adds 0.5 to
  reach the corner convention; lines without a name are named by their ground coordinates.
* **Ground control as a table** (``read_control_table``): a point layer (any GDAL vector format;
  the geometry is the ground X, Y in the layer's CRS) or a CSV (columns ``x``, ``y`` or their
  aliases of :mod:`fotogeo.io.gcps`, the CRS given), in ANY CRS, with one row per measurement
  of a point in a frame: fields ``id``, ``frame``, ``col``, ``row`` (corner convention), ``z``
  (the ground height, metres) and an optional ``role`` (``control`` / ``check``; one role per
  id). :func:`control_in` transforms the ground X, Y into the block's map CRS (heights are kept).
* **Exterior orientation** out (``write_exterior_orientation``): ``name X Y Z omega phi kappa``
  lines, the format :func:`fotogeo.io.camera.read_exterior_orientation` reads (metres, PATB
  degrees).
* **Interior orientation** out (``write_interior_orientation``): orthority's YAML — ``type:
  pinhole`` without distortion (what :func:`fotogeo.io.camera.read_interior_orientation` reads),
  ``type: brown`` with ``k1, k2, p1, p2, k3`` otherwise (orthority's Brown model is OpenCV's, the
  same as fotogeo's bundle adjustment); the principal point as ``cx, cy``, offsets from the image
  centre in units of ``max(w, h)`` pixels.
"""
from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, one_line
from ..pixels import from_centre, to_centre
from .tables import numeric_columns, read_table, require_columns
from .yaml_file import yaml_key


def frame_key(name) -> str:
    r"""The name a frame is known by: its file name without folder and extension. A backslash stays part of the name
    (a file name may hold one here), but the extension is looked for after it only: ``C:\flight.1\DJI_1`` (a Windows
    path without extension, read on Linux) keeps its whole name, for :func:`match_keys` to drop the folder."""
    name = Path(str(name)).name
    head, sep, tail = name.rpartition("\\")
    return head + sep + Path(tail).stem if tail else name


def _bare(key: str) -> str:
    return key.replace("\\", "/").rsplit("/", 1)[-1]


def key_candidates(names, keys) -> dict:
    r"""``{name: [keys]}``: the keys each frame name may stand for — the name itself when it is a key (an exact
    match claims its key first), else the keys that are the name after a Windows folder (``flight1\DJI_0001``, a
    project written on Windows: a backslash is part of a file name here), else those equal to it but for case and
    such a folder (images renamed, or copied through a case-insensitive file system: ``dji_0001.jpg`` for
    ``DJI_0001.JPG``). A key that is one of the ``names`` is never another name's fallback."""
    names, keys = list(names), list(keys)
    own, given = set(keys), set(names)
    bare, folded = {}, {}
    for k in keys:
        if k not in given:
            bare.setdefault(_bare(k), []).append(k)
            folded.setdefault(_bare(k).casefold(), []).append(k)
    return {n: [n] if n in own else bare.get(n) or folded.get(n.casefold(), []) for n in names}


def _claims(found: dict) -> dict:
    out = {}
    for n, ks in found.items():
        for k in ks:
            out.setdefault(k, []).append(n)
    return out


def match_keys(names, keys) -> dict:
    r"""``{name: key}``: each frame name's key among ``keys`` (:func:`key_candidates`), when it has one candidate that
    no other name claims: a key is taken at most once, so two images never share one shot's pose or GPS; a name with
    no such key is left out (:func:`unmatched_reasons` says why).

    >>> match_keys(["DJI_1", "DJI_2", "a"], ["flight1\\DJI_1", "dji_2", "a", "A"])
    {'DJI_1': 'flight1\\DJI_1', 'DJI_2': 'dji_2', 'a': 'a'}
    >>> match_keys(["DJI_1", "dji_1", "A", "a"], ["DJI_1", "f\\A"])
    {'DJI_1': 'DJI_1'}
    """
    found = key_candidates(names, keys)
    claims = _claims(found)
    return {n: ks[0] for n, ks in found.items() if len(ks) == 1 and len(claims[ks[0]]) == 1}


def unmatched_reasons(names, keys) -> dict:
    """``{name: reason}`` for the names :func:`match_keys` leaves out with a candidate: several keys it could be, or
    a key another name claims too (both named); a name without any candidate is not listed."""
    names, keys = list(names), list(keys)
    found, got = key_candidates(names, keys), match_keys(names, keys)
    claims = _claims(found)
    own = set(keys)
    out = {}
    for n in names:
        if n in got:
            continue
        if len(found[n]) > 1:
            out[n] = f"could be any of {', '.join(map(repr, found[n][:5]))}"
        elif found[n]:
            out[n] = f"{found[n][0]!r} claimed by {' and '.join(claims[found[n][0]][:5])}"
        else:
            taken = [k for k in own & set(names) if k != n and _bare(k).casefold() == n.casefold()]
            if taken:
                out[n] = f"{taken[0]!r} is the image {taken[0]}'s"
    return out


@dataclass(frozen=True)
class ImageObservations:
    frame: np.ndarray  # (n,) frame keys (str)
    point: np.ndarray  # (n,) point ids (str)
    pixel: np.ndarray  # (n, 2) corner convention
    sigma: np.ndarray | None  # (n,) px


def read_image_observations(path) -> ImageObservations:
    """Read a table of image observations (module docstring)."""
    what = f"image observations {str(path)!r}"
    t = read_table(path, what)
    hint = "one row per measurement: frame, point, col, row (corner convention), optional sigma"
    fcol, pcol = require_columns(t, ("frame", "point"), what, hint)
    px = numeric_columns(t, ("col", "row"), what, hint, finite=True, id_field="point")
    sigma = None
    if "sigma" in {str(c).lower() for c in t.columns}:
        sigma = numeric_columns(t, ("sigma",), what, hint, finite=True, id_field="point")[:, 0]
        if not (sigma > 0).all():
            raise InputError(f"{what}: sigma must be positive (px)")
    frames = np.array([frame_key(v) for v in t[fcol]], dtype=object)
    points = t[pcol].astype(str).to_numpy(dtype=object)
    return ImageObservations(frames, points, px, sigma)


@dataclass(frozen=True)
class GcpList:
    crs: object  # a CRS spec: the gcp_list.txt line or a pyproj CRS
    name: np.ndarray  # (n,) point names
    ground: np.ndarray  # (n, 3)
    pixel: np.ndarray  # (n, 2) corner convention
    frame: np.ndarray  # (n,) frame keys
    role: np.ndarray | None = None  # (n,) "control" / "check" when the file says; None: all control


def read_control(path, crs=None, csv_crs=None) -> GcpList:
    """Ground control of a block: ``gcp_list.txt`` (any ``.txt``) or a table (:func:`read_control_table`)."""
    return read_gcp_list(path) if Path(path).suffix.lower() == ".txt" else read_control_table(path, crs, csv_crs)


def read_control_table(path, crs=None, csv_crs=None) -> GcpList:
    """Read ground control from a point layer or CSV (module docstring); ``crs`` sets/overrides its CRS,
    ``csv_crs`` is the CRS of a CSV's x, y when ``crs`` is not given (the block's map CRS)."""
    from .gcps import X_NAMES, Y_NAMES, _layer_positions
    from .tables import find_column, is_layer
    what = f"GCP file {str(path)!r}"
    hint = "one row per measurement of a point in a frame: id, frame, col, row (corner convention), z, optional role"
    t = read_table(path, "GCP file")
    if len(t) == 0:
        raise InputError(f"{what} holds no points")
    idc, fcol = require_columns(t, ("id", "frame"), what, hint)
    if is_layer(t):
        xy, map_crs = _layer_positions(t, what, crs)
    else:
        xcol = next((c for c in t.columns if str(c).lower() in X_NAMES), None)
        ycol = next((c for c in t.columns if str(c).lower() in Y_NAMES), None)
        if xcol is None or ycol is None:
            raise InputError(f"{what} needs ground coordinate columns x and y (or mapX/mapY, lon/lat, easting/northing)")
        crs = crs or csv_crs
        if not crs:
            raise InputError(f"{what}: a CSV carries no CRS; give the CRS of its x, y (gcp_crs=, --gcp-crs)")
        from ..crs import parse_crs
        xy, map_crs = numeric_columns(t, [xcol, ycol], what, hint, finite=True), parse_crs(crs, what)
    z = numeric_columns(t, ("z",), what, hint + "; the bundle adjustment needs the heights", finite=True)[:, 0]
    pixel = numeric_columns(t, ("col", "row"), what, hint, finite=True)
    names = t[idc].astype(str).to_numpy(dtype=object)
    rf = find_column(t, "role")
    role = None
    if rf is not None:
        role = t[rf].fillna("control").astype(str).str.strip().str.lower().to_numpy(dtype=object)
        bad = sorted(set(role) - {"control", "check"})
        if bad:
            raise InputError(f"{what}: role values must be 'control' or 'check'; found {', '.join(bad[:5])}")
        mixed = sorted({n for n in names if len(set(role[names == n])) > 1})
        if mixed:
            raise InputError(f"{what}: point(s) {', '.join(mixed[:10])} have both roles; give each id one role")
    frames = np.array([frame_key(v) for v in t[fcol]], dtype=object)
    return GcpList(map_crs, names, np.column_stack([xy, z]), pixel, frames, role)


def control_in(gcp: GcpList, map_crs) -> GcpList:
    """``gcp`` with its ground X, Y transformed into ``map_crs`` (:func:`fotogeo.crs.transform_points`)."""
    from dataclasses import replace

    from ..crs import parse_crs, transform_points
    src = parse_crs(gcp.crs, "CRS of the GCP file")
    xy = transform_points(src, map_crs, gcp.ground[:, :2])
    if not np.isfinite(xy).all():
        raise InputError(f"GCPs cannot be transformed from {src.to_string()} into the map CRS {map_crs.to_string()} "
                         f"(outside its area of use?); check the GCP CRS and --crs")
    return replace(gcp, crs=map_crs, ground=np.column_stack([xy, gcp.ground[:, 2]]))


def split_check_points(gcp: GcpList, check_ids, fraction: float, seed) -> set:
    """The GCP names held out as check points: the file's ``check`` roles, the ``check_ids`` named, and
    with ``fraction`` > 0 a seeded hold-out of ``fraction`` of the remaining control points measured in
    two frames or more (a check point is intersected from its rays alone), spread over the block
    (:func:`fotogeo.models.robust.spread_split` on their mean ground positions), leaving ≥ 3 control."""
    from ..models.robust import spread_split
    checks = set(check_ids) | (set(gcp.name[gcp.role == "check"]) if gcp.role is not None else set())
    if fraction:
        names, rays = np.unique(gcp.name.astype(str), return_counts=True)
        rest = sorted(set(names[rays >= 2]) - checks)
        xy = np.array([gcp.ground[gcp.name == n, :2].mean(axis=0) for n in rest]).reshape(-1, 2)
        chosen = spread_split(xy, fraction, seed) if len(rest) - round(fraction * len(rest)) >= 3 else np.zeros(0)
        if not np.any(chosen):
            raise InputError(f"check_fraction {fraction}: {len(rest)} control points leave none to hold out with 3 "
                             f"control points kept; lower it or give more GCPs")
        checks |= {n for n, c in zip(rest, chosen) if c}
    return checks


def read_gcp_list(path) -> GcpList:
    """Read an ODM/OpenSfM ``gcp_list.txt`` (module docstring)."""
    p = Path(path)
    try:
        lines = [ln.split("#", 1)[0].strip() for ln in p.read_text(encoding="utf-8-sig").splitlines()]
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(one_line(f"cannot read GCP list {str(p)!r} as text: {exc}")) from None
    numbered = [(i + 1, ln) for i, ln in enumerate(lines) if ln]
    if len(numbered) < 2:
        raise InputError(f"GCP list {str(p)!r}: expected a CRS line and measurement lines "
                         f"'geo_x geo_y geo_z im_x im_y image_name [gcp_name]'")
    crs = odm_crs(numbered[0][1])
    names, ground, pixel, frames = [], [], [], []
    for lineno, ln in numbered[1:]:
        parts = ln.split()
        try:
            if len(parts) < 6:
                raise ValueError("too few values")
            g, im = [float(v) for v in parts[:3]], [float(v) for v in parts[3:5]]
        except ValueError:
            raise InputError(one_line(f"GCP list {str(p)!r}, line {lineno}: expected 'geo_x geo_y geo_z im_x im_y "
                                      f"image_name [gcp_name]'; got {ln!r}")) from None
        if not (np.isfinite(g).all() and np.isfinite(im).all()):
            raise InputError(f"GCP list {str(p)!r}, line {lineno}: coordinates must be finite numbers")
        names.append(parts[6] if len(parts) > 6 else f"{g[0]:.3f}_{g[1]:.3f}_{g[2]:.3f}")
        ground.append(g)
        pixel.append(im)
        frames.append(frame_key(parts[5]))
    return GcpList(crs, np.array(names, dtype=object), np.array(ground), from_centre(np.array(pixel)),
                   np.array(frames, dtype=object))


_ODM_UTM = re.compile(r"^WGS\s*84\s+UTM\s+(\d{1,2})\s*([NS])$", re.IGNORECASE)


def odm_crs(line: str) -> str:
    """The CRS of a ``gcp_list.txt`` first line as pyproj reads it: ODM's ``WGS84 UTM 35S`` becomes its
    EPSG code, anything else (``EPSG:32735``, a PROJ string) is kept.

    >>> odm_crs("WGS84 UTM 35S"), odm_crs("WGS84 UTM 5N"), odm_crs("EPSG:2154")
    ('EPSG:32735', 'EPSG:32605', 'EPSG:2154')
    """
    m = _ODM_UTM.match(line.strip())
    if not m or not 1 <= int(m.group(1)) <= 60:
        return line.strip()
    return f"EPSG:{(32600 if m.group(2).upper() == 'N' else 32700) + int(m.group(1))}"


def write_gcp_list(path, crs_line: str, gcp: GcpList) -> None:
    """Write ``gcp`` as ODM/OpenSfM's ``gcp_list.txt`` (module docstring: pixels back to OpenSfM's
    centre convention, frames by the names given, every value at full precision)."""
    spaced = [str(v) for v in (*gcp.name, *gcp.frame) if not str(v) or len(str(v).split()) != 1]
    if spaced:
        raise InputError(f"gcp_list.txt separates values by spaces: the GCP or image name {spaced[0]!r} cannot be "
                         f"written; rename it without spaces")
    px = to_centre(np.asarray(gcp.pixel, float))
    lines = [crs_line.strip()] + [f"{g[0]!r} {g[1]!r} {g[2]!r} {c!r} {r!r} {f} {n}" for n, g, (c, r), f in
                                  zip(gcp.name, np.asarray(gcp.ground, float).tolist(), px.tolist(), gcp.frame)]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def line_breaking(name: str) -> str | None:
    """The first character of ``name`` that an orientation file's one line per frame cannot hold (a control character
    other than a tab, which is quoted, or a Unicode line or paragraph separator), None when there is none."""
    return next((c for c in name if c != "\t" and unicodedata.category(c) in ("Cc", "Zl", "Zp")), None)


def check_frame_names(frames) -> None:
    """Refuse, before any work, a frame file whose name (:func:`frame_key`) holds a character the exterior orientation
    written at the end (:func:`write_exterior_orientation`) cannot hold (:func:`line_breaking`), naming the file."""
    for f in frames:
        if (bad := line_breaking(frame_key(f))) is not None:
            raise InputError(f"image {str(f)!r}: its file name holds the control character {bad!r}, which the "
                             f"exterior orientation file cannot hold on its one line per frame; rename the file")


def write_exterior_orientation(path, names, eos, header: str = "") -> None:
    """``name X Y Z omega phi kappa`` lines (module docstring); ``header`` becomes ``#`` comments. A name holding
    spaces, quotes, ``#`` or backslashes is quoted as the shell quotes it (``shlex.quote``), which
    :func:`fotogeo.io.camera.read_exterior_orientation` reads back (a tab too); a name holding another control
    character (a line break) or a Unicode line separator is refused, naming the frame."""
    import shlex
    for n in names:
        if (bad := line_breaking(str(n))) is not None:
            raise InputError(f"frame {str(n)!r}: its name holds the control character {bad!r}, which "
                             f"{Path(path).name} cannot hold on its one line per frame; rename the image")
    out = [f"# {h}" for h in header.splitlines()] if header else []
    names = [n if re.fullmatch(r"[^\s#'\"\\]+", str(n)) else shlex.quote(str(n)) for n in names]
    out += [f"{n} {e.X:.4f} {e.Y:.4f} {e.Z:.4f} {e.omega:.8f} {e.phi:.8f} {e.kappa:.8f}" for n, e in zip(names, eos)]
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")


def write_interior_orientation(path, name: str, camera, distortion: dict | None = None) -> None:
    """One camera in orthority's YAML (module docstring)."""
    w, h = camera.image_size
    m = max(w, h)
    d = {k: float(v) for k, v in (distortion or {}).items()}
    brown = any(v != 0.0 for v in d.values())
    lines = [f"{yaml_key(name)}:", f"    type: {'brown' if brown else 'pinhole'}", f"    im_size: [{int(w)}, {int(h)}]",
             f"    focal_len: {camera.focal_length!r}",
             f"    sensor_size: [{camera.sensor_size[0]!r}, {camera.sensor_size[1]!r}]",
             f"    cx: {(camera.principal_point[0] - w / 2.0) / m!r}", f"    cy: {(camera.principal_point[1] - h / 2.0) / m!r}"]
    if brown:
        lines += [f"    {k}: {d.get(k, 0.0)!r}" for k in ("k1", "k2", "p1", "p2", "k3")]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
