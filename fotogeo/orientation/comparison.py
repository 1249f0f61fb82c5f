"""Model comparison over control/check sets (Öztürk, Karşlı & Dihkan, Table 1), array layer.

A *set* splits the GCPs into control points (fit the model) and check points (measure it):

* **random sets** — for a count item ``N`` (``N`` control points, every other point a check
  point) or ``N/M`` (a pool of ``N + M`` points spread over the image, ``N`` of them control,
  the rest of the pool check points; the paper's ``20/20`` on its 40-point pool) and a spread
  (``homogeneous``: stratified over the image; ``heterogeneous``: clustered around two random
  centres), drawn anew in each of ``trials`` seeded trials. ``N`` equal to the number of points
  (or ``N/0`` on all of them) is the all-control row (the paper's 40/0, 60/0): one fit, no check
  points;
* **fixed sets** — role columns of the GCP file (``control`` / ``check``; ``blunder`` left
  out), one set each, plus the all-control row.

Counts per model (:func:`parse_counts`): ``"40,20,15"`` for every model, ``"dlt=6,10,15"`` for
a model or for every model whose name starts with the key (``rfm=...`` serves ``rfm``,
``rfm-common``, ``rfm-i2g``, ...; the longest key wins). Without counts, the paper's design by
model family (:data:`FAMILY_COUNTS`): 40, 20, 15, 10, 6 control points for the classical models
and 60, 55, 50, 45, 40 for the RFMs.

Per row (model × set): ``mx``, ``my`` — RMS of the x (col) and y (row) errors — at control and
check points (the median over the trials), ``check_rms_xy``, and the smallest, median and largest
check-point error length pooled over the trials (pixels; ``*_mm`` too with a scan pixel size).
Ground → image models are evaluated as fitted; image → ground models (``*-i2g``, fitted
``(col, row, Z) → (X, Y)``) through their inverse at each point's height, so every error is an
image error in pixels.
"""
from __future__ import annotations

import re

import numpy as np

from ..errors import FotogeoError, InputError, ModelError
from ..models import get_model
from ..models.robust import spread_split
from ..models.stats import residual_stats
from .adjustment import fit_orientation

#: the paper's counts by model-name prefix ("" = every other model): classical models on 40
#: points, RFMs on 60
FAMILY_COUNTS = {"": ((40, None), (20, None), (15, None), (10, None), (6, None)),
                 "rfm": ((60, None), (55, None), (50, None), (45, None), (40, None))}
STAT_KEYS = ("control_rms_x", "control_rms_y", "control_max", "check_rms_x", "check_rms_y", "check_rms_xy",
             "check_min", "check_median", "check_max")


def parse_counts(spec) -> dict:
    """``{model-name prefix: ((N, M or None), ...)}`` from a counts spec (module docstring).

    ``spec``: None (the paper's family counts), integers, or text items ``"[key=]N[/M],..."``
    (several in one text separated by ``;``). Keyed items are added to the family counts; an
    item without key replaces them all.

    >>> parse_counts("dlt=6,10/30; rfm=60")["dlt"], parse_counts([40, 10])[""]
    (((6, None), (10, 30)), [(40, None), (10, None)])
    """
    if spec is None:
        return dict(FAMILY_COUNTS)
    if isinstance(spec, (int, np.integer)):
        spec = [spec]
    items = list(spec.split(";") if isinstance(spec, str) else spec)
    if items and all(isinstance(i, (int, np.integer)) for i in items):
        return {"": [(_positive(i, spec), None) for i in items]}
    out = {}
    for item in (p for i in items for p in str(i).split(";") if p.strip()):
        key, _, values = item.rpartition("=")
        out[key.strip()] = tuple(_count_item(v, item) for v in values.split(",") if v.strip())
        if not out[key.strip()]:
            raise InputError(f"counts {item!r}: no control-point count after '='", option="counts")
    if not out:
        raise InputError("counts: give at least one control-point count, e.g. 40,20,10", option="counts")
    return out if "" in out else {**FAMILY_COUNTS, **out}


def _count_item(text: str, item: str):
    m = re.fullmatch(r"\s*(\d+)\s*(?:/\s*(\d+)\s*)?", text)
    if not m:
        raise InputError(f"counts {item!r}: {text.strip()!r} is not N or N/M (control/check points), e.g. 20 or 20/20",
                         option="counts")
    return _positive(int(m.group(1)), item), None if m.group(2) is None else int(m.group(2))


def _positive(n, spec):
    if int(n) < 1:
        raise InputError(f"counts {spec!r}: a control-point count must be at least 1; got {n}", option="counts")
    return int(n)


def counts_for(model: str, table: dict):
    """The count items of ``model``: those of the longest key of ``table`` its name starts with."""
    key = max((k for k in table if model.startswith(k)), key=len, default=None)
    return () if key is None else table[key]


def select_controls(pixel, n_control: int, spread: str, rng) -> np.ndarray:
    """Mask of ``n_control`` control points: ``homogeneous`` (stratified over the image area) or
    ``heterogeneous`` (clustered: the points nearest to two random centres)."""
    n = len(pixel)
    rng = np.random.default_rng(rng)
    if n_control >= n:
        return np.ones(n, bool)
    if spread == "homogeneous":
        return spread_split(pixel, n_control / n, rng, cells=max(2, int(np.sqrt(n_control))))
    if spread in ("heterogeneous", "clustered"):
        mask = np.zeros(n, bool)
        centres = pixel[rng.choice(n, 2, replace=False)]
        for k, c in enumerate(centres):
            want = n_control // 2 + (k == 0) * (n_control % 2)
            order = np.argsort(np.hypot(*(pixel - c).T))
            mask[[i for i in order if not mask[i]][:want]] = True
        return mask
    raise ModelError(f"spread {spread!r} unknown; use 'homogeneous' or 'heterogeneous'")


def draw_set(pixel, n_control: int, n_check, spread: str, rng) -> np.ndarray:
    """Roles ``(N,)`` of one random set: ``control``, ``check`` or ``unused`` (outside an ``N/M`` pool).

    The pool of ``n_control + n_check`` points is spread over the image (stratified); the
    control points are chosen in it by ``spread`` (:func:`select_controls`)."""
    rng = np.random.default_rng(rng)
    n = len(pixel)
    pool = np.arange(n)
    if n_check is not None and n_control + n_check < n:
        pool = np.flatnonzero(spread_split(pixel, (n_control + n_check) / n, rng,
                                           cells=max(2, int(np.sqrt(n_control + n_check) / 2))))
    role = np.full(n, "unused", dtype=object)
    role[pool] = "check"
    role[pool[select_controls(pixel[pool], n_control, spread, rng)]] = "control"
    return role


def fit_set(name: str, ground, pixel, role, *, camera=None):
    """Image errors ``(N, 2)`` (pixels, model − measured) of every point under model ``name`` fitted on
    the points whose ``role`` is ``control``, and the fit's warnings (module docstring: image → ground
    models through their inverse, :func:`~fotogeo.orientation.adjustment.image_residuals`)."""
    control = np.asarray(role) == "control"
    f = fit_orientation(name, ground, pixel, np.where(control, "control", "check"),
                        np.arange(len(pixel)).astype(str), snooping=False, camera=camera)
    return f.residual, f.warnings


def set_row(errors: list, roles: list) -> dict:
    """Row statistics of one model × set from the errors and roles of each trial (pixels)."""
    acc = {k: [] for k in ("control_rms_x", "control_rms_y", "check_rms_x", "check_rms_y", "check_rms_xy")}
    lengths = {"control": [], "check": []}
    for e, r in zip(errors, roles):
        for which in ("control", "check"):
            ew = e[np.asarray(r) == which]
            if len(ew):
                s = residual_stats(ew)
                acc[f"{which}_rms_x"].append(s["rms_x"])
                acc[f"{which}_rms_y"].append(s["rms_y"])
                if which == "check":
                    acc["check_rms_xy"].append(s["rms_xy"])
                lengths[which].append(np.hypot(*ew.T))
    row = {k: float(np.median(v)) if v else None for k, v in acc.items()}
    cl, ch = (np.concatenate(lengths[w]) if lengths[w] else np.zeros(0) for w in ("control", "check"))
    row["control_max"] = float(cl.max()) if cl.size else None
    for k, f in (("check_min", np.min), ("check_median", np.median), ("check_max", np.max)):
        row[k] = float(f(ch)) if ch.size else None
    return row


def _short(warning: str) -> str:
    """The gist of a fit warning: without its ``model 'name':`` head, up to the first ``;`` or ``(``."""
    text = re.sub(r"^model '[^']*':\s*", "", warning)
    return re.split(r"[;(]", text)[0].strip()[:70]


def with_units(row: dict, scale_mm: float | None) -> dict:
    """``row``'s statistics as ``*_px`` and, with ``scale_mm`` (mm per pixel), ``*_mm``."""
    out = {k: v for k, v in row.items() if k not in STAT_KEYS}
    for k in STAT_KEYS:
        v = row.get(k)
        out[f"{k}_px"] = v
        if scale_mm:
            out[f"{k}_mm"] = None if v is None else v * scale_mm
    return out


def _job_rows(name, ground, pixel, sets, camera, scale_mm):
    """One row per set of one model: ``sets`` is a list of ``(spread, label, [roles per trial])``."""
    cls = get_model(name)
    rows = []
    for spread, label, trial_roles in sets:
        r0 = np.asarray(trial_roles[0])
        row = {"model": name, "spread": spread, "set": label, "n_control": int((r0 == "control").sum()),
               "n_check": int((r0 == "check").sum())}
        if row["n_control"] < cls.min_points:
            rows.append({**row, "note": f"needs at least {cls.min_points} control points"})
            continue
        errors, roles, notes = [], [], set()
        for roles_t in trial_roles:
            try:
                e, warns = fit_set(name, ground, pixel, roles_t, camera=camera)
            except FotogeoError as exc:
                notes.add(str(exc))
                continue
            errors.append(e)
            roles.append(roles_t)
            notes.update(_short(w) for w in warns)
        if errors:
            row.update(set_row(errors, roles))
            row["vectors"] = {"pixel": pixel, "error": errors[0], "role": np.asarray(roles[0]).astype(str)}
        row["trials"] = len(errors)
        if notes:
            row["note"] = "; ".join(sorted(notes))[:200]
        rows.append(with_units(row, scale_mm))
    return rows


def layout_of(label: str) -> str:
    """The layout of a fixed set named ``label``: the label without a trailing ``_<digits>``
    (``homogeneous_20`` → ``homogeneous``), so that sets of one layout share a table."""
    return re.sub(r"[_-]\d+$", "", label) or label


def random_sets(name, pixel, table, spreads, trials, seed, explicit: bool):
    """``(spread, label, [roles per trial])`` of model ``name``'s counts (module docstring) and notes
    for counts the points cannot serve (only for ``explicit`` counts; the defaults are dropped)."""
    n, sets, notes = len(pixel), [], []
    for n_control, n_check in counts_for(name, table):
        need = n_control + (n_check or 0)
        label = f"{n_control}/{n_check}" if n_check is not None else str(n_control)
        if need > n:
            if explicit:
                notes.append((label, f"{label} needs {need} points; the file has {n}"))
            continue
        for k, spread in enumerate(spreads):
            everything = n_control == n
            trial_roles = [draw_set(pixel, n_control, n_check, spread, [seed, n_control, n_check or 0, k, t])
                           for t in range(1 if everything else trials)]
            sets.append((spread, label, trial_roles))
    return sets, notes


def fixed_sets_of(role_sets: dict, n: int):
    """``(layout, label, [roles])`` of the GCP file's role columns, each layout with an all-control set."""
    sets, layouts = [], []
    for label, roles in role_sets.items():
        roles = np.where(np.asarray(roles) == "blunder", "unused", np.asarray(roles).astype(object))
        sets.append((layout_of(label), label, [roles]))
        if layout_of(label) not in layouts:
            layouts.append(layout_of(label))
            used = np.asarray(role_sets[label]) != "blunder"
            sets.append((layout_of(label), "all", [np.where(used, "control", "unused").astype(object)]))
    return sets


def compare(models, ground, pixel, *, counts=None, spreads=("homogeneous", "heterogeneous"), trials: int = 5,
            seed: int = 0, camera=None, role_sets: dict | None = None, scale_mm: float | None = None,
            progress=None) -> list[dict]:
    """Table-1-style comparison (module docstring): one row per model × set, in model order.

    ``role_sets`` (``{label: roles (N,)}``) gives fixed sets and then ``counts``, ``spreads``
    and ``trials`` are not used; otherwise random sets by ``counts`` (:func:`parse_counts`).
    Every model meets the same sets (seeded per count, spread and trial). Rows hold the
    statistics in pixels (``*_px``) and with ``scale_mm`` (mm per scan pixel) in mm (``*_mm``),
    ``trials`` and a ``note`` (why a model could not be fitted, its warnings); ``vectors``
    holds the first trial's errors for plots.
    """
    from ..progress import as_progress
    prog = as_progress(progress)
    ground, pixel = np.asarray(ground, float), np.asarray(pixel, float)
    table = None if role_sets else parse_counts(counts)
    rows = []
    for j, name in enumerate(models):
        get_model(name)
        if role_sets:
            sets, notes = fixed_sets_of(role_sets, len(pixel)), []
        else:
            sets, notes = random_sets(name, pixel, table, spreads, trials, seed, counts is not None)
        rows += [{"model": name, "set": label, "note": text} for label, text in notes]
        if not sets and not notes:
            rows.append({"model": name, "note": f"no count for {name!r} fits the file's {len(pixel)} points"})
        rows += _job_rows(name, ground, pixel, sets, camera, scale_mm)
        prog((j + 1) / len(models), f"{name} compared")
    return rows
