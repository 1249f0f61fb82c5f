"""One headless QGIS per test process, with Processing and the fotogeo provider.

Test modules do ``from qgis_env import qgis_app`` (a session fixture). QgsApplication may be
created only once per process, so :func:`start` is idempotent; ``exitQgis`` is never
called (it can segfault at interpreter exit with Processing loaded).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PROCESSING_PLUGINS = "/usr/share/qgis/python/plugins"
_STATE: dict = {}
# QGIS computes statistics when it loads a raster layer, and GDAL would save them in an
# .aux.xml beside the raster — beside the inputs in ../shared/data. Tests never write beside
# their inputs: no GDAL side files in this process and the QGIS processes it starts.
os.environ["GDAL_PAM_ENABLED"] = "NO"


def start():
    """Return ``(QgsApplication, provider)``, creating them at the first call."""
    if "app" in _STATE:
        return _STATE["app"], _STATE["provider"]
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    os.environ.setdefault("FOTOGEO_PYTHON", sys.executable)  # the plugin's runtime: this venv (it has fotogeo)
    from qgis.core import QgsApplication
    if PROCESSING_PLUGINS not in sys.path:
        sys.path.append(PROCESSING_PLUGINS)
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    app = QgsApplication.instance() or QgsApplication([], False)
    app.initQgis()
    from processing.core.Processing import Processing
    Processing.initialize()
    from processing_provider.provider import FotogeoProvider
    provider = FotogeoProvider()
    assert QgsApplication.processingRegistry().addProvider(provider), "fotogeo provider could not be added"
    _STATE.update(app=app, provider=provider)
    return app, provider


def need_qgis():
    """Skip (with the reason) when Debian's python3-qgis is not importable."""
    try:
        import qgis.core  # noqa: F401
    except ImportError as e:
        pytest.skip(f"QGIS Python bindings not importable ({e}): install python3-qgis qgis-providers "
                    f"(make test does) and use a venv made with --system-site-packages", allow_module_level=True)


@pytest.fixture(scope="session")
def qgis_app():
    """The running QgsApplication (session-wide)."""
    need_qgis()
    app, _ = start()
    return app
