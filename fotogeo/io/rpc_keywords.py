"""RPC keyword files: OSSIM/OTB geometry files (``.geom``) and DigitalGlobe ``.RPB`` files.

Both hold RPC00B in its own pixel convention (the *centre* of the first pixel is (0, 0), GDAL's RPC metadata
convention), read as they are into an :class:`~fotogeo.orientation.rpc.Rpc`:

* OSSIM keyword list (``key:  value`` lines, written by OTB / OSSIM for ``ossimRpcModel``,
  ``ossimPleiadesModel`` …): ``line_off``, ``samp_off`` …, ``line_num_coeff_00`` … ``_19``; its
  ``polynomial_format`` must be ``B`` (RPC00B term order). OSSIM's Pleiades model has already moved DIMAP's
  1-based offsets to 0-based (``line_off`` = DIMAP ``LINE_OFF`` − 1). Non-zero adjustment parameters
  (``adjustment_N.adj_param_M.parameter`` of the current adjustment: OSSIM's in-track/cross-track offsets and
  scales) change the model and are refused rather than ignored.
* ``.RPB`` (``name = value;`` statements, coefficient lists in parentheses): ``lineOffset`` …,
  ``lineNumCoef = ( … );``; ``SpecId`` must be ``RPC00B`` when present.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..orientation.rpc import Rpc
from .rpc import checked_rpc, read_rpc_file_text

_OSSIM_SCALARS = ("line_off", "samp_off", "lat_off", "long_off", "height_off", "line_scale", "samp_scale",
                  "lat_scale", "long_scale", "height_scale")
_RPB_NAMES = {"lineoffset": "LINE_OFF", "sampoffset": "SAMP_OFF", "latoffset": "LAT_OFF", "longoffset": "LONG_OFF",
              "heightoffset": "HEIGHT_OFF", "linescale": "LINE_SCALE", "sampscale": "SAMP_SCALE",
              "latscale": "LAT_SCALE", "longscale": "LONG_SCALE", "heightscale": "HEIGHT_SCALE",
              "linenumcoef": "LINE_NUM_COEFF", "linedencoef": "LINE_DEN_COEFF", "sampnumcoef": "SAMP_NUM_COEFF",
              "sampdencoef": "SAMP_DEN_COEFF"}
_RPB_STATEMENT = re.compile(r"(\w+)[ \t]*=[ \t]*(\([^)]*\)|[^;\n]*);")


def _number(value: str, key: str, source: str) -> float:
    try:
        return float(value)
    except ValueError:
        raise InputError(f"{source}: {key} {value!r} is not a number; the RPC file is damaged") from None


def ossim_keywords(text: str) -> dict:
    """``{key: value}`` of an OSSIM keyword list (``key:  value`` per line; the first ``:`` splits)."""
    out = {}
    for line in text.splitlines():
        key, sep, value = line.partition(":")
        if sep and key.strip() and not key.lstrip().startswith("//"):
            out[key.strip()] = value.strip()
    return out


def read_rpc_ossim(path) -> Rpc:
    """Read the RPC00B of an OSSIM/OTB ``.geom`` keyword list (module docstring)."""
    path = Path(path)
    source = f"RPC file {str(path)!r}"
    kw = ossim_keywords(read_rpc_file_text(path))
    fmt = kw.get("polynomial_format", "B").strip().upper()
    if fmt != "B":
        raise InputError(f"{source}: polynomial_format {fmt} is not supported (only B, RPC00B term order)")
    current = kw.get("current_adjustment", "0").strip() or "0"
    for key, value in kw.items():
        m = re.fullmatch(rf"adjustment_{re.escape(current)}\.adj_param_(\d+)\.parameter", key)
        if m and value and _number(value, key, source) != 0.0:
            what = kw.get(f"adjustment_{current}.adj_param_{m.group(1)}.description", f"adj_param_{m.group(1)}")
            raise InputError(f"{source}: OSSIM adjustment {what} = {value} is not applied by fotogeo; write the "
                             f"adjusted RPC (e.g. otbcli_ReadImageInfo / gdal) or set the parameter to 0")
    d = {k.upper(): kw[k] for k in _OSSIM_SCALARS if k in kw}
    for name in ("line_num", "line_den", "samp_num", "samp_den"):
        keys = [f"{name}_coeff_{i:02d}" for i in range(20)]
        if all(k in kw for k in keys):
            d[f"{name.upper()}_COEFF"] = [kw[k] for k in keys]
    return checked_rpc(Rpc.from_mapping(d, source), source)


def read_rpc_rpb(path) -> Rpc:
    """Read a DigitalGlobe ``.RPB`` file (module docstring)."""
    path = Path(path)
    source = f"RPC file {str(path)!r}"
    d = {}
    for stmt, value in _RPB_STATEMENT.findall(read_rpc_file_text(path)):
        key = stmt.lower()
        if key == "specid" and value.strip().strip('"').upper() not in ("RPC00B", ""):
            raise InputError(f"{source}: SpecId {value.strip()} is not supported (only RPC00B term order)")
        if key in _RPB_NAMES:
            name = _RPB_NAMES[key]
            if name.endswith("_COEFF") != ("(" in value):
                raise InputError(f"{source}: {stmt} = {value.strip()[:40]!r} is not a "
                                 f"{'list (...)' if name.endswith('_COEFF') else 'single value'}; the file is damaged")
            d[name] = [v for v in re.split(r"[\s,()]+", value) if v] if "(" in value else value.strip()
    try:
        d = {k: np.asarray(v, dtype=np.float64) if isinstance(v, list) else v for k, v in d.items()}
    except ValueError:
        raise InputError(f"{source}: a coefficient list holds a non-numeric value; the RPC file is damaged") from None
    return checked_rpc(Rpc.from_mapping(d, source), source)
