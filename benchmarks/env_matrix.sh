#!/bin/bash
# Run test files under one "other machine" setting at a time (issue 32 item 9): another OpenBLAS kernel, BLAS or
# OpenCV thread counts, OpenCV's SIMD dispatch switched off, -n 1 vs -n 2, reversed file order, a HOME without
# ~/.cache. Usage, from the repository root:
#   benchmarks/env_matrix.sh NAME OUTDIR [VAR=VALUE ...] -- [pytest args] -- FILE...
# e.g. benchmarks/env_matrix.sh nehalem /tmp/m OPENBLAS_CORETYPE=Nehalem -- -n 2 -- tests/test_ortho.py
# Writes OUTDIR/NAME.log (pytest -rfE) and OUTDIR/NAME.time (user/sys CPU seconds, wall).
set -u
name=$1; out=$2; shift 2
envs=()
while [ "$1" != "--" ]; do envs+=("$1"); shift; done; shift
args=()
while [ "$1" != "--" ]; do args+=("$1"); shift; done; shift
mkdir -p "$out"
export GDAL_PAM_ENABLED=NO PYTHONPATH="${PYTHONPATH:-$PWD}" QT_QPA_PLATFORM=offscreen
PY=${PY:-/work/main/.venv/bin/python}
env "${envs[@]}" /usr/bin/time -f "%U user %S sys %e wall" -o "$out/$name.time" \
  "$PY" -m pytest -q -p no:cacheprovider -rfE "${args[@]}" "$@" > "$out/$name.log" 2>&1
echo "$name: $(tail -1 "$out/$name.log") | $(cat "$out/$name.time")"
