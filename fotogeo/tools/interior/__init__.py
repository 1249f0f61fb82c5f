"""Interior orientation of scanned film frames (``fotogeo interior``).

* :mod:`.tool` — :func:`interior`, fiducials measured → pixel ↔ photo transforms and a report;
* :mod:`.frame` — the standard frame of a scan (``--resample``).

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

__all__ = ['interior']
_MODULES = {'interior': 'tool'}


def __getattr__(name):
    if name in _MODULES:
        import importlib
        return getattr(importlib.import_module(f".{_MODULES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
