"""The report of a refused run (``fotogeo dsm --report``, ``fotogeo triangulate``'s ``report.json``): one format, one
writer, for every tool that leaves one.

A run refused once its outputs were checked writes its report — what was given and what the run had found when it
stopped — so the user can see why, not only the error's one line. The report is JSON, written whole or not at all
(:func:`fotogeo.io.report.write_json_whole`)::

    {"fotogeo": "<command>", "status": "refused",
     "error": "<the error's line>", "refused": "<the same line>",   # "refused": the key triangulate's report had
     "option": "<the option it concerns, or null>",                  # the tool's name; the CLI's flag, QGIS's label
     "inputs": {...},                                                # paths as text
     ...what the run had found (dsm: crs, crs_rule, pairs; triangulate: frames, matching)...,
     "outputs": {"report": "<this file>"}}

A report that cannot be written leaves the refusal as it was (the refusal is what the user must read). A run
refused by the outputs' own checks (an existing file without overwrite, a report beside an input) writes nothing:
the report's path is then no place to write.
"""
from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from ...errors import FotogeoError


def refusal_entries(command: str, message: str, option, inputs: dict, found: dict, path) -> dict:
    """The refused run's report of the module docstring; ``inputs`` with paths as text (None left out)."""
    given = {k: ([str(p) for p in v] if isinstance(v, (list, tuple)) else str(v) if isinstance(v, Path) else v)
             for k, v in inputs.items() if v is not None}
    return {"fotogeo": command, "status": "refused", "error": message, "refused": message, "option": option,
            "inputs": given, **found, "outputs": {"report": str(path)}}


def write_refusal(path, command: str, message: str, option, inputs: dict, found: dict) -> bool:
    """Write the report (module docstring) to ``path``; False when it could not be written."""
    from ...io.report import write_json_whole
    try:
        write_json_whole(path, refusal_entries(command, message, option, inputs, found, path))
    except OSError:
        return False
    return True


@contextmanager
def reporting_refusal(path, command: str, inputs: dict, found=dict, errors=(FotogeoError,), reword=None):
    """A refusal (one of ``errors``) raised inside writes the report to ``path`` (None: none asked) and is raised
    again. ``found()``: the report's fields of what the run had found (None: nothing worth a report yet, the
    refusal raised as it is); ``inputs`` read when the refusal comes (a run may complete it on the way).
    ``reword(exc, path)``: ``(the line when the report was written, the line when not)`` — a line other than the
    error's is raised as the same error with that line (its option and parts kept)."""
    try:
        yield
    except errors as exc:
        fields = found() if path is not None else None
        if fields is None:
            raise
        written, unwritten = reword(exc, path) if reword is not None else (str(exc), str(exc))
        line = written if write_refusal(path, command, written, exc.option, inputs, fields) else unwritten
        if line == str(exc):
            raise
        raise type(exc)(line, option=exc.option, frames=getattr(exc, "frames", ()),
                        also=getattr(exc, "also", ())) from None
