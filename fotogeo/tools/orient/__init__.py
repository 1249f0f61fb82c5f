"""Orientation models from GCPs (``fotogeo orient``, ``compare-models``, ``rpc-bias``): fit, check,
export, rectify.

* :mod:`.tool` — :func:`orient`, the tool (image + GCPs → fitted model, report, error vectors, exports);
* :mod:`.report` — the readable ``report.html``;
* :mod:`.compare` — :func:`compare_models`, every model × GCP set × layout (Öztürk, Karşlı & Dihkan);
* :mod:`.compare_report` — that comparison as CSV, Markdown, HTML and plots;
* :mod:`.rpc_bias` — :func:`rpc_bias`, a vendor RPC corrected by GCPs;
* :mod:`.rectify` — one image through a ground → image model onto a north-up map grid.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"orient": "tool", "compare_models": "compare", "rpc_bias": "rpc_bias"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
