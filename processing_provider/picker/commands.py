"""Undo/redo of the picker's edits: each edit is a :class:`QUndoCommand` on a :class:`QUndoStack`.

GCPs are known by their ``id`` (feature ids change when a deleted point is added back). The
dock refits after every change of the stack's index (push, undo, redo), so an undo restores
the table, the arrows and the predictions with the points.
"""
from __future__ import annotations

from dataclasses import replace

from qgis.PyQt.QtWidgets import QUndoCommand

from .gcp_layer import Gcp, GcpLayer


def _fid(store: GcpLayer, gcp_id: str) -> int | None:
    return next((g.fid for g in store.gcps() if g.id == gcp_id), None)


class AddGcps(QUndoCommand):
    """Add points (one click pair, accepted proposals, an import)."""

    def __init__(self, store: GcpLayer, gcps: list[Gcp], text: str = ""):
        super().__init__(text or (f"add GCP {gcps[0].id}" if len(gcps) == 1 else f"add {len(gcps)} GCPs"))
        self.store, self.gcps = store, list(gcps)

    def redo(self):
        self.gcps = [self.store.add(g) for g in self.gcps]

    def undo(self):
        for g in self.gcps:
            fid = _fid(self.store, g.id)
            if fid is not None:
                self.store.delete(fid)


class DeleteGcps(QUndoCommand):
    def __init__(self, store: GcpLayer, gcps: list[Gcp]):
        super().__init__(f"delete GCP {gcps[0].id}" if len(gcps) == 1 else f"delete {len(gcps)} GCPs")
        self.store, self.gcps = store, list(gcps)

    def redo(self):
        for g in self.gcps:
            fid = _fid(self.store, g.id)
            if fid is not None:
                self.store.delete(fid)

    def undo(self):
        self.gcps = [self.store.add(g) for g in self.gcps]


class UpdateGcp(QUndoCommand):
    """Move a point (image or map side), change its role or height: ``before`` -> ``after``."""

    def __init__(self, store: GcpLayer, before: Gcp, after: Gcp, text: str = ""):
        super().__init__(text or f"edit GCP {before.id}")
        self.store, self.before, self.after = store, before, after

    def _write(self, gcp: Gcp):
        fid = _fid(self.store, gcp.id)
        if fid is not None:
            self.store.update(replace(gcp, fid=fid))

    def redo(self):
        self._write(self.after)

    def undo(self):
        self._write(self.before)
