"""The 10,000-case Monte-Carlo study of docs/scale.md: its summary (markdown, printed) and
its figure docs/scale_monte_carlo.png, from the table the command wrote:

    sed 's/^cases: 200 /cases: 10000 /' config/sweep_example.yaml > /tmp/spec10k.yaml
    serial-dynamics sweep /tmp/spec10k.yaml --workers 2 --out /tmp/results10k.parquet
    .venv/bin/python docs/make_scale_figure.py /tmp/results10k.parquet
"""
import os
import sys

import pandas as pd

from serial_dynamics import sweep

HERE = os.path.dirname(os.path.abspath(__file__))


def markdown(df, index=True):
    """A DataFrame as a markdown table (numbers to 4 significant digits)."""
    cells = lambda row: [f"{v:.4g}" if isinstance(v, float) else str(v) for v in row]
    head = ([df.index.name or ""] if index else []) + [str(c) for c in df.columns]
    rows = [([str(i)] if index else []) + cells(r) for i, r in zip(df.index, df.to_numpy())]
    lines = [head, ["---"] * len(head)] + rows
    return "\n".join("| " + " | ".join(r) + " |" for r in lines)


def main(path):
    table = pd.read_parquet(path)
    sweep.plot(table, os.path.join(HERE, "scale_monte_carlo.png"))
    percentiles, worst = sweep.summary(table, worst=5)
    ran = table[table["error"] == ""]
    joints = [c[len("max_"):] for c in table.columns if c.startswith("max_") and c != "max_error"]
    per_joint = pd.DataFrame({j: ran[f"max_{j}"].quantile([0.5, 0.99, 1.0]).to_numpy()
                              for j in joints}, index=["p50", "p99", "p100"])
    heavy = ran["payload"] > 2.0
    print(f"{len(table)} cases, {int((table['error'] != '').sum())} failed, "
          f"{int(ran['diverged'].sum())} diverged\n")
    print(markdown(percentiles), "\n")
    print(markdown(per_joint), "\n")
    print(markdown(worst, index=False), "\n")
    print(f"max error p50, payload <= 1 kg: {ran[ran['payload'] <= 1]['max_error'].median():.4g}; "
          f"payload > 2 kg: {ran[heavy]['max_error'].median():.4g}")
    for lo, hi in ((0.5, 0.8), (0.8, 1.25), (1.25, 2.0)):
        band = ran[ran["friction_scale"].between(lo, hi)]
        print(f"friction scale {lo}-{hi}: max error p50 {band['max_error'].median():.4g}, "
              f"p99 {band['max_error'].quantile(0.99):.4g}")


if __name__ == "__main__":
    main(sys.argv[1])
