"""Interior orientation of scanned film frames (``fotogeo interior``).

* :mod:`.tool` — :func:`interior`, fiducials measured → pixel ↔ photo transforms and a report;
* :mod:`.frame` — the standard frame of a scan (``--resample``).

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"interior": "tool"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
