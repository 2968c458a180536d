#!/usr/bin/env python3
"""Fig. 8 of the paper from `panoscan tables fig8`'s fig8_sweep.csv: the tracking error (stitched
ground-truth depth RMSE and mean ATE, mm, left axis) and the optimisation time (s, log scale,
right axis) against the sparsity n (log scale), one line per scan.

Usage:
  /usr/bin/python3 scripts/plot_fig8.py fig8_sweep.csv fig8.png

Uses Debian's python3-matplotlib (Agg backend). Writes the PNG atomically (temporary file + rename).
"""

import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_fig8.py fig8_sweep.csv fig8.png")
    source, target = sys.argv[1], sys.argv[2]
    rows = {}
    with open(source, newline="") as handle:
        for row in csv.DictReader(handle):
            try:
                rows.setdefault(row["scan"], []).append(
                    (int(row["n"]), float(row["stitched_rmse_mm"]), float(row["ate_mm"]), float(row["optimisation_s"])))
            except (KeyError, ValueError) as error:
                sys.exit(f"{source}: bad row {row}: {error}")
    if not rows:
        sys.exit(f"{source}: no rows")

    figure, error_axis = plt.subplots(figsize=(7.5, 4.5))
    time_axis = error_axis.twinx()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    all_n = set()
    for index, (scan, values) in enumerate(sorted(rows.items())):
        values.sort()
        n = [v[0] for v in values]
        all_n.update(n)
        colour = colours[index % len(colours)]
        error_axis.plot(n, [v[1] for v in values], "o-", color=colour, label=f"{scan} stitched RMSE")
        error_axis.plot(n, [v[2] for v in values], "s:", color=colour, label=f"{scan} mean ATE")
        time_axis.plot(n, [v[3] for v in values], "^--", color=colour, alpha=0.6, label=f"{scan} time")
    error_axis.set_xscale("log", base=2)
    error_axis.set_xticks(sorted(all_n))
    error_axis.set_xticklabels([str(n) for n in sorted(all_n)])
    error_axis.set_xlabel("sparsity n (one frame of every n per camera)")
    error_axis.set_ylabel("error (mm)")
    error_axis.set_ylim(bottom=0)
    time_axis.set_yscale("log")
    time_axis.set_ylabel("optimisation time (s)")
    lines = error_axis.get_legend_handles_labels()
    more = time_axis.get_legend_handles_labels()
    error_axis.legend(lines[0] + more[0], lines[1] + more[1], fontsize=8, loc="upper left")
    error_axis.set_title("Fig. 8: tracking error and optimisation time against n")
    error_axis.grid(True, alpha=0.3)
    figure.tight_layout()
    temporary = target + ".tmp.png"
    figure.savefig(temporary, dpi=120)
    os.replace(temporary, target)


if __name__ == "__main__":
    main()
