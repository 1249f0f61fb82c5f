"""``KEY: value`` RPC text files (IKONOS ``_rpc.txt``, Planet/SkySat ``_RPC.TXT``), and what every RPC reader
shares: the file's text and the check of the values read (:mod:`fotogeo.io.rpc` picks the reader by content)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..orientation.rpc import Rpc
from .text import read_text_file


def read_rpc_file_text(path: Path) -> str:
    """The text of RPC file ``path`` (undecodable bytes replaced; :func:`~fotogeo.io.text.read_text_file`)."""
    return read_text_file(path, "RPC file", hint="give the RPC file (_RPC.TXT, .RPB, .geom or RPC XML)",
                          errors="replace")


def checked_rpc(rpc: Rpc, source: str) -> Rpc:
    """``rpc`` if every value is finite, the scales non-zero and the denominators not all zero."""
    for f in dataclasses.fields(rpc):
        value = np.asarray(getattr(rpc, f.name), dtype=np.float64)
        if not np.isfinite(value).all():
            raise InputError(f"{source}: {f.name.upper()} is not finite; the RPC file is damaged")
        if f.name.endswith("_scale") and value == 0:
            raise InputError(f"{source}: {f.name.upper()} is 0; the RPC file is damaged")
        if f.name.endswith("_den") and not value.any():
            raise InputError(f"{source}: {f.name.upper()}_COEFF are all 0; the RPC file is damaged")
    return rpc


def read_rpc_text(path) -> Rpc:
    """Read a ``KEY: value [unit]`` RPC text file (IKONOS ``_rpc.txt``, Planet/SkySat ``_RPC.TXT``)."""
    path = Path(path)
    d = {}
    for line in read_rpc_file_text(path).splitlines():
        key, sep, value = line.partition(":")
        if sep and value.split():
            d[key.strip().upper()] = value.split()[0]
    source = f"RPC file {str(path)!r}"
    return checked_rpc(Rpc.from_mapping(d, source), source)
