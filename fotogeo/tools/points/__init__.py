"""Point measurement tools (``fotogeo transfer``, ``targets``, ``points``).

* :mod:`.transfer` — :func:`transfer_gcps`, GCPs carried from a reference to another image by area-based matching;
* :mod:`.targets` — :func:`measure_targets`, X-shaped targets to sub-pixel;
* :mod:`.layers` — :func:`points_to_layer` / :func:`layer_to_points`, QGIS ``.points`` files ↔ GeoPackage.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

__all__ = ['layer_to_points', 'measure_targets', 'points_to_layer', 'transfer_gcps']
_MODULES = {'transfer_gcps': 'transfer', 'measure_targets': 'targets', 'points_to_layer': 'layers', 'layer_to_points': 'layers'}


def __getattr__(name):
    if name in _MODULES:
        import importlib
        return getattr(importlib.import_module(f".{_MODULES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
