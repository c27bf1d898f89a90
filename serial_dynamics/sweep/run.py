"""``sweep.run``: a function over many cases, on Dask (``dask.distributed``).

The cases are cut into tasks of consecutive cases (``chunks``); each task runs its cases
one after the other in a worker process and returns one row per case. Dask's scheduler
hands the tasks out, and when a worker dies it reruns that worker's unfinished tasks on
another (up to ``distributed.scheduler.allowed-failures`` times): a task's result is
either kept once or recomputed, so no case is lost or counted twice. The table is
assembled here in case order, so it does not depend on where or in which order the tasks
ran: the same cases and function give the same table, bit for bit, in this process
(``client="serial"``), on a local pool or on a cluster.
"""
from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from importlib.util import find_spec

import pandas as pd

ERROR = "error"             # the column that says why a case did not run ("" when it ran)
TASKS_PER_SLOT = 4          # tasks per worker thread: balances uneven cases, bounds a rerun
MIN_TASKS = 100             # and at least this many: the progress bar moves by 1 %, a dead
                            # worker's rerun is short; at 2-4 ms of Dask per task (measured,
                            # bench/bench_sweep.py) 100 tasks cost under 0.5 s in all


def run(fn, cases, client=None, progress=True, *, workers=None, chunk_size=None):
    """``fn(case) -> dict`` over every case; a pandas DataFrame in case order: the case's
    columns, ``fn``'s outputs, and ``error`` ("" when the case ran, else the exception's
    type and message; a failing case never ends the sweep).

    cases: a list of dicts or a DataFrame (one row a case). client: a
        ``dask.distributed.Client`` (its cluster runs the cases), None (a local cluster of
        ``workers`` processes, default one per core, closed at the end) or "serial" (every
        case in this process, in order: the reference, and the way to debug ``fn``).
    progress: Dask's progress bar on stderr (and the dashboard's address, when it has one).
    chunk_size: cases per task (default: ``chunks``).
    ``fn`` and what it closes over (a ``Robot`` travels as its model data) are pickled to
    the workers; outputs are scalars (numbers, strings, bools), one column each.
    """
    table = _as_table(cases)
    records = table.to_dict("records")
    if isinstance(client, str):
        if client != "serial":
            raise ValueError(f"client = {client!r}; give a dask.distributed Client (e.g. "
                             "Client('tcp://host:8786')), None (local processes) or 'serial'")
        rows = run_cases(fn, records)
    elif client is None:
        from distributed import Client, LocalCluster
        with LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1,
                          processes=True, host="127.0.0.1", dashboard_address=":0") as cluster, \
                Client(cluster) as local:
            rows = _on_cluster(fn, records, local, progress, chunk_size)
    else:
        rows = _on_cluster(fn, records, client, progress, chunk_size)
    return assemble(table, rows)


def run_cases(fn, cases):
    """One task: the rows of ``cases`` run one after the other (the worker's side)."""
    return [_row(fn, case) for case in cases]


def _row(fn, case):
    try:
        out = fn(dict(case))
    except Exception as exc:    # the case's row carries the failure; the sweep goes on
        return {ERROR: f"{type(exc).__name__}: {exc}"}
    if not isinstance(out, Mapping):
        return {ERROR: f"the sweep function returned {type(out).__name__}; it must return a "
                       "dict of outputs"}
    clash = [k for k in out if k in case or k == ERROR]
    if clash:
        return {ERROR: f"the sweep function returned {clash[0]!r}, which is a case column "
                       "(or 'error'); give its outputs other names"}
    return {**out, ERROR: ""}


def chunks(n_cases, slots, chunk_size=None):
    """(start, stop) of each task: ``chunk_size`` cases, or as many cases as make
    ``TASKS_PER_SLOT`` tasks per worker slot (at least ``MIN_TASKS`` tasks), in equal parts."""
    if chunk_size is None:
        chunk_size = -(-n_cases // max(MIN_TASKS, TASKS_PER_SLOT * slots))
    if not (isinstance(chunk_size, int) and chunk_size >= 1):
        raise ValueError(f"chunk_size = {chunk_size!r}; give a whole number of cases >= 1")
    return [(i, min(i + chunk_size, n_cases)) for i in range(0, n_cases, chunk_size)]


def _on_cluster(fn, records, client, progress, chunk_size):
    slots = sum(client.nthreads().values()) or 1
    futures = [client.submit(run_cases, fn, records[a:b], pure=False)
               for a, b in chunks(len(records), slots, chunk_size)]
    if progress and futures:
        from distributed import progress as bar
        link = client.dashboard_link if find_spec("bokeh") else "none (pip install bokeh)"
        print(f"sweep: {len(records)} cases in {len(futures)} tasks; dashboard: {link}",
              file=sys.stderr)
        bar(futures)
    return [row for rows in client.gather(futures) for row in rows]


def _as_table(cases):
    if isinstance(cases, pd.DataFrame):
        return cases.reset_index(drop=True)
    cases = list(cases)
    bad = next((k for k, c in enumerate(cases) if not isinstance(c, Mapping)), None)
    if bad is not None:
        raise ValueError(f"case {bad} is of type {type(cases[bad]).__name__}; give the cases as "
                         "dicts (column: value) or a pandas DataFrame")
    return pd.DataFrame(cases)


def assemble(table, rows):
    """The case columns, then the outputs in the order they first appear, then ``error``."""
    out = pd.DataFrame(rows, index=table.index, columns=None if rows else [ERROR])
    out = out[[c for c in out.columns if c != ERROR] + [ERROR]]
    return pd.concat([table, out], axis=1)
