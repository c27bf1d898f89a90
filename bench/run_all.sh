#!/usr/bin/env bash
# Regenerate bench/BENCHMARKS.md and the plots, one benchmark after the other (about
# 45 minutes on 2 cores: the ROS soak 5 of them, bench_compile 17). Run on a quiet machine: other load moves
# the absolute times.
#   bash bench/run_all.sh            (uses .venv/bin/python, or $PYTHON)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
"$PY" -m serial_dynamics.precompile          # fill the numba cache first
"$PY" bench/bench_speed.py
"$PY" bench/bench_load.py
"$PY" bench/bench_modelling.py
"$PY" bench/bench_planar.py
"$PY" bench/bench_simulate.py
"$PY" bench/bench_ros_latency.py
"$PY" bench/bench_ros_users.py
"$PY" bench/bench_ros_throughput.py
"$PY" bench/bench_ros_soak.py --write             # 5 minutes of both cores
"$PY" bench/bench_regressor.py
"$PY" bench/bench_derivatives.py
"$PY" bench/bench_servo.py
"$PY" bench/bench_observer.py
"$PY" bench/bench_trees.py
"$PY" bench/bench_kinematics.py
"$PY" bench/bench_threads.py
"$PY" bench/bench_contacts.py                # needs the mujoco wheel (the bench extra)
"$PY" bench/bench_gpu.py                    # GPU rows only where a card is
"$PY" bench/bench_first_run.py              # empty caches of its own
"$PY" bench/bench_compile.py                # each kernel alone, empty caches (about 15 min)
