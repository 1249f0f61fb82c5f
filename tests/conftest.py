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


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (``make test`` runs ``-n 2 --dist loadgroup``) every QGIS test runs in one worker: one
    QgsApplication per process, and the desktop tests' ``xvfb-run -a`` picks its display racily when two start at
    once. Without xdist the marker is inert."""
    for item in items:
        if item.path.name.startswith("test_qgis"):  # one install of build/qgis-test-runtime at a time, too
            item.add_marker(pytest.mark.xdist_group("qgis"))
