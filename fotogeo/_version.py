"""fotogeo's version, from its one source: ``version`` in pyproject.toml.

Looked up in this order:

1. the ``pyproject.toml`` of a source checkout this package sits in (an editable install's metadata
   keeps the version it was installed with until it is reinstalled; the checkout is the truth);
2. the installed distribution's metadata (``importlib.metadata``: a wheel or sdist install);
3. the ``metadata.txt`` beside the package in the QGIS plugin zip, whose version
   ``scripts/build_plugin.py`` writes from pyproject.toml;
4. ``0+unknown`` when none of them is there.

``importlib.metadata`` (with ``email``, ``zipfile``, ``csv``) is imported only when step 2 is reached.
"""
from __future__ import annotations

import re
from pathlib import Path

_HERE = Path(__file__).resolve().parent


def _from_pyproject(path: Path) -> str | None:
    """``version = "..."`` of the ``[project]`` table of a pyproject.toml naming fotogeo (no TOML parser on 3.10)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return None
    table = re.search(r"^\[project\]\s*$(.*?)(?=^\[|\Z)", text, re.MULTILINE | re.DOTALL)
    if not table or not re.search(r'^name\s*=\s*["\']fotogeo["\']', table.group(1), re.MULTILINE):
        return None
    m = re.search(r'^version\s*=\s*["\']([^"\']+)["\']', table.group(1), re.MULTILINE)
    return m.group(1) if m else None


def _from_plugin_metadata(path: Path) -> str | None:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return None
    m = re.search(r"^version\s*=\s*(\S+)\s*$", text, re.MULTILINE)
    return m.group(1) if m else None


def version() -> str:
    found = _from_pyproject(_HERE.parent / "pyproject.toml")
    if found:
        return found
    from importlib import metadata
    try:
        return metadata.version("fotogeo")
    except metadata.PackageNotFoundError:
        pass
    return _from_plugin_metadata(_HERE.parent / "metadata.txt") or "0+unknown"
