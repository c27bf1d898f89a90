#!/usr/bin/env bash
# On a machine with an NVIDIA card: bench/bench_gpu.py (batches and the Monte-Carlo study,
# the card named), then the gpu tests on the card itself (not the simulator).
#   bash bench/gpu_on_card.sh [RESULTS_DIR]      (PYTHON: default .venv/bin/python, else python3)
# numba-cuda comes from PyPI, or, where the machine reaches no registry, WHEELS names a folder
# of carried wheels, installed with --no-deps into /tmp/site (the card's own NumPy, numba,
# numba-cuda, pandas kept): dask, distributed and their pure-Python needs, yourdfpy, trimesh.
set -uo pipefail
cd "$(dirname "$0")/.."
RESULTS=${1:-bench}
mkdir -p "$RESULTS"
PY=${PYTHON:-.venv/bin/python}
[ -x "$PY" ] || PY=python3
export PYTHONUNBUFFERED=1 NUMBA_ENABLE_CUDASIM=0
if [ -n "${WHEELS:-}" ]; then
    "$PY" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/site "$WHEELS"/*.whl || exit 1
    export PYTHONPATH=/tmp/site:$PWD${PYTHONPATH:+:$PYTHONPATH}
elif ! "$PY" -c "import numba_cuda" 2>/dev/null; then
    "$PY" -m pip install 'numba-cuda[cu12]==0.30.*' || exit 1
fi
nvidia-smi -L
"$PY" -c "import numpy, numba, numba_cuda, pandas, dask; print('numpy', numpy.__version__, \
'numba', numba.__version__, 'numba-cuda', numba_cuda.__version__, 'pandas', \
pandas.__version__, 'dask', dask.__version__)"
# the CPU kernels once, on every core, into numba's cache (the bench, its Dask workers and
# the tests then load them)
"$PY" -c "from serial_dynamics.precompile import precompile; import os; \
print(f'numba CPU kernels: {precompile(jobs=os.cpu_count()):.1f} s')"
timeout "${BENCH_TIMEOUT:-360}" "$PY" bench/bench_gpu.py --out "$RESULTS/gpu_section.md" \
    2>&1 | tee "$RESULTS/bench_gpu.log"
timeout "${TEST_TIMEOUT:-200}" "$PY" -m pytest -q -p no:cacheprovider test/gpu \
    --ignore=test/gpu/test_compile.py 2>&1 | tee "$RESULTS/gpu_tests.log"
