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

