#!/usr/bin/env bash
# Issue 26's check that no ROS test races the machine: test/ros N times in a row (default
# 10) while another process keeps one core busy; one line per run in ros_tests_under_load.log
# (exit code, seconds, pytest's summary), each run's output in ros_tests_under_load_<k>.txt.
#     bash bench/ros_tests_under_load.sh [N]
set -u
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
N=${1:-10}
python3 -c "while True: pass" &
BUSY=$!
trap 'kill $BUSY' EXIT
for k in $(seq 1 "$N"); do
  start=$(date +%s)
  "$PY" -m pytest -q -p no:cacheprovider test/ros > "ros_tests_under_load_$k.txt" 2>&1
  rc=$?
  echo "run $k rc=$rc $(( $(date +%s) - start )) s $(tail -1 "ros_tests_under_load_$k.txt")" \
    | tee -a ros_tests_under_load.log
done
