"""What a refused triangulation leaves behind once its frames were matched: the pairs it tried, in the error's one
line and in ``report.json`` (the tool layer of ``fotogeo triangulate``).

A block refused for lack of ties (a frame reached by too few tie points, a frame the block does not determine) is a
question about matching: which pairs were tried, how many descriptor matches each gave and how many of them fit
the two-view geometry — on the frames as they are and, where it ran, on the ground plane
(:mod:`fotogeo.tools.triangulate.guided`). The error names the weakest pairs with their counts (the one line
stays short); ``report.json`` in the output folder lists every pair, with the refusal, the inputs and the start —
the one file such a run writes (written whole or not at all: a temporary file renamed).
"""
from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from ...errors import InputError, MatchingError, ModelError

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


def write_refusal_report(path: Path, message: str, matching: dict, names, inputs: dict) -> None:
    """``report.json`` of a refused run (module docstring), written to a temporary file and renamed."""
    from ...io.report import write_json_whole
    write_json_whole(path, {"refused": message, "inputs": inputs, "frames": list(map(str, names)),
                            "matching": matching})


@contextmanager
def reporting_refusal(path: Path, matching, names, inputs: dict):
    """A refusal (:class:`ModelError`, :class:`MatchingError`, :class:`InputError`) raised inside, once the frames were matched (``matching`` not None), is raised
    again with the pairs tried in its line, after their report is written to ``path``."""
    try:
        yield
    except (ModelError, MatchingError, InputError) as exc:
        if matching is None:
            raise
        head, sep, fix = str(exc).rpartition(" — ")  # the pairs go with the detail, before the fix
        head, sep, fix = (head, sep, fix) if sep else (fix, "", "")
        message = f"{head}; {pair_summary(matching, names, exc.frames)}{sep}{fix}"
        try:  # the line names the report by its folder and name (the full path would crowd the one line)
            line = f"{message}; every pair in {Path(path).parent.name}/{Path(path).name}"
            write_refusal_report(path, line, matching, names, inputs)
            message = line
        except OSError:
            pass
        raise type(exc)(message, option=exc.option, frames=exc.frames, also=exc.also) from None
