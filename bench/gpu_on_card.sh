#!/usr/bin/env bash
# On a machine with an NVIDIA card: the gpu tests on the card itself (not the simulator),
# then bench/bench_gpu.py (its section of BENCHMARKS.md, the card named). numba-cuda comes
# from PyPI, or from a folder of carried wheels where the machine reaches no registry:
#   WHEELS=/path/to/wheels bash bench/gpu_on_card.sh        (uses .venv/bin/python, or $PYTHON)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
if ! "$PY" -c "import numba_cuda" 2>/dev/null; then
    "$PY" -m pip install ${WHEELS:+--no-index --find-links "$WHEELS"} 'numba-cuda[cu12]==0.30.*'
fi
NUMBA_ENABLE_CUDASIM=0 "$PY" -m pytest -q test/gpu
NUMBA_ENABLE_CUDASIM=0 "$PY" bench/bench_gpu.py
