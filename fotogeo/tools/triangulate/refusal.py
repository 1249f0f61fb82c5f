"""What a refused triangulation leaves behind once its frames were matched: the pairs it tried, in the error's one
line and in ``report.json`` (the tool layer of ``fotogeo triangulate``).

A block refused for lack of ties (a frame reached by too few tie points, a frame the block does not determine) is a
question about matching: which pairs were tried, how many descriptor matches each gave and how many of them fit
the two-view geometry — on the frames as they are and, where it ran, on the ground plane
(:mod:`fotogeo.tools.triangulate.guided`). The error names the weakest pairs with their counts (the one line
stays short); ``report.json`` in the output folder lists every pair, with the refusal and the inputs — the one
file such a run writes, in the format of every refused run's report (:mod:`fotogeo.tools.common.refusal`).
"""
from __future__ import annotations

from pathlib import Path

from ...errors import InputError, MatchingError, ModelError
from ..common.refusal import reporting_refusal as common_reporting

#: pairs named in the error's line (those of the refused frames first, the weakest first); every pair is in the report
SHOWN = 3


def pair_summary(matching: dict, names, refused=()) -> str:
    """``"pairs tried (matches/inliers): A–B 89/65, C–D 54/40 plain, 124/120 on the ground plane, …"``: the
    :data:`SHOWN` pairs — those of the frames ``refused`` first, then the fewest inliers kept — and how many more
    there are."""
    refused = set(refused)
    rows = sorted(matching.get("pairs") or [],
                  key=lambda r: (not refused & {names[k] for k in r["pair"]}, r["inliers"], r["pair"]))
    if not rows:
        return "no pair of frames overlapped"
    parts = []
    for r in rows[:SHOWN]:
        a, b = (names[k] for k in r["pair"])
        plain, g = r.get("plain", r), r.get("guided")
        text = f"{a}–{b} {plain['matches']}/{plain['inliers']}"
        if g and g.get("skipped"):
            text += f" plain, not on the ground plane ({g['skipped']})"
        elif g:
            text += f" plain, {g['matches']}/{g['inliers']} on the ground plane"
        parts.append(text)
    more = f", {len(rows) - SHOWN} more" if len(rows) > SHOWN else ""
    return f"{len(rows)} pair(s) tried (matches/epipolar inliers): {', '.join(parts)}{more}"


def reporting_refusal(path: Path, matching, names, inputs: dict):
    """A refusal (:class:`ModelError`, :class:`MatchingError`, :class:`InputError`) raised inside, once the frames
    were matched (``matching`` not None), is raised again with the pairs tried in its line, after their report is
    written to ``path`` (the one refusal report, :mod:`fotogeo.tools.common.refusal`: ``frames`` and ``matching``
    what the run had found)."""
    def found():
        return None if matching is None else {"frames": list(map(str, names)), "matching": matching}

    def reword(exc, path):
        head, sep, fix = str(exc).rpartition(" — ")  # the pairs go with the detail, before the fix
        head, sep, fix = (head, sep, fix) if sep else (fix, "", "")
        message = f"{head}; {pair_summary(matching, names, exc.frames)}{sep}{fix}"
        # the line names the report by its folder and name (the full path would crowd the one line)
        return f"{message}; every pair in {Path(path).parent.name}/{Path(path).name}", message

    return common_reporting(path, "triangulate", inputs, found, (ModelError, MatchingError, InputError), reword)
