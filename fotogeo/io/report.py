"""JSON reports: numpy values converted, NaN and infinity written as null (JSON has neither)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np


def _jsonable(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o)}")


def _finite(o):
    """Replace non-finite floats (NaN, inf) by None, recursively: JSON has no NaN."""
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    if isinstance(o, (float, np.floating)):
        return float(o) if np.isfinite(o) else None
    if isinstance(o, np.ndarray):
        return _finite(o.tolist())
    return o


def write_json(path, data: dict) -> None:
    """Write ``data`` as indented JSON (numpy values converted, NaN written as null)."""
    text = json.dumps(_finite(data), indent=2, default=_jsonable, allow_nan=False)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())


def write_json_whole(path, data: dict) -> None:
    """:func:`write_json` to a temporary file beside ``path`` renamed over it: a reader sees the whole report or
    none (the report of a refused run, written outside the run's atomic outputs)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write_json(tmp, data)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def read_json(path, what: str) -> dict:
    """A JSON report (one of fotogeo's): a dict, or one :class:`~fotogeo.errors.InputError` line naming ``what``."""
    from ..errors import InputError
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError) as exc:
        raise InputError(f"{what} {str(path)!r} cannot be read as JSON ({exc})") from None
    if not isinstance(data, dict):
        raise InputError(f"{what} {str(path)!r} is not a fotogeo report (no JSON object)")
    return data
