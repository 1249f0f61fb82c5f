"""The worker's progress texts in the Processing log: every stage, not every iteration of one."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis

pytestmark = [pytest.mark.qgis]
need_qgis()

from processing_provider import runner  # noqa: E402


class Feedback:
    def __init__(self):
        self.texts, self.values = [], []

    def setProgress(self, value):  # noqa: N802 - QGIS's name
        self.values.append(value)

    def setProgressText(self, text):  # noqa: N802 - QGIS's name
        self.texts.append(text)


def test_iterations_of_one_stage_are_logged_once_stages_always(monkeypatch):
    fb, last = Feedback(), [None, None, 0.0]
    clock = iter([float(t) for t in range(100)] + [200.0] * 10)
    monkeypatch.setattr(runner.time, "monotonic", lambda: next(clock))
    texts = ["matching"] + [f"bundle adjustment: iteration {k}, cost {4875.12 - k / 100:.6g}" for k in range(1, 12)] + [
        "resampling window 1/6", "resampling window 2/6", "resampled", "bundle adjustment: iteration 60, cost 4874.9"]
    for k, text in enumerate(texts):
        runner._apply({"type": "progress", "fraction": k / len(texts), "message": text}, fb, last)
    assert len(fb.values) == len(texts)  # the bar moves at every message
    # iterations 2 … 11 come within 15 s of iteration 1: not logged; after another stage the stem is new again
    assert fb.texts == ["matching", "bundle adjustment: iteration 1, cost 4875.11", "resampling window 1/6",
                        "resampled", "bundle adjustment: iteration 60, cost 4874.9"]
