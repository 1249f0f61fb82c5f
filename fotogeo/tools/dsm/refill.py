"""The pair choice redone after the pairs' setup: a pair refused when set up gives its images their next candidate.

The choice (:func:`fotogeo.stereo.pairs.choose_pairs`) sees only the footprints; a kept pair may still be refused
when set up (:func:`.tool._pair_setup`: :func:`fotogeo.stereo.rectify.rectify` fails, its sparse matches' row
differences after rectification say the orientation does not fit, too few matches). Refused after the choice, it
kept the per-image cap's slot it took from a pair that would have matched, and its images lost that partner with
nothing in its place. So the refused pairs are added to the choice's ``leave_out`` and the choice is redone: the
cap and the readmission of uncovered ground then give their slots to the next candidates; only the pairs the new
choice adds are set up (a pair's sparse check runs once), and this repeats while new pairs are refused, at most
:data:`MAX_ROUNDS` times. Every pair set up and matched stays kept (a pair is never dropped for its replacement),
and a pair the redone choice adds names the refused pairs of its images (``replaces``): those sharing an image with
it, else all the refusals of that round (ground the readmission freed).
"""
from __future__ import annotations

#: choices redone after the first; each one follows a round of refusals, so the loop ends when one has none
MAX_ROUNDS = 4


def settle(choose, set_up, names, rounds: int = MAX_ROUNDS) -> tuple:
    """``(choices, setups, tried)``: the final choice (:class:`~fotogeo.stereo.pairs.PairChoice` s), the set-up
    pairs still kept by ``(i, j)`` and every pair set up (in order; module docstring). ``choose(refused)``: the pair
    choice with the ``{(i, j): reason}`` refused so far left out; ``set_up(p)``: a matchable pair's set-up, or the
    reason (str) to leave it out; ``names``: the images' names."""
    refused, done, setups = {}, {}, {}
    choices = choose(refused)
    for r in range(rounds + 1):
        choices = [_carry(p, done, refused) for p in choices]
        now = []
        for p in [p for p in choices if p.kept and (p.i, p.j) not in done]:
            done[(p.i, p.j)] = p
            got = set_up(p)
            if isinstance(got, str):
                p.kept, p.reason, refused[(p.i, p.j)] = False, got, got
                now.append(p)
            else:
                setups[(p.i, p.j)] = got
        if not now or r == rounds:
            break
        before = {(p.i, p.j) for p in choices if p.kept}
        choices = choose(refused)
        for p in choices:
            if p.kept and (p.i, p.j) not in before and (p.i, p.j) not in done:
                _name_replaced(p, now, names)
    return choices, {k: m for k, m in setups.items() if done[k].kept}, list(done.values())


def _carry(p, done: dict, refused: dict):
    """The pair set up before in place of the redone choice's ``p`` (its measures and matches in ``extra``, the
    one its set-up refers to): kept when its set-up worked, left out with its own reason when refused."""
    old = done.get((p.i, p.j))
    if old is None:
        return p
    if (p.i, p.j) in refused:
        old.kept, old.reason = False, refused[(p.i, p.j)]
    return old


def _name_replaced(p, now: list, names) -> None:
    """Say in ``p``'s reason and ``extra["replaces"]`` which refused pairs of this round it replaces."""
    mine = [q for q in now if {q.i, q.j} & {p.i, p.j}] or now
    gone = [f"{names[q.i]}-{names[q.j]}" for q in mine]
    p.extra["replaces"] = gone
    p.reason = (f"{p.reason}; chosen after {', '.join(gone)} {'was' if len(gone) == 1 else 'were'} refused when set "
                "up")
