"""The desktop menu *fotogeo*: *Install / repair runtime* and *Runtime status*.

The install runs as a :class:`QgsTask` (QGIS's task manager shows its progress and can cancel
it) doing what ``make qgis-install`` does for the runtime (:func:`processing_provider.runtime.install`):
a venv of binary wheels beside QGIS, checked by the worker. Afterwards the provider is
refreshed, so the algorithms, greyed out until then (``canExecute``), become runnable.
The status shows the versions of GDAL, GEOS and PROJ the worker runs with next to QGIS's own.
"""
from __future__ import annotations

from qgis.core import Qgis, QgsApplication, QgsMessageLog, QgsTask
from qgis.PyQt.QtWidgets import QAction, QMessageBox

from . import runner
from . import runtime as rt

MENU = "&fotogeo"


def qgis_libraries() -> str:
    """GDAL, GEOS and PROJ as QGIS's own process loaded them."""
    from osgeo import gdal
    from qgis.core import QgsProjUtils
    geos = Qgis.geosVersion() if hasattr(Qgis, "geosVersion") else "?"
    proj = f"{QgsProjUtils.projVersionMajor()}.{QgsProjUtils.projVersionMinor()}"
    return f"GDAL {gdal.__version__}, GEOS {geos}, PROJ {proj}"


def status_report(check: dict | None = None) -> str:
    """Human-readable: is the runtime usable; the libraries on each side, and why they may differ."""
    ok, why = runner.runtime_status(refresh=True)
    runtime = runner.current_runtime()
    check = check if check is not None else (rt.check(runtime) if runtime.python.exists() else {})
    lines = [why, "", f"QGIS {Qgis.QGIS_VERSION} runs with {qgis_libraries()} (its own process)."]
    if check.get("libraries"):
        lines.append(f"fotogeo's worker ({runtime.python}) runs with {rt.describe_libraries(check)}.")
        lines.append("They may differ: each process loads its own libraries, so the versions cannot conflict.")
    for problem in check.get("problems", []):
        lines.append(f"Problem: {problem}")
    return "\n".join(lines)


class InstallTask(QgsTask):
    """Builds or repairs the runtime in the background; reports through the task manager."""

    def __init__(self, on_done):
        super().__init__("fotogeo: install / repair runtime", QgsTask.CanCancel)
        self.runtime, self.on_done, self.error, self.result = runner.current_runtime(), on_done, None, None

    def run(self):
        def progress(fraction, message):
            self.setProgress(100.0 * fraction)
            return not self.isCanceled()
        try:
            self.result = rt.install(self.runtime, log=lambda line: QgsMessageLog.logMessage(line, "fotogeo"),
                                     progress=progress)
        except Exception as e:  # noqa: BLE001 - shown to the user in finished()
            self.error = str(e)
            return False
        return True

    def finished(self, ok):
        runner.forget_status()
        self.on_done(ok, self.error, self.result)


class RuntimeMenu:
    """The two actions in the menu *fotogeo* (Plugins toolbar menu bar)."""

    def __init__(self, iface, provider):
        self.iface, self.provider, self.task = iface, provider, None
        self.install = QAction("Install / repair runtime", iface.mainWindow())
        self.install.triggered.connect(self.start_install)
        self.status = QAction("Runtime status", iface.mainWindow())
        self.status.triggered.connect(self.show_status)
        for action in (self.install, self.status):
            iface.addPluginToMenu(MENU, action)
        ok, why = runner.runtime_status(refresh=True)
        if not ok:
            iface.messageBar().pushMessage("fotogeo", why, Qgis.Warning, 0)

    def remove(self):
        for action in (self.install, self.status):
            self.iface.removePluginMenu(MENU, action)

    def start_install(self):
        if self.task is not None:
            return
        self.task = InstallTask(self.install_done)
        QgsApplication.taskManager().addTask(self.task)
        self.iface.messageBar().pushMessage("fotogeo", f"installing the runtime in {self.task.runtime.folder} "
                                            f"(progress in the task manager, bottom right)", Qgis.Info, 10)

    def install_done(self, ok, error, result):
        self.task = None
        if self.provider is not None:
            self.provider.refreshAlgorithms()
        if ok:
            self.iface.messageBar().pushMessage("fotogeo", "runtime ready: " + rt.describe_libraries(result),
                                                Qgis.Success, 10)
        else:
            QMessageBox.warning(self.iface.mainWindow(), "fotogeo", f"The runtime could not be installed:\n\n{error}")

    def show_status(self):
        QMessageBox.information(self.iface.mainWindow(), "fotogeo runtime", status_report())
