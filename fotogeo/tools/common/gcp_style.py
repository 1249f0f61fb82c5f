"""The legend class of a GCP in every layer fotogeo writes (one style, ``styles/gcps.qml``, draws them).

``class`` is the point's role — ``control`` or ``check`` — unless the blunder test flagged it:
``blunder`` (flagged, removed from the fit or not) or ``suspect`` (flagged where the redundancy is too
low to call it a blunder; :mod:`fotogeo.orientation.blunders`). A point the fit left out as a blunder
(role ``blunder``) is a ``blunder`` too.
"""
from __future__ import annotations

import numpy as np

CLASSES = ("control", "check", "suspect", "blunder")


def legend_class(role, flag) -> np.ndarray:
    """``(N,)`` legend classes from the points' roles and blunder-test flags.

    >>> legend_class(["control", "control", "check", "blunder"], ["", "suspect", "", ""]).tolist()
    ['control', 'suspect', 'check', 'blunder']
    """
    role = np.asarray(role).astype(object)
    flag = np.asarray(flag).astype(object)
    out = role.copy()
    out[flag == "suspect"] = "suspect"
    out[(flag == "blunder") | (role == "blunder")] = "blunder"
    return out.astype(str)
