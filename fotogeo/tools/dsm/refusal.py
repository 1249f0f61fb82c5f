"""What a refused ``fotogeo dsm`` run leaves behind: its report (``--report``), never the DSM.

A run refused once its outputs were checked (no stereo pair among the images, no pair that could be set up, no
height matched, a bad input found on the way) wrote nothing, and the user could not see which pairs were tried and
why each was left out. Its report now says ``"status": "refused"``, the error's line (``error``, and ``option``: the
tool's name of the option it concerns, which the command line calls by its flag and QGIS by its label), the inputs,
and what the run had found when it stopped: the map CRS and its rule, and every candidate pair with its measures
and why it was kept or left out (as in a finished run's report). It is the one refusal report
(:mod:`fotogeo.tools.common.refusal`, as a refused ``triangulate``'s ``report.json``): whole or not at all, the
refusal left as it was when the report cannot be written. Every refusal once the outputs were checked writes it
(two images needed, ``--rpc`` with a frames' orientation or ``--sfm-frame``, a bad ``--crs`` too); a run refused by
the outputs' own checks (an existing file without ``--overwrite``, a report beside an input) writes nothing: the
report's path is then no place to write.
"""
from __future__ import annotations


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
