"""The worker runs a request in the caller's folder (relative paths from ``qgis_process`` are the caller's) and
gives the folder back afterwards, so that a worker serving another request does not inherit it."""
from __future__ import annotations

import os

import pytest

from fotogeo import worker
from fotogeo.errors import InputError


def where(progress=None, fail=False):
    """A stand-in tool: the folder it runs in (or an error, to check the folder is restored after one)."""
    if fail:
        raise InputError("refused")
    return os.getcwd()


class _Silent:
    def progress(self, fraction, message=""):
        return True

    running = False


@pytest.fixture
def probe(monkeypatch):
    monkeypatch.setitem(worker.TOOLS, "where", (__name__, "where"))


def test_a_request_runs_in_the_callers_folder_and_gives_it_back(probe, tmp_path):
    before = os.getcwd()
    assert worker.run_request({"tool": "where", "cwd": str(tmp_path)}, _Silent()) == str(tmp_path)
    assert os.getcwd() == before


def test_the_folder_is_given_back_after_a_refusal(probe, tmp_path):
    before = os.getcwd()
    with pytest.raises(InputError):
        worker.run_request({"tool": "where", "cwd": str(tmp_path), "kwargs": {"fail": True}}, _Silent())
    assert os.getcwd() == before


def test_without_a_folder_the_request_runs_where_the_worker_is(probe):
    assert worker.run_request({"tool": "where"}, _Silent()) == os.getcwd()
