"""The embedded default (``fotogeo demo``, ``make demo``): a rendered scene and block with known truth.

* :mod:`.tool` — :func:`run_demo`, the registration part and the whole run;
* :mod:`.block` — the demo's small aerial block, triangulated end to end.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

__all__ = ['run_demo']
_MODULES = {'run_demo': 'tool'}


def __getattr__(name):
    if name in _MODULES:
        import importlib
        return getattr(importlib.import_module(f".{_MODULES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
