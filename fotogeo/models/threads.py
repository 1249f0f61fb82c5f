"""Model fits on one BLAS thread whatever the caller's thread setting (issues 15 and 24).

Two reasons. Speed (issue 15): a model fit on 1000 GCPs factorises matrices of a few thousand
rows and at most ~80 columns; OpenBLAS splits such products over its threads, and the threads
cost more than they save. On the 2-core development machine, loaded by other jobs (least
squares + QR, best of 40 runs): 2000 x 80 (an RFM) 14.5 ms on one thread, 23.4 ms on two;
2000 x 40 2.6 vs 4.6 ms; at heavier load a 1000 x 12 QR + SVD took 0.45 vs 76 ms (median of
15: the threads waiting for a core spin), 20000 x 80 1.2 vs 2.8 s and 2000 x 400 0.86 vs 6.7 s.
Determinism (issue 24): on another 2-core machine an RFM fit on 60 points (a 120 x 59 design,
then left unpinned because OpenBLAS was assumed to keep one thread below 10⁴ elements) gave
coefficients 0.9 apart under ``OPENBLAS_NUM_THREADS=2`` and 1 — the regularisation's products
are ``grid x rows x cols`` (37 x 120 x 59 ≈ OpenBLAS's GEMM threading threshold of 2.6·10⁵)
and its gemv threads from 9216 elements. A fit must give the same coefficients whatever the
caller's threads, so every problem OpenBLAS could split is pinned: from ``rows · cols² =``
:data:`SMALL_FLOPS` up, without an upper limit (the measurements above found no size where two
threads paid). Only RANSAC's minimal samples (a homography's 8 x 9, a DLT's 12 x 11) stay below:
OpenBLAS runs them on one thread by itself, and switching costs ~0.03-0.06 ms per fit.

:func:`blas_threads_for` sets BLAS to one thread (threadpoolctl, a BSD
library, finds the BLAS libraries loaded in the process and sets their thread counts). The
setting is process-wide, as BLAS's own is: fits running in several threads at once share one
pin, counted under a lock, and the thread that ends the last of them puts the caller's counts
back. threadpoolctl (3.8) lets only one Python thread at a time change OpenBLAS's count and
silently ignores the others; fotogeo takes that control only for the moment of each change
(``OpenBLASController.clear_controlling_thread(force=True)`` before and after), so a pin set
in one thread is always undone, by whichever thread ends last. Without threadpoolctl nothing is
pinned (then ``OPENBLAS_NUM_THREADS=1`` is what makes fits repeatable).
"""
from __future__ import annotations

import contextlib
import sys
import threading

#: below this many rows x columns² no product of a fit reaches OpenBLAS's threading thresholds
#: (gemv from 9216 matrix elements, GEMM from 2.6·10⁵ multiply-adds): no pin
SMALL_FLOPS = 5_000

_lock = threading.Lock()
_state = {"depth": 0, "original": None, "pinned": [], "blas": None, "modules": 0}


def _blas_libraries():
    """threadpoolctl's controllers of the loaded BLAS libraries; an empty list without threadpoolctl.

    Looked up again whenever the process has imported modules since the last look: numpy's OpenBLAS
    is loaded first, scipy's own (``scipy.libs/libscipy_openblas``, used by the RFM's
    :mod:`~fotogeo.models.tikhonov` and the bundle adjustment) only when ``scipy.linalg`` is first
    imported — a list taken before that left scipy's BLAS on all its threads."""
    loaded = len(sys.modules)
    if _state["blas"] is None or _state["modules"] != loaded:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:
            _state["blas"] = []
        else:
            _state["blas"] = list(ThreadpoolController().select(user_api="blas").lib_controllers)
        _state["modules"] = len(sys.modules)
    return _state["blas"]


def _release_control() -> None:
    """Let any thread change OpenBLAS's count next (threadpoolctl's single controlling thread)."""
    try:
        from threadpoolctl import OpenBLASController
    except ImportError:
        return
    clear = getattr(OpenBLASController, "clear_controlling_thread", None)
    if clear is not None:
        clear(force=True)


def _set_counts(libraries, counts) -> None:
    _release_control()
    for lib, n in zip(libraries, counts):
        if n is not None:
            lib.set_num_threads(n)
    _release_control()


def pins(rows: int, cols: int) -> bool:
    """Whether a least-squares problem of ``rows x cols`` runs on one BLAS thread.

    >>> pins(2000, 78), pins(120, 59), pins(200_000, 80), pins(8, 9), pins(12, 11)
    (True, True, True, False, False)
    """
    return rows * cols * cols >= SMALL_FLOPS


@contextlib.contextmanager
def blas_threads_for(rows: int, cols: int):
    """Run the block on one BLAS thread when :func:`pins` says so (see the module docstring)."""
    if not pins(rows, cols):
        yield
        return
    with _lock:
        if _state["depth"] == 0:  # the first of concurrent fits pins every BLAS loaded by now
            _state["pinned"] = _blas_libraries()
            _state["original"] = [lib.get_num_threads() for lib in _state["pinned"]]
            _set_counts(_state["pinned"], [1] * len(_state["pinned"]))
        _state["depth"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["depth"] -= 1
            if _state["depth"] == 0:
                _set_counts(_state["pinned"], _state["original"])
