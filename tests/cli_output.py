"""Helpers reading what a CLI run printed, shared by the test modules."""
from __future__ import annotations

import re


def not_progress(stderr: str) -> list:
    """The lines of ``stderr`` less the progress (off a terminal: ``' 42.0% message'`` lines)."""
    return [line for line in stderr.splitlines() if not re.match(r"^\s*\d+\.\d% ", line)]
