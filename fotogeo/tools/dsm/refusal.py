"""What a refused ``fotogeo dsm`` run leaves behind: its report (``--report``), never the DSM.

A run refused once its outputs were checked (no stereo pair among the images, no pair that could be set up, no
height matched, a bad input found on the way) wrote nothing, and the user could not see which pairs were tried and
why each was left out. Its report now says ``"status": "refused"``, the error's line (``error``, and ``option``: the
tool's name of the option it concerns, which the command line calls by its flag and QGIS by its label), the inputs,
and what the run had found when it stopped: the map CRS and its rule, and every candidate pair with its measures
and why it was kept or left out (as in a finished run's report). It is written as a refused ``triangulate``
writes its ``report.json`` (:mod:`fotogeo.tools.triangulate.refusal`), whole or not at all
(:func:`fotogeo.io.report.write_json_whole`); a report that cannot be written leaves the refusal as it was. A run
refused by the outputs' own checks (an existing file without ``--overwrite``, a report beside an input) writes
nothing: the report's path is then no place to write.
"""
from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from ...errors import FotogeoError


class Attempt:
    """What a run has found so far (module docstring): the images' ``names``, the latest pair ``choices``
    (:class:`~fotogeo.stereo.pairs.PairChoice` s, kept or left out with their reasons), the map ``crs`` and its
    ``crs_rule``."""

    def __init__(self):
        self.names, self.choices, self.crs, self.crs_rule = [], [], None, None

    def entries(self) -> dict:
        """The report's fields of what was found (those not found yet left out)."""
        from .outputs import pair_entry
        out = {}
        if self.crs is not None:
            out.update(crs=getattr(self.crs, "name", str(self.crs)), crs_rule=self.crs_rule)
        if self.choices:
            out.update(pairs=[pair_entry(p, self.names) for p in self.choices],
                       pairs_kept=sum(p.kept for p in self.choices))
        return out


@contextmanager
def reporting_refusal(report, inputs: dict):
    """Yield an :class:`Attempt` for the run to fill; a deliberate refusal (:class:`~fotogeo.errors.FotogeoError`)
    raised inside writes the report ``report`` (None: none asked) of the module docstring and is raised again."""
    attempt = Attempt()
    try:
        yield attempt
    except FotogeoError as exc:
        if report is not None:
            write_refusal(report, exc, inputs, attempt)
        raise


def write_refusal(report, exc: FotogeoError, inputs: dict, attempt: Attempt) -> None:
    """The refused run's report (module docstring); an :class:`OSError` writing it is left unsaid (the refusal is
    what the user must read)."""
    from ...io.report import write_json_whole
    data = {"fotogeo": "dsm", "status": "refused", "error": str(exc), "option": exc.option,
            "inputs": {k: (str(v) if isinstance(v, Path) else v) for k, v in inputs.items() if v is not None},
            **attempt.entries(), "outputs": {"report": str(report)}}
    try:
        write_json_whole(report, data)
    except OSError:
        pass
