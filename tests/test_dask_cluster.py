"""The one local Dask cluster (:func:`fotogeo.tools.common.dask_cluster.connect`) that register-batch, mosaic and
triangulate run their tasks on."""
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
