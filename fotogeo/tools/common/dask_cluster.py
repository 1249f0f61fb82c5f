"""Where fotogeo's Dask tasks run (``register-batch``'s scenes, ``mosaic``'s tiles): one mechanism.

:func:`connect` gives a ``dask.distributed.Client``: the one given, one connected to a running scheduler
(``scheduler``: ``tcp://host:8786``; every worker must see the same paths — a shared file system — and import
fotogeo), or one of a local cluster of ``workers`` processes (default one per CPU) with one thread each. Tasks
call :func:`pin_threads` so that GDAL, OpenCV, BLAS and fotogeo's resampling use one thread: the parallelism is
across tasks, and N tasks on N cores do not oversubscribe them.
"""
from __future__ import annotations

import os

from ...errors import InputError, one_line

#: environment of a task: one thread for BLAS, GDAL, OpenCV (set separately) and fotogeo's resampling
SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                     "GDAL_NUM_THREADS": "1", "FOTOGEO_NUM_THREADS": "1"}
#: glibc malloc of a local worker. Dask's nanny sets ``MALLOC_TRIM_THRESHOLD_=65536`` (to hand freed memory back),
#: and setting any malloc tunable turns off glibc's dynamic mmap threshold: every array above 128 KiB was then
#: mmap'ed and unmapped, its pages faulted in afresh (the 500-frame block's LSM tasks spent half their time in
#: the kernel: 16 000 mmap/munmap per 10 s). Arrays up to 32 MiB come from the heap, and the heap is trimmed
#: above 64 MiB free — a worker still gives memory back, in larger steps.
WORKER_MALLOC_ENV = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(64 << 20)}


def missing_dask(what: str) -> str:
    return f"{what} needs Dask: pip install 'fotogeo[batch]' (or pip install 'dask[distributed]')"


def distributed_module(what: str = "register-batch"):
    """``dask.distributed``, or an :class:`InputError` saying how to install it. Importing it sets its logger to
    INFO; the level the command line had set (``-q``/``-v``; WARNING by default) is put back, or every batch run
    printed some 20 lines of cluster chatter ("State start", "Start Nanny at", ...) on stderr."""
    import logging
    log = logging.getLogger("distributed")
    level = log.level
    try:
        import distributed
    except ImportError:
        raise InputError(missing_dask(what)) from None
    if level:
        log.setLevel(level)
    return distributed


def pin_threads():
    """One thread for GDAL, OpenCV, BLAS (new pools) and fotogeo's resampling inside this task."""
    os.environ.update(SINGLE_THREAD_ENV)
    import cv2
    cv2.setNumThreads(1)


def connect(client=None, scheduler=None, workers=None, what: str = "register-batch"):
    """``(client, close)``: the given client, one connected to ``scheduler``, or a local cluster's
    (module docstring); ``close()`` ends what this call started."""
    if client is not None:
        return client, lambda: None
    distributed = distributed_module(what)
    if scheduler:
        try:
            c = distributed.Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise InputError(f"cannot reach the Dask scheduler {scheduler!r} ({one_line(str(e))}); is it running "
                             f"and the address right (tcp://host:8786)?") from None
        return c, c.close
    from ...io.warp import default_threads
    import dask
    spawn = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}), **WORKER_MALLOC_ENV}
    with dask.config.set({"distributed.nanny.pre-spawn-environ": spawn}):  # read by the worker's malloc at start
        cluster = distributed.LocalCluster(n_workers=workers or default_threads(), threads_per_worker=1,
                                           processes=True, dashboard_address=None, env=dict(SINGLE_THREAD_ENV))
    c = distributed.Client(cluster)
    return c, lambda: (c.close(), cluster.close())
