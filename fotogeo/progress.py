"""The one progress protocol of fotogeo.

A progress callback is any callable ``progress(fraction: float, message: str) -> bool``.
``fraction`` runs from 0.0 to 1.0 over the whole job; returning ``False`` (and only
``False``; ``None`` means "go on") asks the job to stop, which then raises
:class:`fotogeo.errors.Cancelled` and removes what it had started writing.

Tools split their work into stages with :meth:`Progress.stage`, each stage owning a slice
of the fraction range, so nested functions report in their own 0..1 terms. A progress and
all its stages share one ``timings`` store, which :meth:`Progress.timed` blocks fill with
wall-clock seconds (a tool starts its own store with :meth:`Progress.with_own_timings`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable, Optional

from .errors import Cancelled

ProgressCallback = Callable[[float, str], Optional[bool]]


def _silent(fraction: float, message: str) -> bool:
    return True


@dataclass
class Progress:
    """Maps a sub-task's 0..1 progress into a slice ``[start, end]`` of a parent callback.

    >>> seen = []
    >>> p = Progress(lambda f, m: seen.append(round(f, 2)) or True)
    >>> sub = p.stage(0.5, 1.0, "half")
    >>> sub(0.5, "inside")
    >>> seen
    [0.5, 0.75]
    """

    callback: ProgressCallback | None = None
    start: float = 0.0
    end: float = 1.0
    label: str = ""
    timings: dict = field(default_factory=dict)

    def __call__(self, fraction: float, message: str = "") -> None:
        """Report ``fraction`` of this slice; raise :class:`Cancelled` if the callback says stop."""
        cb = self.callback or _silent
        f = self.start + (self.end - self.start) * min(max(float(fraction), 0.0), 1.0)
        text = message or self.label
        if cb(f, text) is False:
            raise Cancelled(f"cancelled by the user during: {text or 'processing'}")

    def stage(self, start: float, end: float, label: str) -> "Progress":
        """A child reporting into ``[start, end]`` (fractions of this slice); reports 0 at once."""
        span = self.end - self.start
        child = Progress(self.callback, self.start + span * start, self.start + span * end, label,
                         self.timings)
        child(0.0, label)
        return child

    def timed(self, name: str):
        """Context manager adding the wall time of a block to ``timings[name]`` (seconds).

        >>> p = Progress().with_own_timings()
        >>> with p.stage(0.0, 1.0, "work").timed("work"):
        ...     pass
        >>> list(p.timings)
        ['work']
        """
        return _Timer(self.timings, name)

    def with_own_timings(self) -> "Progress":
        """This progress with a new, empty ``timings`` store, shared by the stages made from it."""
        return replace(self, timings={})


class _Timer:
    def __init__(self, store: dict, name: str):
        self.store, self.name = store, name

    def __enter__(self):
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.store[self.name] = self.store.get(self.name, 0.0) + time.perf_counter() - self.t0
        return False


def as_progress(progress: ProgressCallback | Progress | None) -> Progress:
    """Wrap a user callback (or None) into a :class:`Progress`."""
    if isinstance(progress, Progress):
        return progress
    return Progress(progress)
