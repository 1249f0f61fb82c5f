"""fotogeo's QGIS Processing provider — the only part of fotogeo that imports ``qgis``.

Parameters → the same fotogeo tool the command line calls. fotogeo itself is imported
lazily inside each algorithm's ``processAlgorithm``. ``scripts/build_plugin.py`` packs this
package, ``metadata.txt`` and the pure-Python fotogeo package into ``dist/fotogeo_qgis.zip``.
"""


def classFactory(iface):  # noqa: N802 - QGIS plugin entry point
    from .plugin import classFactory as factory
    return factory(iface)
