"""A long-lived fotogeo worker for quick calls from QGIS (the GCP picker's refits).

:class:`WorkerSession` keeps one ``python -m fotogeo.worker --session`` process running in the
plugin's runtime (the same interpreter, environment and folder as
:func:`processing_provider.runner.run_tool`), so a refit costs a JSON round trip instead of a
process start and fotogeo's imports. Protocol: :mod:`fotogeo.worker` (one request line
``{"id", "tool", "kwargs"}``, warning lines, then one result or error line with the same id).

* :meth:`WorkerSession.call` returns the tool's JSON result, or raises :class:`SessionError`
  with the tool's one-line message; warnings of the last call are in ``last_warnings`` (and in
  QGIS's message log).
* A worker that has died (crash, killed) is restarted transparently at the next call; one that
  does not answer within ``timeout`` seconds is killed (the next call starts a new one).
* Calls are serialised by a lock: several threads may share one session.

Why a separate process at all: :mod:`processing_provider.runtime`. Standard library and
``qgis.core`` only (this module runs inside QGIS).
"""
from __future__ import annotations

import json
import queue
import subprocess
import tempfile
import threading
import time

from qgis.core import Qgis, QgsMessageLog

from .runner import start_worker

STOP_WAIT_S = 3.0


class SessionError(RuntimeError):
    """A session call failed: the tool's own one-line message (``error`` = its error class)."""

    def __init__(self, message: str, error: str = "SessionError"):
        super().__init__(message)
        self.error = error


def _pump(stream, lines: queue.Queue):
    try:
        for line in stream:
            lines.put(line)
    except (OSError, ValueError):  # closed by WorkerSession._stop
        pass
    lines.put(None)  # end of output: the process has gone


class WorkerSession:
    """One fotogeo worker process answering :meth:`call` s (module docstring)."""

    def __init__(self):
        self._lock = threading.Lock()
        self._proc = None
        self._lines: queue.Queue | None = None
        self._stderr = None
        self._next_id = 0
        self.last_warnings: list[str] = []
        self.starts = 0  # processes started so far (a restart shows here)

    # -- process ------------------------------------------------------------------------------
    def _alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def _start(self):
        self._stderr = tempfile.TemporaryFile("w+", encoding="utf-8", errors="replace")
        self._proc = start_worker(self._stderr, "--session", error=SessionError, bufsize=1)
        self._lines = queue.Queue()
        threading.Thread(target=_pump, args=(self._proc.stdout, self._lines), daemon=True).start()
        self.starts += 1

    def _stop(self, kill: bool = False):
        proc, self._proc = self._proc, None
        if proc is not None and proc.poll() is None:
            try:
                if not kill:
                    proc.stdin.write("quit\n")
                    proc.stdin.flush()
                    proc.wait(STOP_WAIT_S)
            except (OSError, ValueError, subprocess.TimeoutExpired):
                pass
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        if proc is not None:
            for stream in (proc.stdin, proc.stdout):
                try:
                    stream.close()
                except (OSError, ValueError):
                    pass
        if self._stderr is not None:
            self._stderr.close()
            self._stderr = None

    def _stderr_tail(self) -> str:
        if self._stderr is None:
            return ""
        try:
            self._stderr.seek(0)
            return " | ".join(self._stderr.read().strip().splitlines()[-5:])
        except (OSError, ValueError):
            return ""

    # -- calls --------------------------------------------------------------------------------
    def call(self, tool: str, timeout: float = 30, **kwargs):
        """The JSON result of fotogeo's ``tool`` called with ``kwargs``; :class:`SessionError` on failure."""
        with self._lock:
            for attempt in (1, 2):
                if not self._alive():
                    self._stop()
                    self._start()
                self._next_id += 1
                rid = self._next_id
                try:
                    self._proc.stdin.write(json.dumps({"id": rid, "tool": tool, "kwargs": kwargs}) + "\n")
                    self._proc.stdin.flush()
                except (BrokenPipeError, OSError, ValueError):
                    self._stop(kill=True)
                    if attempt == 1:
                        continue  # it died since the last call: restart it once
                    raise SessionError(f"fotogeo's worker cannot be reached: {self._stderr_tail() or 'no message'}")
                return self._answer(rid, tool, timeout)

    def _answer(self, rid: int, tool: str, timeout: float):
        """Read lines until the result or error of request ``rid``."""
        self.last_warnings = []
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self._lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                self._stop(kill=True)
                raise SessionError(f"fotogeo's {tool} did not answer within {timeout:g} s; the worker was stopped "
                                   f"(the next call starts a new one)") from None
            if line is None:
                tail = self._stderr_tail()
                self._stop()
                raise SessionError(f"fotogeo's worker stopped during {tool}: {tail or 'no message'}")
            try:
                message = json.loads(line)
            except ValueError:
                continue
            if not isinstance(message, dict) or message.get("id") != rid:
                continue  # an answer to a request that timed out before
            kind = message.get("type")
            if kind == "warning":
                self.last_warnings.append(message.get("message", ""))
                QgsMessageLog.logMessage(f"{tool}: {message.get('message', '')}", "fotogeo", Qgis.Warning)
            elif kind == "error":
                raise SessionError(message.get("message") or message.get("error", "fotogeo failed"),
                                   message.get("error", "SessionError"))
            elif kind == "result":
                return message.get("result")

    def close(self):
        """End the worker process (a later :meth:`call` would start a new one)."""
        with self._lock:
            self._stop()


_SHARED: dict = {}
_SHARED_LOCK = threading.Lock()


def shared_session() -> WorkerSession:
    """The one session of this QGIS process (created at the first call)."""
    with _SHARED_LOCK:
        if "session" not in _SHARED:
            _SHARED["session"] = WorkerSession()
        return _SHARED["session"]


def close_shared_session() -> None:
    """Close the shared session, if any (the plugin's ``unload``)."""
    with _SHARED_LOCK:
        session = _SHARED.pop("session", None)
    if session is not None:
        session.close()
