"""Point measurement tools (``fotogeo transfer``, ``targets``, ``points``).

* :mod:`.transfer` — :func:`transfer_gcps`, GCPs carried from a reference to another image by area-based matching;
* :mod:`.targets` — :func:`measure_targets`, X-shaped targets to sub-pixel;
* :mod:`.layers` — :func:`points_to_layer` / :func:`layer_to_points`, QGIS ``.points`` files ↔ GeoPackage.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"transfer_gcps": "transfer", "measure_targets": "targets", "points_to_layer": "layers",
            "layer_to_points": "layers"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
