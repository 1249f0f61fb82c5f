"""A package's names loaded on first use (PEP 562): importing one module of a capability package does not import
the tool and its readers (the QGIS plugin imports small modules in-process, without rasterio)."""
from __future__ import annotations

import importlib


def lazy_getattr(package: str, modules: dict):
    """The module-level ``__getattr__`` of ``package`` that imports ``modules[name]`` (a submodule, relative) the
    first time ``name`` is asked for."""
    def __getattr__(name):
        if name in modules:
            return getattr(importlib.import_module(f".{modules[name]}", package), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    return __getattr__
