"""Area-based co-registration of two dates on the target's own grid (``fotogeo coreg``).

* :mod:`.tool` — :func:`coregister`, the tool (reference + target → corrected target, field, report);
* :mod:`.files` — the strips both images are read in, and the written outputs.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"coregister": "tool"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
