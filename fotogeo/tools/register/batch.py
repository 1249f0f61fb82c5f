"""Batch co-registration on Dask: many target scenes registered to one reference, one task per scene.

``register_batch(reference, targets, outdir)`` registers every target with
:func:`fotogeo.tools.register.tool.register` (with ``dem``: terrain-aware) into
``OUTDIR/<scene>.tif`` / ``.gpkg`` / ``.json`` and keeps a manifest
(:mod:`fotogeo.io.manifest`: ``OUTDIR/manifest.csv`` and the GeoPackage layer ``scenes`` of
``OUTDIR/manifest.gpkg``, one row per scene with its footprint, status, inliers, check RMSE,
time and error message), rewritten atomically as the results arrive.

Where it runs: on a ``dask.distributed.Client`` given as ``client``; on a running cluster
whose scheduler address is ``scheduler`` (``tcp://host:8786``; every worker must see the same
paths — a shared file system — and import fotogeo); otherwise on a local cluster of
``workers`` processes (default one per CPU), one thread each. Each task (:func:`register_scene`,
a module-level function, so any worker can import it) opens its own files and runs with GDAL,
OpenCV, BLAS and fotogeo's resampling pinned to one thread: the parallelism is across
scenes, and N scenes on N cores do not oversubscribe them.

A failing scene never stops the batch: its row says ``failed`` with the one-line message.
A worker that dies mid-scene (killed, out of memory) loses its task; the scheduler runs it
again on another worker (Dask's ``distributed.scheduler.allowed-failures`` times). With
``resume`` (the default) a scene whose manifest row says ``ok`` and whose outputs exist
(raster, GeoPackage, report; with ``local`` its displacement field ``<scene>_field.tif`` too)
is skipped — so is one whose outputs and report exist though the manifest missed it (a crash
between the two); anything else is registered again, its outputs replaced.
"""
from __future__ import annotations

import collections
import glob
import os
import socket
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from ...errors import Cancelled, FotogeoError, InputError, OutputError, one_line
from ...io import manifest as mf
from ...options import RegisterOptions
from ...progress import as_progress
from ..common.boundary import tool
from ..common.dask_cluster import SINGLE_THREAD_ENV, connect, distributed_module, missing_dask, pin_threads  # noqa: F401

MANIFEST_CSV, MANIFEST_GPKG = "manifest.csv", "manifest.gpkg"
MISSING_DASK = missing_dask("register-batch")


@dataclass(frozen=True)
class BatchResult:
    """What :func:`register_batch` did: the manifest paths, its rows and the counts."""

    manifest_csv: Path
    manifest_gpkg: Path
    rows: list = field(repr=False)
    ok: int
    failed: int
    skipped: int

    @property
    def failures(self) -> dict:
        """``{scene: error message}`` of the failed scenes."""
        return {r["scene"]: r["error"] for r in self.rows if r["status"] == "failed"}


def expand_targets(targets) -> list[Path]:
    """The target paths: a list of paths and/or globs, or one path, glob or list file (one path
    per line, ``#`` comments, relative to the list file's folder); duplicates removed, order kept."""
    items = [targets] if isinstance(targets, (str, os.PathLike)) else list(targets)
    out = []
    for item in items:
        text = str(item)
        if glob.has_magic(text):
            found = sorted(glob.glob(text))
            if not found:
                raise InputError(f"no file matches the targets pattern {text!r}")
            out += [Path(p) for p in found]
        elif Path(text).suffix.lower() in (".txt", ".lst", ".list") and Path(text).is_file():
            base = Path(text).parent
            for line in Path(text).read_text(encoding="utf-8").splitlines():
                line = line.strip()
                if line and not line.startswith("#"):
                    out.append(Path(line) if Path(line).is_absolute() else base / line)
        else:
            out.append(Path(text))
    unique = list(dict.fromkeys(p.resolve() for p in out))
    if not unique:
        raise InputError("no target scenes given; give paths, a glob such as 'scenes/*.tif' or a list file")
    missing = [str(p) for p in unique if not p.is_file()]
    if missing:
        raise InputError(f"{len(missing)} target scene(s) do not exist, e.g. {missing[0]!r}; check the paths")
    return unique


def scene_names(targets: list[Path]) -> list[str]:
    """One output stem per target: its file stem, with a number added where two stems collide.

    >>> scene_names([Path("a/x.tif"), Path("b/x.tif"), Path("c/y.tif")])
    ['x', 'x_2', 'y']
    """
    seen: dict = {}
    names = []
    for p in targets:
        n = seen[p.stem] = seen.get(p.stem, 0) + 1
        names.append(p.stem if n == 1 else f"{p.stem}_{n}")
    return names


def scene_outputs(outdir: Path, scene: str, local: bool = False) -> dict:
    """A scene's output paths; with ``local`` also its displacement field (``<scene>_field.tif``)."""
    outs = {"output": outdir / f"{scene}.tif", "vectors": outdir / f"{scene}.gpkg", "report": outdir / f"{scene}.json"}
    return {**outs, "field": outdir / f"{scene}_field.tif"} if local else outs


def _footprint_wkt(geo, target) -> str | None:
    """The scene's footprint on the map as a lon/lat polygon WKT (None if the model gives none)."""
    import numpy as np
    import shapely
    from ...crs import to_lonlat
    from ...io.raster import open_raster
    info = open_raster(target, "target")
    XY = geo.footprint(info.width, info.height, 9)
    XY = XY[np.isfinite(XY).all(axis=1)]
    if len(XY) < 3:
        return None
    return shapely.Polygon(to_lonlat(geo.crs, XY)).wkt


def scene_row(scene: str, target, report: dict, output, footprint_wkt=None) -> dict:
    """The manifest row of a registered scene, from its report."""
    check, control = report.get("check", {}), report.get("control", {})
    fitted = report.get("model") or {}  # Model.to_dict(): its name under "model" (2-D registrations)
    model = report.get("terrain", {}).get("chosen") or fitted.get("name") or fitted.get("model")
    return {"scene": scene, "target": str(target), "status": "ok", "inliers": report.get("inliers"),
            "check_n": check.get("n"), "check_rmse_m": check.get("rmse_m"), "check_rmse_px": check.get("rmse_px"),
            "control_rmse_m": control.get("rmse_m"), "model": model, "output_crs": report.get("output_crs"),
            "output": str(output), "error": None, "footprint_wkt": footprint_wkt}


def register_scene(reference: str, target: str, scene: str, outdir: str, dem=None, options: dict | None = None) -> dict:
    """The Dask task: register one scene into ``outdir`` (threads pinned); its manifest row.

    Never raises for a failed scene: the row says ``failed`` with the one-line message.
    """
    from .tool import register
    pin_threads()
    t0 = time.perf_counter()
    outs = scene_outputs(Path(outdir), scene, bool((options or {}).get("local")))
    try:
        r = register(reference, target, outs["output"], vectors=outs["vectors"], report=outs["report"],
                     field=outs.get("field"), overwrite=True, dem=dem, **(options or {}))
        try:
            wkt = _footprint_wkt(r.georeference, target)
        except Exception:  # noqa: BLE001 - the footprint is informative; the scene itself succeeded
            wkt = None
        row = scene_row(scene, target, r.report, outs["output"], wkt)
    except Exception as e:  # noqa: BLE001 - isolate every failure in the scene's row
        message = str(e) if isinstance(e, FotogeoError) else f"{type(e).__name__}: {e}"
        row = {"scene": scene, "target": str(target), "status": "failed", "error": one_line(message)}
    row["seconds"] = round(time.perf_counter() - t0, 3)
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def _done_before(row: dict | None, scene: str, target: Path, outdir: Path, local: bool) -> dict | None:
    """The row of a scene a previous run finished (manifest ``ok`` + outputs, or outputs + report;
    with ``local`` its field too: a scene registered without it is registered again)."""
    import json
    outs = scene_outputs(outdir, scene, local)
    if not all(p.is_file() for p in outs.values()):
        return None
    if row and row.get("status") == "ok" and row.get("target") == str(target):
        return row
    try:
        report = json.loads(outs["report"].read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if Path(report.get("target", "")).resolve() != target:
        return None
    return {**scene_row(scene, target, report, outs["output"]), "seconds": None, "worker": None}


class _Manifest:
    """The batch's rows, written (CSV each update, GeoPackage at most every ``every_s``) atomically."""

    def __init__(self, outdir: Path, rows: list[dict], every_s: float = 2.0):
        self.csv, self.gpkg, self.rows, self.every_s = outdir / MANIFEST_CSV, outdir / MANIFEST_GPKG, rows, every_s
        self._index = {r["scene"]: i for i, r in enumerate(rows)}
        self._last_gpkg = 0.0

    def update(self, row: dict | None = None, final: bool = False):
        if row is not None:
            self.rows[self._index[row["scene"]]] = row
        mf.write_csv(self.csv, self.rows)
        if final or time.monotonic() - self._last_gpkg >= self.every_s:
            mf.write_gpkg(self.gpkg, self.rows)
            self._last_gpkg = time.monotonic()


@tool("REGISTER_BATCH", "REGISTER", "REGISTER_TERRAIN", rasters={"reference": "reference_nodata", "dem": None},
      outputs=("outdir",))
def register_batch(reference, targets, outdir, *, client=None, scheduler=None, workers=None, resume=True, dem=None,
                   progress=None, **register_options) -> BatchResult:
    """Register every scene of ``targets`` to ``reference`` on Dask; write ``outdir`` and its manifest.

    ``targets``: paths, globs or a list file (:func:`expand_targets`). ``register_options``: the
    options of :func:`fotogeo.tools.register.tool.register` (checked before anything runs).
    ``progress(fraction, message) -> bool`` counts scenes; False cancels the scenes not yet
    finished (those finished keep their outputs and rows, so the batch can be resumed).
    """
    from ...options import REGISTER
    RegisterOptions(**{k: v for k, v in register_options.items() if k in REGISTER}).validate()
    if isinstance(register_options.get("camera"), (str, os.PathLike)):
        register_options["camera"] = str(Path(register_options["camera"]).resolve())
    reference = Path(reference).resolve()
    if not reference.is_file():
        raise InputError(f"reference {str(reference)!r} does not exist")
    dem = str(Path(dem).resolve()) if isinstance(dem, (str, os.PathLike)) else dem
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise OutputError(f"outdir {str(outdir)!r} is a file; give a folder")
    outdir.mkdir(parents=True, exist_ok=True)
    outdir = outdir.resolve()
    paths = expand_targets(targets)
    names = scene_names(paths)
    inputs = {*paths, reference, *([Path(dem)] if isinstance(dem, str) else [])}
    local = bool(register_options.get("local"))
    every = [p for n in names for p in scene_outputs(outdir, n, local).values()]
    twice = [str(p) for p, k in collections.Counter(every).items() if k > 1]
    if twice:
        raise InputError(f"two scenes would write {twice[0]!r} (a scene's field is <scene>_field.tif); rename "
                         f"the target that ends in _field")
    clash = [str(p) for p in every if p in inputs]
    if clash:
        raise InputError(f"the output {clash[0]!r} would replace an input; choose an outdir other than the "
                         f"targets' folder")
    previous = {r["scene"]: r for r in mf.read_csv(outdir / MANIFEST_CSV)} if resume else {}
    rows, todo = [], []
    for scene, target in zip(names, paths):
        done = _done_before(previous.get(scene), scene, target, outdir, local) if resume else None
        rows.append(done or {"scene": scene, "target": str(target), "status": "pending"})
        if done is None:
            todo.append((scene, target))
    book = _Manifest(outdir, rows)
    book.update(final=True)
    prog = as_progress(progress)
    skipped = len(paths) - len(todo)
    if todo:
        _run(book, prog, todo, str(reference), str(outdir), dem, register_options, client, scheduler, workers,
             len(paths), skipped)
    book.update(final=True)
    prog(1.0, f"{len(paths)} scenes done")
    ok = sum(r["status"] == "ok" for r in rows)
    return BatchResult(book.csv, book.gpkg, rows, ok - skipped, sum(r["status"] == "failed" for r in rows), skipped)


def _run(book, prog, todo, reference, outdir, dem, options, client, scheduler, workers, total, skipped):
    """Submit one task per scene and record the rows as they complete (any completion order)."""
    distributed = distributed_module()
    c, close = connect(client, scheduler, workers)
    batch_id = uuid.uuid4().hex[:8]
    futures = {}
    try:
        for scene, target in todo:
            fut = c.submit(register_scene, reference, str(target), scene, outdir, dem, dict(options),
                           key=f"fotogeo-register-{scene}-{batch_id}", pure=False)
            futures[fut] = (scene, target)
        done = skipped
        failed = 0
        prog(done / total, f"{done}/{total} scenes ({skipped} done before)")
        for fut in distributed.as_completed(list(futures)):
            scene, target = futures[fut]
            try:
                row = fut.result()
            except Exception as e:  # noqa: BLE001 - a task Dask gave up on (e.g. KilledWorker)
                row = {"scene": scene, "target": str(target), "status": "failed",
                       "error": one_line(f"{type(e).__name__}: {e}")}
            done += 1
            failed += row["status"] == "failed"
            book.update(row)
            prog(done / total, f"{done}/{total} scenes, {failed} failed")
    except (Cancelled, KeyboardInterrupt):
        for fut in futures:
            fut.cancel()
        book.update(final=True)
        raise
    finally:
        futures.clear()
        close()
