"""Point tables: CSV files or vector layers (any OGR format) in, CSV or GeoPackage out.

Every table fotogeo reads (GCPs, points to transfer, approximate target positions, tie-point
layers) goes through :func:`read_table`: a ``.csv`` file becomes a pandas ``DataFrame``,
anything else is read by GDAL (GeoPackage, Shapefile, GeoJSON, …) into a geopandas
``GeoDataFrame`` carrying the point geometries and the layer's CRS. Column (field) names are
matched case-insensitively. Failures are one :class:`fotogeo.errors.VectorError` naming the
file and what is wrong.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VectorError, one_line


def read_table(path, what: str, layer: str | None = None):
    """Read the point table ``path``: CSV → ``DataFrame``, any vector format → ``GeoDataFrame``.

    ``what`` names the table in error messages (e.g. ``"GCP file"``); ``layer`` picks a layer
    of a multi-layer vector file (default: the first). A CSV's numbers are read correctly rounded (pandas'
    ``round_trip`` parser; its default is off by one unit in the last place on about 12 % of the numbers Python
    writes), so a table written and read back holds the same doubles. A missing or unreadable file raises
    :class:`VectorError` with the path and the reader's reason.
    """
    p = Path(path)
    if not p.exists():
        raise VectorError(f"{what} {str(p)!r} does not exist")
    csv = p.suffix.lower() == ".csv"
    try:
        if csv:
            import pandas as pd
            return pd.read_csv(p, float_precision="round_trip", **csv_dialect(p))
        import geopandas as gpd

        from .clocale import c_case_rules, import_pyogrio
        import_pyogrio()
        with c_case_rules():
            return gpd.read_file(p, layer=layer, engine="pyogrio") if layer else gpd.read_file(p, engine="pyogrio")
    except Exception as e:  # noqa: BLE001 - any reader failure becomes one clear error
        kind = "CSV" if csv else "a vector layer" + (f" (layer {layer!r})" if layer else "")
        raise VectorError(one_line(f"{what} {str(p)!r} cannot be read as {kind}: {e}")) from None


def csv_dialect(path) -> dict:
    r"""``pandas.read_csv`` keywords for the CSV ``path``: the separator among ``,`` ``;`` and tab that splits the
    header line into the most fields, and a decimal comma when the separator is not a comma and the first data
    lines write numbers as ``12,5`` (a spreadsheet's CSV in a locale with decimal commas). A ``;`` table with
    decimal commas was refused as "needs map coordinate columns x and y", its one column being ``id;x;y;z;col;row``.

    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> (d / "a.csv").write_text("id;x;y\ng1;259692,922;6272527,29\n") and csv_dialect(d / "a.csv")
    {'sep': ';', 'decimal': ','}
    >>> (d / "b.csv").write_text("id,x,y\ng1,259692.922,6272527.29\n") and csv_dialect(d / "b.csv")
    {}
    """
    import re
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        lines = [f.readline() for _ in range(6)]
    header = lines[0]
    sep = max((",", ";", "\t"), key=lambda c: (header.count(c), c == ","))
    if sep == "," or not header.count(sep):
        return {}
    body = "".join(lines[1:])
    return {"sep": sep, "decimal": ","} if re.search(r"\d,\d", body) else {"sep": sep}


def is_layer(table) -> bool:
    """True when ``table`` (from :func:`read_table`) carries point geometries (a vector layer)."""
    import geopandas as gpd
    return isinstance(table, gpd.GeoDataFrame)


def find_column(table, name: str | None) -> str | None:
    """The column of ``table`` called ``name`` in any letter case, or None."""
    if not name:
        return None
    return {str(c).lower(): c for c in table.columns}.get(name.lower())


def require_columns(table, names, what: str, hint: str = "") -> list:
    """The columns of ``table`` called ``names`` (any letter case), or :class:`VectorError`
    listing the missing ones, the table's own fields and ``hint`` (how to fix it)."""
    found = [find_column(table, n) for n in names]
    missing = [n for n, c in zip(names, found) if c is None]
    if missing:
        fields = ", ".join(str(c) for c in table.columns if c != "geometry") or "none"
        raise VectorError(f"{what} lacks the field(s) {', '.join(missing)}{f' ({hint})' if hint else ''}; "
                          f"its fields are: {fields}")
    return found


def describe_rows(table, rows, id_field: str | None = "id", limit: int = 10) -> str:
    """``rows`` (0-based positions in ``table``) named for a message: by the ``id_field`` values when
    the table has that field, else as data rows (1-based; for a CSV, line = row + 1 after the header)."""
    rows = list(rows)
    idf = find_column(table, id_field)
    if idf is not None:
        names = [repr(str(v))[:40] for v in table[idf].iloc[rows[:limit]]]
        text = f"point{'s' if len(rows) > 1 else ''} {', '.join(names)}"
    else:
        unit = "feature" if is_layer(table) else "row"
        text = f"{unit}{'s' if len(rows) > 1 else ''} {', '.join(str(r + 1) for r in rows[:limit])}"
    return text + (f" and {len(rows) - limit} more" if len(rows) > limit else "")


def numeric_columns(table, names, what: str, hint: str = "", *, finite: bool = False,
                    id_field: str | None = "id") -> np.ndarray:
    """The columns ``names`` of ``table`` as a float64 (N, len(names)) array (see :func:`require_columns`).

    A value that is not a number (text in a numeric field) raises :class:`VectorError` naming the
    field, the rows (by ``id_field`` when the table has it) and the value. Empty cells become NaN,
    unless ``finite``: then empty, NaN and infinite values are refused the same way.
    """
    import pandas as pd
    columns = require_columns(table, names, what, hint)
    out = np.empty((len(table), len(columns)), dtype=np.float64)
    for j, c in enumerate(columns):
        raw = table[c]
        values = pd.to_numeric(raw, errors="coerce") if raw.dtype.kind not in "iufb" else raw
        text = (values.isna() & raw.notna()).to_numpy()
        if text.any():
            rows = np.flatnonzero(text)
            raise VectorError(one_line(f"{what}: field {str(c)!r} must hold numbers; {describe_rows(table, rows, id_field)} "
                                       f"hold{'s' if len(rows) == 1 else ''} {str(raw.iloc[rows[0]])!r}; fix the value"
                                       f"{'s' if len(rows) > 1 else ''} or name the right field"))
        out[:, j] = np.asarray(values, dtype=np.float64)
        if finite and not np.isfinite(out[:, j]).all():
            rows = np.flatnonzero(~np.isfinite(out[:, j]))
            raise VectorError(one_line(f"{what}: {describe_rows(table, rows, id_field)} "
                                       f"{'have' if len(rows) > 1 else 'has'} no valid {str(c)!r} (empty, NaN or "
                                       f"infinite); fill in the value{'s' if len(rows) > 1 else ''} or remove "
                                       f"{'those rows' if len(rows) > 1 else 'that row'}"))
    return out


def write_table(path, columns: dict, crs=None, xy=None) -> None:
    """Write ``columns`` (name → values) as CSV (by the ``.csv`` suffix) or as the GeoPackage
    layer ``points``, whose point geometries are ``xy`` (N, 2) or else the ``col``, ``row`` columns."""
    if str(path).lower().endswith(".csv"):
        import pandas as pd
        pd.DataFrame(columns).to_csv(path, index=False)
    else:
        import shapely

        from .vector import write_layers
        geom = shapely.points(xy if xy is not None else np.column_stack([columns["col"], columns["row"]]))
        write_layers(path, {"points": {**columns, "geometry": geom}}, crs)


def duplicate_ids(ids) -> dict[str, list[int]]:
    """``{id: [rows]}`` of the ids given more than once (rows 1-based, in input order; ids in order of first
    appearance) — the one test behind every refusal of a point or GCP table naming one id twice."""
    seen: dict[str, list[int]] = {}
    for k, i in enumerate(ids):
        seen.setdefault(str(i), []).append(k + 1)
    return {i: rows for i, rows in seen.items() if len(rows) > 1}
