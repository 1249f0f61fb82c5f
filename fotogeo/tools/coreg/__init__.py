"""Area-based co-registration of two dates on the target's own grid (``fotogeo coreg``).

* :mod:`.tool` — :func:`coregister`, the tool (reference + target → corrected target, field, report);
* :mod:`.files` — the strips both images are read in, and the written outputs.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

__all__ = ['coregister']
_MODULES = {'coregister': 'tool'}


def __getattr__(name):
    if name in _MODULES:
        import importlib
        return getattr(importlib.import_module(f".{_MODULES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
