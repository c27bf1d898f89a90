"""URDF load time against chain length (issue 13: a chain of 991 joints took 26.5 s).

    python bench/bench_load.py             # writes the "load" section of bench/BENCHMARKS.md
    python bench/bench_load.py --no-dense  # without the (slow) column of the check of before

Synthetic chains of n joints (``serial_dynamics.builtin.synthetic.chain_urdf``: rods, axes
cycling z, y, x) loaded from the XML string with ``sd.load_urdf``, default base and tip.
Columns: the whole load (parse, chain extraction and lumping, ``Model.build`` with its
validation, the ``Robot``); of it, the parse (lxml, the element checks, yourdfpy) and the
mass-matrix check (``urdf/mass_matrix.check_mass_matrix``, O(n): composite and articulated inertias
at three configurations); and the whole load again with the dense check the loader ran
before (the NumPy CRBA, O(n^2) Python-level products, and the eigenvalues of M, O(n^3), at
the same three configurations; its ``_check_reduced_mass_matrix`` with G = 1). Times are
the minimum over repeats, wall clock, one process, numba cache warm.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

import serial_dynamics as sd                                   # noqa: E402
from serial_dynamics.urdf import loader as urdf_module                # noqa: E402
from serial_dynamics.urdf import mass_matrix as check_module    # noqa: E402
from serial_dynamics.builtin.synthetic import chain_urdf, mimic_chain_urdf  # noqa: E402
from _report import REPORT, stamp, write_section               # noqa: E402

SIZES = (6, 25, 100, 400, 1000)


def best(fn, repeats):
    t = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        t = min(t, time.perf_counter() - start)
    return t


def dense_check(model):
    """The mass-matrix check the loader ran before issue 13, at the same configurations."""
    rng = np.random.default_rng(0)
    lo = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    hi = np.where(np.isfinite(model.upper), model.upper, np.pi)
    qs = np.vstack([np.clip(np.zeros(model.dof), lo, hi), rng.uniform(lo, hi, (2, model.dof))])
    check_module._check_reduced_mass_matrix(model, qs)


def measure(sizes, dense=True):
    rows = []
    sd.load_urdf(chain_urdf(6))                       # imports, numba cache: not timed
    for n in sizes:
        xml = chain_urdf(n)
        repeats = 5 if n <= 100 else 3 if n <= 400 else 2
        load = best(lambda: sd.load_urdf(xml), repeats)
        parse = best(lambda: urdf_module._parse(xml), repeats)
        model = sd.load_urdf(xml).model
        check = best(lambda: check_module.check_mass_matrix(model), repeats)
        mimic_xml = mimic_chain_urdf(n, follower=n // 2 + 1)
        mimic = best(lambda: sd.load_urdf(mimic_xml), repeats)
        old = None
        if dense:
            fast = urdf_module.check_mass_matrix       # the loader's, replaced for a while
            urdf_module.check_mass_matrix = dense_check
            try:
                old = best(lambda: sd.load_urdf(xml), 1 if n >= 400 else repeats)
            finally:
                urdf_module.check_mass_matrix = fast
        rows.append((n, load, parse, check, old, mimic))
        print(f"n = {n:5d}: load {load:.4f} s (parse {parse:.4f} s, mass-matrix check "
              f"{check:.4f} s); with one mimic joint {mimic:.4f} s"
              + ("" if old is None else f"; with the dense check {old:.3f} s"), flush=True)
    return rows


def slope(rows, column):
    pts = [(r[0], r[column]) for r in rows if r[0] >= 100 and r[column]]
    if len(pts) < 2:
        return float("nan")
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def report(rows) -> str:
    dense = rows[0][4] is not None
    L = ["## URDF load time against chain length", "", stamp(),
         "Regenerate with `python bench/bench_load.py` (about a minute; `--no-dense` skips the "
         "check of before). Synthetic chain of n joints (`chain_urdf(n)`, from the XML string), "
         "`sd.load_urdf` with the default base and tip; minimum over repeats, numba cache warm.",
         "",
         "| joints | load | of which: parse | of which: mass-matrix check | load with one mimic "
         "joint | load with the dense check of before |",
         "|---:|---:|---:|---:|---:|---:|"]
    for n, load, parse, check, old, mimic in rows:
        L.append(f"| {n} | {load * 1e3:.1f} ms | {parse * 1e3:.1f} ms | {check * 1e3:.1f} ms | "
                 f"{mimic * 1e3:.1f} ms | "
                 + (f"{old * 1e3:.1f} ms" if old is not None else "") + " |")
    L += ["", f"Log-log slope over n = 100 .. {rows[-1][0]}: load {slope(rows, 1):.2f}, parse "
          f"{slope(rows, 2):.2f}, mass-matrix check {slope(rows, 3):.2f}, load with one mimic "
          f"joint {slope(rows, 5):.2f}"
          + (f", with the dense check of before {slope(rows, 4):.2f}" if dense else "")
          + " (1 is linear).", "",
          "*Parse*: lxml, the element checks that name a bad value's link or joint, and "
          "yourdfpy (linear; meshes are never loaded). *Mass-matrix check*: a joint that moves "
          "no mass, or two joints that move the same mass the same way, make M singular; "
          "checked at three configurations from the diagonal M_ii and the pivots D_i of the "
          "articulated-body inertias (M = L^T D L, so M is positive definite iff every "
          "D_i > 0), O(n), in place of the NumPy CRBA and the eigenvalues of M (O(n^2) "
          "Python-level products and O(n^3)), which the last column puts back: the loader "
          "of issue 13 spent its time there (the issue measured 1.1 s, 4.9 s and 26.5 s for "
          "106, 406 and 991 joints on its machine; a profile of 400 joints here, 0.94 s of "
          "1.12 s in the dense check). *One mimic joint*: the same chain with joint n/2 + 1 "
          "mimicking joint n/2 (`mimic_chain_urdf`); the check is the O(n) one of the whole "
          "chain at q_all = G q + o (M positive definite makes G^T M G so), the dense one "
          "only where that fails (issue 22 measured 5.2 s and 14.0 s for 500 and 1,000 "
          "joints with one mimic joint, when the dense check ran for every mimic chain)."]
    return "\n".join(L)


def place_section():
    """The section goes right after the speed section (its scaling table), once."""
    if not os.path.exists(REPORT):
        return
    text = open(REPORT).read()
    if "<!-- BEGIN load -->" in text or "<!-- END speed -->" not in text:
        return
    text = text.replace("<!-- END speed -->",
                        "<!-- END speed -->\n\n<!-- BEGIN load -->\n<!-- END load -->", 1)
    with open(REPORT, "w") as fh:
        fh.write(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-dense", action="store_true",
                    help="skip the load with the dense check of before (slow for long chains)")
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    rows = measure(args.sizes, dense=not args.no_dense)
    text = report(rows)
    print(text)
    if not args.no_write:
        place_section()
        write_section("load", text)


if __name__ == "__main__":
    main()
