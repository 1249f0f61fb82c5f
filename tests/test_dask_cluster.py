"""The one local Dask cluster (:func:`fotogeo.tools.common.dask_cluster.connect`) that register-batch, mosaic and
triangulate run their tasks on."""
import logging

import pytest

from fotogeo.tools.common.dask_cluster import SINGLE_THREAD_ENV, WORKER_MALLOC_ENV, connect


def _worker_environment():
    import os
    return {k: os.environ.get(k) for k in (*SINGLE_THREAD_ENV, *WORKER_MALLOC_ENV)}


def test_local_workers_start_with_one_thread_and_heap_allocations():
    """A local worker process starts with one BLAS/GDAL thread and with glibc's malloc set so arrays up to 32 MiB
    come from the heap: Dask's own MALLOC_TRIM_THRESHOLD_ alone turns every array above 128 KiB into an
    mmap/munmap with fresh page faults (half the 500-frame block's LSM time was spent in the kernel)."""
    pytest.importorskip("distributed", reason="Dask (fotogeo[batch]) is not installed")
    client, close = connect(workers=1)
    try:
        env = client.submit(_worker_environment, pure=False).result()
    finally:
        close()
    assert env == {**SINGLE_THREAD_ENV, **WORKER_MALLOC_ENV}


def test_a_batch_run_keeps_the_command_lines_log_level():
    """Importing distributed sets its logger to INFO: register-batch printed ~20 lines of cluster chatter ("State
    start", "Start Nanny at", ...) though the command line had set WARNING. The level set before the import stays."""
    import subprocess
    import sys
    pytest.importorskip("distributed")
    code = ("import logging; from fotogeo.cli.conventions import setup_logging; setup_logging(0, False); "
            "from fotogeo.tools.common.dask_cluster import distributed_module; distributed_module(); "
            "print(logging.getLogger('distributed').getEffectiveLevel())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split()[-1] == str(logging.WARNING), out
