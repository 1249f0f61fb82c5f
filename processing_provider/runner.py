"""Run a fotogeo tool in the plugin's runtime (``python -m fotogeo.worker``) for a Processing algorithm.

The worker's JSON lines drive the algorithm's feedback: progress and its text, warnings;
its final line is the tool's result (JSON) or its error, raised as a
:class:`QgsProcessingException` with the tool's own one-line message. Cancel (the dialog's
button, a task's cancel) sends SIGTERM: the worker raises ``Cancelled`` inside the tool, whose
atomic outputs delete what they had started; a worker that does not stop within
:data:`KILL_AFTER_S` is killed. Why a separate process at all: :mod:`processing_provider.runtime`.
"""
from __future__ import annotations

import json
import os
import queue
import re
import signal
import subprocess
import tempfile
import threading
import time

from qgis.core import QgsApplication, QgsProcessingException, QgsSettings

from . import runtime as rt

KILL_AFTER_S = 15.0
_STATUS: dict = {}


def current_runtime() -> rt.Runtime:
    """The runtime of the running QGIS profile (see :func:`processing_provider.runtime.resolve`)."""
    return rt.resolve(QgsApplication.qgisSettingsDirPath(), QgsSettings().value(rt.SETTING, "") or None)


def runtime_status(refresh: bool = False) -> tuple[bool, str]:
    """``(usable, message)`` of the current runtime, cached until :func:`forget_status`."""
    key = str(current_runtime())
    if refresh or _STATUS.get("key") != key:
        _STATUS.update(key=key, value=rt.status(current_runtime()))
    return _STATUS["value"]


def forget_status() -> None:
    _STATUS.clear()


def _reader(stream, lines: queue.Queue):
    for line in stream:
        lines.put(line)
    lines.put(None)


def _message(line: str):
    try:
        message = json.loads(line)
    except ValueError:
        return None
    return message if isinstance(message, dict) else None


#: a progress text that differs from the last logged one only in its numbers ("iteration 12, cost 4875.1") is
#: logged again after this many seconds at the earliest: the log keeps the stages, not every iteration
REPEAT_S = 15.0


def _apply(message: dict, feedback, last: list, words=str):
    """Progress and warnings (in the user's ``words``) to the feedback; returns the final message, or None.
    ``last``: ``[text, its numbers-free stem, when]`` of the last progress text logged."""
    kind = message.get("type")
    if kind == "progress":
        if feedback is not None:
            feedback.setProgress(100.0 * min(max(float(message.get("fraction", 0.0)), 0.0), 1.0))
            text = message.get("message") or ""
            stem, now = re.sub(r"[-+.,e\d]*\d", "#", text), time.monotonic()
            if text and text != last[0] and (stem != last[1] or now - last[2] >= REPEAT_S):
                last[:] = [text, stem, now]
                feedback.setProgressText(text)
        return None
    if kind == "warning":
        if feedback is not None:
            feedback.pushWarning(words(message.get("message", "")))
        return None
    return message if kind in ("result", "error") else None


def start_worker(stderr, *worker_args: str, error=QgsProcessingException, **popen) -> subprocess.Popen:
    """Start ``python -m fotogeo.worker [worker_args]`` in the current runtime (text pipes on stdin/stdout,
    ``stderr`` a file); ``error(message)`` with the reason and the fix when the runtime is not usable."""
    ok, why = runtime_status()
    if not ok:
        ok, why = runtime_status(refresh=True)  # installed since the last look?
    if not ok:
        raise error(why)
    runtime = current_runtime()
    try:
        return subprocess.Popen(rt.worker_command(runtime, *worker_args), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=stderr, text=True, encoding="utf-8", env=rt.worker_environment(),
                                cwd=str(rt.PLUGIN_ROOT), **popen)
    except OSError as e:
        forget_status()
        raise error(f"fotogeo's runtime {runtime.python} cannot start ({e}). Fix: menu fotogeo > "
                    f"Install / repair runtime") from None


def callers_folder() -> str | None:
    """The folder QGIS runs in (``qgis_process``: the user's shell's), against which the worker resolves the
    relative paths of a request: it starts in the plugin's folder (:func:`start_worker`), so that no module of
    the user's folder shadows fotogeo's, and changes to this one before running the tool. None when the folder
    has gone."""
    try:
        return os.getcwd()
    except OSError:
        return None


def run_tool(tool: str, *args, feedback=None, words=str, **kwargs):
    """Call fotogeo's ``tool`` (a name of ``fotogeo.worker.TOOLS``) in the runtime; its JSON result.

    ``words(message)`` puts the tool's warnings and error in the caller's words (command-line flags →
    parameter labels, :func:`fotogeo.options.in_labels`). Relative paths among ``args`` and ``kwargs`` are the
    caller's (:func:`callers_folder`), as ``qgis_process run … --FRAMES=img/a.JPG`` means them."""
    request = json.dumps({"tool": tool, "args": list(args), "kwargs": kwargs, "cwd": callers_folder()}) + "\n"
    with tempfile.TemporaryFile("w+", encoding="utf-8", errors="replace") as stderr, start_worker(stderr) as proc:
        proc.stdin.write(request)  # the pipes are closed on leaving (qgis_process printed ResourceWarnings)
        proc.stdin.flush()
        final = _follow(proc, feedback, words)
        proc.wait()
        if final is None and feedback is not None and feedback.isCanceled():  # SIGTERM before its handler was set
            raise QgsProcessingException("cancelled by the user (fotogeo's worker ended before it began the tool)")
        if final is None:
            stderr.seek(0)
            tail = " | ".join(stderr.read().strip().splitlines()[-5:])
            raise QgsProcessingException(f"fotogeo's worker stopped without an answer (exit {proc.returncode}): "
                                         f"{tail or 'no message'}")
        if final["type"] == "error":
            if final.get("traceback") and feedback is not None:
                feedback.pushDebugInfo(final["traceback"])
            raise QgsProcessingException(_in_callers_words(final, words))
        return final.get("result")


def _in_callers_words(error: dict, words) -> str:
    """The worker's error message in the caller's words: ``words(message, option, also)``, ``option`` the option
    the error is about (``error["option"]``, :attr:`fotogeo.errors.FotogeoError.option`) or None, ``also`` the
    further options it names (:attr:`~fotogeo.errors.FotogeoError.also`)."""
    message = error.get("message") or error.get("error", "fotogeo failed")
    if words is str:
        return message
    return words(message, error.get("option"), tuple(error.get("also") or ()))


def _follow(proc, feedback, words=str):
    """Read the worker's lines until its final message; SIGTERM it on cancel, kill it if it hangs."""
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=_reader, args=(proc.stdout, lines), daemon=True).start()
    last, final, cancelled_at = [None, None, 0.0], None, None
    while True:
        if cancelled_at is None and feedback is not None and feedback.isCanceled():
            cancelled_at = time.monotonic()
            proc.send_signal(signal.SIGTERM)
        if cancelled_at is not None and time.monotonic() - cancelled_at > KILL_AFTER_S and proc.poll() is None:
            proc.kill()
        try:
            line = lines.get(timeout=0.1)
        except queue.Empty:
            continue
        if line is None:
            return final
        message = _message(line)
        if message is not None:
            final = _apply(message, feedback, last, words) or final
