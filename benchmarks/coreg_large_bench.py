"""Issue 19: a 10980 x 10980 single-band scene (a Sentinel-2 tile's size) co-registered by fotogeo
and by AROSICS ``COREG_LOCAL`` in the same run: wall time, peak memory, windows, residual.

Run:  .venv/bin/python benchmarks/coreg_large_bench.py [--tool register|coreg] [--size 10980] [--threads 1]
      [--arosics ../arosics-venv/bin/python] [--arosics-timeout 3000]

The scene is built in a temporary folder (never in the shared data): the s2_pair reference
(Sentinel-2 B04, 10 m) has its valid columns mirror-tiled to ``--size``² uint16, and the target
is that scene under a known smooth warp ``E`` (constant offset + 1.5-px sinusoid of 3000 px
wavelength): target pixel ``q`` shows the reference at ``q + E(q)``. Both tools measure a
grid of 256-px windows every 100 px and write a corrected target:

- ``--tool register`` (default): ``fotogeo.register(..., local=True, local_grid_spacing=100,
  local_window=256, resampling="cubic")`` as a user calls it (= ``fotogeo register REF TGT OUT
  --local --local-grid-spacing 100 --local-window 256 --resampling cubic``; cubic like AROSICS'
  output, the default nearest neighbour alone leaves ~0.25 px of rounding in a window's shift):
  feature matching, the global model, the local field, one resampling. Its residual against the truth is dense: at every node of the written
  field, the target pixel the output pixel takes (the model through the field) minus the one
  the known warp says it should take;
- ``--tool coreg``: ``fotogeo coreg`` on the target's own grid (the field against the truth).

Each runs in a fresh subprocess on ``--threads`` cores (:func:`coreg_bench.run`: wall time, CPU
time, peak resident memory of the process tree sampled every 0.2 s); AROSICS is stopped after
``--arosics-timeout`` s (its time and memory up to then are lower bounds). The corrected outputs are then
measured the same way for both tools: fotogeo's window matcher (grey values, one pass, no
field) on a 500-px grid against the reference — the radiometry is the reference's, so any
residual shift is an error. Writes ``benchmarks/results/coreg_bench.json``
(``threads_N`` → ``large`` for coreg, ``large_register`` for register).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]
import coreg_bench as cb  # noqa: E402
import coreg_scenes as cs  # noqa: E402

#: the known warp of the target (see the module docstring)
WARP = {"amplitude": 1.5, "wavelength": 3000.0, "offset": (0.4, -0.3)}
GRID, WINDOW = 100, 256
#: field nodes this far from the edges are left out of the residual (the spline fades there)
EDGE_NODES = 8

REGISTER_RUN = """
import json, sys, time, cv2
cv2.setNumThreads({threads})
sys.path[:0] = {paths!r}
from fotogeo.tools.register.tool import register
from coreg_large_bench import register_residual
kw = json.loads(sys.argv[1])
t = time.perf_counter()
reg = register(**kw)
t_register = time.perf_counter() - t
local = reg.report["local"]
print("RESULT " + json.dumps({{"register_s": t_register, "windows": local["windows"], "after": local.get("after"),
      "timings": reg.report["timings_s"], "field_vs_truth_px": register_residual(reg, kw["field"], kw["target"])}}))
"""


def build_large(folder: Path, size: int = 10980):
    """The ``size``² reference (s2_pair reference, its valid columns mirror-tiled) and its warped copy."""
    import rasterio
    from affine import Affine
    from fotogeo.matching.interpolation import sample
    with rasterio.open(cs.S2_PAIR / "ref_S2A_20160608T153121_T33UUU_sub.jp2") as ds:
        tile = ds.read(1)[:, 1100:]
    reps = (-(-size // tile.shape[0]), -(-size // tile.shape[1]))
    row = np.concatenate([tile if j % 2 == 0 else tile[:, ::-1] for j in range(reps[1])], axis=1)
    band = np.concatenate([row if i % 2 == 0 else row[::-1] for i in range(reps[0])], axis=0)[:size, :size]
    E = cs.sinusoid(**WARP)
    prof = dict(driver="GTiff", width=size, height=size, count=1, dtype="uint16", crs="EPSG:32633", nodata=0,
                transform=Affine(10.0, 0, 300000.0, 0, -10.0, 5900000.0), tiled=True, compress="deflate")
    ref, tgt = folder / "large_ref.tif", folder / "large_tgt.tif"
    with rasterio.open(ref, "w", **prof) as dst:
        dst.write(band, 1)
    with rasterio.open(tgt, "w", **prof) as dst:
        for r0 in range(0, size, 512):
            h = min(512, size - r0)
            y, x = np.mgrid[r0:r0 + h, 0:size] + 0.5
            ex, ey = E(x, y)
            lo, hi = max(r0 - 8, 0), min(r0 + h + 8, size)
            v, _ = sample(band[lo:hi].astype(np.float64), x + ex - 0.5, y + ey - 0.5 - lo, "bicubic")
            dst.write(np.clip(np.round(np.nan_to_num(v)), 0, 65535).astype(np.uint16), 1,
                      window=rasterio.windows.Window(0, r0, size, h))
    return ref, tgt, E


def _stats(err: np.ndarray) -> dict:
    return {"n": int(err.size), "rms": float(np.sqrt((err ** 2).mean())), "ce90": float(np.percentile(err, 90)),
            "max": float(err.max())}


def register_residual(reg, field_path, target) -> dict:
    """Dense error (target px) of a ``register --local`` result against the known warp: at each inner
    node ``p`` of the written field (output pixels), the target pixel the output takes,
    ``model⁻¹(p + D(p))``, minus the true one, ``r + D_E(r)`` with ``r`` the target pixel of the
    map point of ``p`` (reference and target share one grid) and ``D_E`` the inverse of the warp."""
    import rasterio
    from fotogeo.pixels import map_to_pixel, pixel_to_map
    with rasterio.open(field_path) as ds:
        D, node_t = ds.read().astype(np.float64), ds.transform
    with rasterio.open(reg.output) as ds:
        out_t = ds.transform
    with rasterio.open(target) as ds:
        tgt_t = ds.transform
    rows, cols = np.mgrid[EDGE_NODES:D.shape[1] - EDGE_NODES, EDGE_NODES:D.shape[2] - EDGE_NODES]
    XY = pixel_to_map(node_t, np.stack([cols.ravel() + 0.5, rows.ravel() + 0.5], axis=1))
    p = map_to_pixel(out_t, XY)
    d = np.stack([D[0][rows, cols].ravel(), D[1][rows, cols].ravel()], axis=1)
    taken = reg.map_to_pixel(pixel_to_map(out_t, p + d))
    r = map_to_pixel(tgt_t, XY)
    tx, ty = cs.true_field(cs.sinusoid(**WARP), r[:, 0], r[:, 1])
    return _stats(np.hypot(taken[:, 0] - (r[:, 0] + tx), taken[:, 1] - (r[:, 1] + ty)))


def coreg_residual(field_path, E) -> dict:
    """Dense error (target px) of a ``coreg`` field against the known warp at its inner nodes."""
    import rasterio
    with rasterio.open(field_path) as ds:
        D, step = ds.read().astype(np.float64), int(round(ds.transform.a / 10.0))
    y, x = (np.mgrid[0:D.shape[1], 0:D.shape[2]] + 0.5) * step
    tx, ty = cs.true_field(E, x, y)
    inner = (slice(EDGE_NODES, -EDGE_NODES),) * 2
    return _stats(np.hypot(D[0] - tx, D[1] - ty)[inner])


def fotogeo_register(ref, tgt, tmp: Path, threads: int) -> dict:
    kw = {"reference": str(ref), "target": str(tgt), "output": str(tmp / "large_fotogeo.tif"),
          "field": str(tmp / "large_field.tif"), "local": True, "local_grid_spacing": GRID, "local_window": WINDOW,
          "resampling": "cubic", "overwrite": True}
    paths = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]
    fg = cb.run(cb.PY, REGISTER_RUN.format(threads=threads, paths=paths), kw, threads)
    return {"command": f"fotogeo register REF TGT OUT --local --local-grid-spacing {GRID} --local-window {WINDOW} "
                       f"--resampling cubic",
            "wall_s": fg["wall_s"], "cpu_s": fg["cpu_s"], "peak_mb": fg["peak_mb"], "error": fg.get("error"),
            **(fg["result"] or {})}


def fotogeo_coreg(ref, tgt, tmp: Path, threads: int, E) -> dict:
    fg = cb.fotogeo(ref, tgt, tmp / "large_fotogeo.tif", GRID, WINDOW, threads, field=str(tmp / "large_field.tif"))
    row = {"command": f"fotogeo coreg REF TGT OUT --grid-spacing {GRID} --window {WINDOW}",
           "wall_s": fg["wall_s"], "cpu_s": fg["cpu_s"], "peak_mb": fg["peak_mb"], "error": fg.get("error")}
    if fg["result"]:
        row.update(windows=fg["result"]["windows"], after=fg["result"]["after"], timings=fg["result"]["timings_s"],
                   field_vs_truth_px=coreg_residual(tmp / "large_field.tif", E))
    return row


def large_case(args, tmp: Path) -> dict:
    print(f"\n== {args.size} x {args.size}, fotogeo {args.tool}, grid {GRID}, window {WINDOW}, "
          f"{args.threads} core(s); building the scene in {tmp}", flush=True)
    started = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
    t0 = time.perf_counter()
    ref, tgt, E = build_large(tmp, args.size)
    print(f"built in {time.perf_counter() - t0:.0f} s", flush=True)
    fg = (fotogeo_register(ref, tgt, tmp, args.threads) if args.tool == "register"
          else fotogeo_coreg(ref, tgt, tmp, args.threads, E))
    print(f"fotogeo: {fg['wall_s']:.0f} s (CPU {fg['cpu_s']:.0f} s), peak {fg['peak_mb']} MB, windows {fg.get('windows')}, "
          f"field vs truth {fg.get('field_vs_truth_px')} {fg.get('error') or ''}", flush=True)
    row = {"size": args.size, "grid": GRID, "window": WINDOW, "warp": WARP, "fotogeo": fg,
           "started": started}
    if args.arosics:
        aro = cb.arosics(args.arosics, ref, tgt, tmp / "large_arosics.tif", GRID, WINDOW, args.threads,
                         timeout=args.arosics_timeout)
        row["arosics"] = {**(aro["result"] or {}), "wall_s": aro["wall_s"], "cpu_s": aro["cpu_s"],
                          "peak_mb": aro["peak_mb"], "timed_out": aro["timed_out"], "error": aro.get("error")}
        if aro["timed_out"]:
            row["arosics"]["note"] = f"stopped after {args.arosics_timeout:.0f} s, before it finished"
        print(f"arosics: {aro['wall_s']:.0f} s (CPU {aro['cpu_s']:.0f} s), peak {aro['peak_mb']} MB, timed out {aro['timed_out']}, "
              f"{aro['result']}", flush=True)
    outs = {"original": tgt, "fotogeo": tmp / "large_fotogeo.tif", "arosics": tmp / "large_arosics.tif"}
    row["measured"] = cb.measure_outputs(ref, outs, 500, WINDOW, None, args.threads)
    row["measured_grid"] = f"fotogeo's matcher, 500-px grid, {WINDOW}-px windows, one pass"
    _print_table(row)
    return row


def _print_table(row):
    print(f"{'tool':8s} {'time s':>7s} {'CPU s':>7s} {'peak MB':>8s} {'valid windows':>14s}  "
          f"residual vs truth (n med rms ce90)")
    f, a = row["fotogeo"], row.get("arosics") or {}
    for name, t, n in (("fotogeo", f, (f.get("windows") or {}).get("reliable")), ("arosics", a, a.get("kept"))):
        if t:
            m = row["measured"].get(name, {}).get("fg-intens")
            print(f"{name:8s} {t['wall_s']:7.0f} {t['cpu_s']:7.0f} {t['peak_mb']:8d} {str(n):>14s}  {cb._fmt(m)}")
    print(f"{'original':8s} {'':>7s} {'':>7s} {'':>8s} {'':>14s}  "
          f"{cb._fmt(row['measured']['original'].get('fg-intens'))}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tool", choices=("register", "coreg"), default="register")
    ap.add_argument("--size", type=int, default=10980)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--arosics", default=str(ROOT.parent / "arosics-venv" / "bin" / "python"))
    ap.add_argument("--arosics-timeout", type=float, default=3000.0)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "coreg_bench.json"))
    args = ap.parse_args()
    if args.arosics and not Path(args.arosics).exists():
        print(f"AROSICS python {args.arosics} not found: fotogeo alone", file=sys.stderr)
        args.arosics = None
    with tempfile.TemporaryDirectory(prefix="coreg_large_") as t:
        row = large_case(args, Path(t))
    out = Path(args.out)
    old = json.loads(out.read_text()) if out.exists() else {}
    key = "large_register" if args.tool == "register" else "large"
    old.setdefault(f"threads_{args.threads}", {})[key if args.size == 10980 else f"{key}_{args.size}"] = row
    out.write_text(json.dumps(old, indent=1, default=str))
    print(f"\nwrote {out} [threads_{args.threads}][{key}]")


if __name__ == "__main__":
    main()
