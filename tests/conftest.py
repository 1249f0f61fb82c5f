"""Shared test fixtures: the real data folder and small generated images."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """``../shared/data``; tests using it skip with a clear message when it is absent."""
    if not DATA.is_dir():
        if os.environ.get("CI"):
            pytest.fail(f"real test data not found at {DATA}: CI must have ../shared beside the clone")
        pytest.skip(f"real test data not found at {DATA} (clone next to ../shared, or set FOTOGEO_DATA)")
    return DATA


@pytest.fixture(scope="session")
def blunder_scene():
    """The synthetic relief scene of benchmarks/blunder_bench.py: the true models and a pool of 1500 points on its
    DEM, shared by the blunder tests (built once per test process)."""
    import sys
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from blunder_bench import pool, relief_dem, truths
    dem = relief_dem()
    return truths(dem), pool(dem, 1500)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)



@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """Under pytest-xdist (``make test`` runs ``-n 2``) every QGIS test runs in one worker: one install of
    ``build/qgis-test-runtime`` at a time, and the desktop tests' ``xvfb-run -a`` picks its display racily when two
    start at once. A scope scheduler whose scope is "qgis" for the ``test_qgis*`` files and the test itself for every
    other test (xdist's own ``--dist loadgroup`` cannot be used: it renames node ids through an attribute pytest 9 no
    longer reads). Without xdist this hook is never called."""
    from xdist.scheduler import LoadScopeScheduling

    class QgisTogether(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return "qgis" if Path(nodeid.split("::")[0]).name.startswith("test_qgis") else nodeid

    return QgisTogether(config, log)


@pytest.fixture(scope="session", autouse=True)
def _qgis_temp_in_pytest_folder(tmp_path_factory):
    """QGIS's temporary folders (``QGIS3-XXXXXX``, ``processing_XXXXXX``: Qt's ``QDir::tempPath()``, which reads
    ``TMPDIR``) under this session's pytest folder instead of ``/tmp``. A QGIS that does not end cleanly — the
    desktop under Xvfb aborting while quitting, a GUI script ended by ``os._exit``, an xdist worker — never removes
    them, and dozens piled up in /tmp. Set after pytest has chosen its own base folder (Python's ``tempfile``
    keeps the folder it found first), so it moves only what Qt and the child processes create; pytest's own
    retention removes the folder with the session's others."""
    folder = tmp_path_factory.mktemp("tmpdir")
    old = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = str(folder)
    yield folder
    if old is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = old
