"""Long picker work (proposals, rectification, RPC export, report) as a :class:`QgsTask`.

The task runs one fotogeo worker tool through :func:`processing_provider.runner.run_tool` (its own
process, as the Processing algorithms do): QGIS's task manager shows the worker's progress, and
its cancel button reaches the worker (SIGTERM; the tool's atomic outputs delete what they had
started). ``on_done(ok, result, error)`` runs in the main thread when the task ends.
"""
from __future__ import annotations

from qgis.core import QgsApplication, QgsProcessingException, QgsProcessingFeedback, QgsTask


class ToolTask(QgsTask):
    """``fotogeo.worker`` tool ``tool`` called with ``kwargs`` in the background."""

    def __init__(self, description: str, tool: str, kwargs: dict, on_done):
        super().__init__(description, QgsTask.CanCancel)
        self.tool, self.kwargs, self.on_done = tool, kwargs, on_done
        self.result, self.error = None, None
        self.feedback = QgsProcessingFeedback()
        self.feedback.progressChanged.connect(self.setProgress)

    def run(self):
        from ..runner import run_tool
        try:
            self.result = run_tool(self.tool, feedback=self.feedback, **self.kwargs)
        except QgsProcessingException as e:
            self.error = str(e)
            return False
        except Exception as e:  # noqa: BLE001 - shown to the user by on_done, never a crash of QGIS
            self.error = f"{type(e).__name__}: {e}"
            return False
        return not self.feedback.isCanceled()

    def cancel(self):
        self.feedback.cancel()
        super().cancel()

    def finished(self, ok):
        if not ok and self.error is None:
            self.error = "cancelled" if self.isCanceled() else "failed"
        self.on_done(ok, self.result, self.error)


def start(description: str, tool: str, kwargs: dict, on_done) -> ToolTask:
    """Queue a :class:`ToolTask` in QGIS's task manager and return it (keep a reference while it runs)."""
    task = ToolTask(description, tool, kwargs, on_done)
    QgsApplication.taskManager().addTask(task)
    return task
