"""Fits run on one BLAS thread whatever the caller's setting, and give it back (issues 15 and 24)."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from fotogeo.models import MODELS
from fotogeo.models.threads import SMALL_FLOPS, blas_threads_for, pins

threadpoolctl = pytest.importorskip("threadpoolctl")


def _blas_threads() -> int:
    return max(i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas")


@pytest.fixture
def two_blas_threads():
    """The caller's setting: two BLAS threads (skipped where BLAS cannot have two)."""
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        if _blas_threads() != 2:
            pytest.skip("this BLAS cannot run two threads")
        yield


def test_which_problems_are_pinned():
    assert pins(2000, 78) and pins(2000, 11)  # the RFM and the DLT on 1000 GCPs
    assert pins(120, 59)  # the rfm-common on 60 points whose coefficients moved with the threads (issue 24)
    assert pins(200_000, 80)  # no size where two threads paid: large fits are pinned too
    assert not pins(8, 9) and not pins(12, 11)  # RANSAC samples: OpenBLAS keeps one thread by itself
    assert pins(9216, 1)  # OpenBLAS's gemv threads from 9216 elements
    assert pins(SMALL_FLOPS, 1) and not pins(SMALL_FLOPS - 1, 1)


@pytest.mark.parametrize("name", ["dlt", "rfm-poly", "projective", "poly2"])
def test_a_fit_runs_on_one_thread_and_restores_the_setting(two_blas_threads, monkeypatch, name):
    cls = MODELS[name]
    seen = []
    fit = cls._fit.__func__

    def recording_fit(klass, *args, **kw):
        seen.append(_blas_threads())
        return fit(klass, *args, **kw)

    monkeypatch.setattr(cls, "_fit", classmethod(recording_fit))
    rng = np.random.default_rng(0)
    src = np.column_stack([rng.uniform(0, 1000, 1000), rng.uniform(0, 1000, 1000), rng.uniform(0, 200, 1000)])
    src = src[:, :cls.src_dims]
    dst = src[:, :2] * [0.5, -0.4] + [10, 20] + 0.001 * src[:, :2] ** 1.5 / 30
    if cls.src_dims == 3:
        dst = dst + src[:, 2:] * 0.05
    cls.estimate(src, dst)
    assert seen == [1]
    assert _blas_threads() == 2


@pytest.mark.parametrize("last", ["setter", "other"])
def test_concurrent_pins_restore_once_the_last_ends(two_blas_threads, last):
    """Two threads fit at once; whichever leaves last — the one that set the pin or the other —
    the count stays 1 until then and is the caller's 2 after."""
    both_in, first_left, seen = threading.Barrier(2, timeout=10), threading.Event(), {}

    def fit(name, leaves_first):
        with blas_threads_for(2000, 78):
            both_in.wait()
            if not leaves_first:
                first_left.wait(10)
                seen[name] = _blas_threads()
        if leaves_first:
            first_left.set()

    setter = threading.Thread(target=fit, args=("setter", last != "setter"))
    setter.start()
    deadline = time.monotonic() + 10
    while _blas_threads() != 1 and time.monotonic() < deadline:  # the other joins an existing pin
        time.sleep(0.001)
    other = threading.Thread(target=fit, args=("other", last != "other"))
    other.start()
    for t in (setter, other):
        t.join(20)
    assert seen == {last: 1}
    assert _blas_threads() == 2


def test_an_error_inside_restores_the_setting(two_blas_threads):
    with pytest.raises(ZeroDivisionError):
        with blas_threads_for(2000, 78):
            assert _blas_threads() == 1
            1 / 0
    assert _blas_threads() == 2


LATE_SCIPY = r"""
import json, sys
from threadpoolctl import threadpool_info, threadpool_limits
from fotogeo.models.threads import blas_threads_for
with blas_threads_for(2000, 78):  # the first pin: only numpy's BLAS is loaded
    pass
import scipy.linalg  # noqa: F401 - loads scipy's own OpenBLAS
with threadpool_limits(limits=2, user_api="blas"):
    with blas_threads_for(2000, 78):
        inside = {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    after = {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
print(json.dumps([inside, after]))
"""


def test_a_blas_loaded_after_the_first_fit_is_pinned_too():
    """scipy's own OpenBLAS (the RFM's regularisation) loads after numpy's: it must be pinned as well."""
    import json
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", LATE_SCIPY], capture_output=True, text=True, check=True).stdout
    inside, after = json.loads(out.strip().splitlines()[-1])
    if len(inside) < 2 or max(after.values()) < 2:
        pytest.skip("numpy and scipy share one BLAS here, or it cannot run two threads")
    assert set(inside.values()) == {1}
    assert all(n == 2 for n in after.values())
