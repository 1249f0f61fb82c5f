"""The embedded default (``fotogeo demo``, ``make demo``): a rendered scene and block with known truth.

* :mod:`.tool` — :func:`run_demo`, the registration part and the whole run;
* :mod:`.block` — the demo's small aerial block, triangulated end to end.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"run_demo": "tool"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
