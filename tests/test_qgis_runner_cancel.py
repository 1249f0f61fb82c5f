"""A cancel that ends fotogeo's worker before the worker has set its SIGTERM handler (under load, in its first
second) read "fotogeo's worker stopped without an answer (exit -15)" instead of "cancelled" (the QGIS files under
OpenBLAS Nehalem at load 25–30, docs/development.md): the runner sent that SIGTERM itself, so it says cancelled."""
from __future__ import annotations

import subprocess
import sys

import pytest
from qgis_env import need_qgis

pytestmark = [pytest.mark.qgis]


class _Cancelled:
    def isCanceled(self):  # noqa: N802 - QGIS's name
        return True

    def __getattr__(self, name):  # setProgress, pushInfo…: nothing to show
        return lambda *a, **k: None


def test_a_cancel_before_the_worker_answers_reads_cancelled(monkeypatch):
    need_qgis()
    from qgis.core import QgsProcessingException
    from processing_provider import runner

    def worker_without_handler(stderr, *args, **kwargs):  # a worker still starting: SIGTERM's default ends it
        return subprocess.Popen([sys.executable, "-c", "import sys, time; sys.stdin.readline(); time.sleep(60)"],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, text=True)

    monkeypatch.setattr(runner, "start_worker", worker_without_handler)
    with pytest.raises(QgsProcessingException, match=r"^cancelled by the user"):
        runner.run_tool("ortho", feedback=_Cancelled())
