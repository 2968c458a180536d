#!/usr/bin/env python3
"""Plots from the JSON reports of `panoscan eval` (one JSON per run).

  cloud_evaluation       -> <stem>_errors.png: histograms of point->mesh (accuracy) and
                            sample->cloud (completeness) distances, and the fraction within a
                            distance (the accuracy / completeness curves behind the F-score);
                            <stem>_legend.png: the colour bar of the error-coloured PLY, if one was written
  trajectory_evaluation  -> <stem>_trajectory.png: top view (x-y) of the ground truth and the
                            aligned estimate, and the position error over time

Usage:
  /usr/bin/python3 scripts/plot_eval.py REPORT.json [REPORT.json ...] [--out DIR] [--format png|svg|both]

Uses Debian's python3-matplotlib and python3-numpy (run with /usr/bin/python3), Agg backend.
"""

import argparse
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def save(figure, out_dir, name, formats):
    paths = []
    for fmt in formats:
        path = os.path.join(out_dir, f"{name}.{fmt}")
        # Atomic like every other output: write a temporary file, then rename it into place.
        temporary = os.path.join(out_dir, f".{name}.{fmt}.tmp-{os.getpid()}")
        figure.savefig(temporary, dpi=150, bbox_inches="tight", format=fmt)
        os.replace(temporary, path)
        paths.append(path)
    plt.close(figure)
    return paths


def histogram_arrays(histogram):
    """Bin centres (mm), counts, and the cumulative fraction at each bin's right edge."""
    counts = np.asarray(histogram["counts"], dtype=float)
    width_mm = 1e3 * histogram["bin_width_m"]
    total = counts.sum() + histogram["overflow"]
    centres = (np.arange(len(counts)) + 0.5) * width_mm
    edges = np.arange(len(counts) + 1) * width_mm  # the curve starts at (0, 0)
    cumulative = np.concatenate([[0.0], np.cumsum(counts)]) / total if total > 0 else np.zeros(len(counts) + 1)
    return centres, counts, width_mm, edges, cumulative, total


def plot_cloud(report, stem, out_dir, formats):
    hists = report["histograms"]
    accuracy = report["accuracy"]
    thresholds_mm = [1e3 * t for t in report["settings"]["thresholds_m"]]
    figure, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))

    centres, counts, width, edges, cumulative, total = histogram_arrays(hists["accuracy"])
    left.bar(centres, counts / max(total, 1), width=width, color="tab:blue", alpha=0.7,
             label="reconstruction -> mesh (accuracy)")
    right.plot(edges, 100 * cumulative, color="tab:blue", label="accuracy (points within d)")
    if hists.get("completeness"):
        c_centres, c_counts, c_width, c_edges, c_cumulative, c_total = histogram_arrays(hists["completeness"])
        left.step(c_centres, c_counts / max(c_total, 1), where="mid", color="tab:orange",
                  label="visible ground truth -> reconstruction (completeness)")
        right.plot(c_edges, 100 * c_cumulative, color="tab:orange", label="completeness (surface within d)")
    overflow = hists["accuracy"]["overflow"]
    left.set_xlabel("distance (mm)")
    left.set_ylabel("fraction per bin")
    left.set_title(f"RMSE {accuracy['rmse_mm']:.2f} mm, median {accuracy['median_mm']:.2f} mm\n"
                   f"{accuracy['count']} points ({overflow} beyond the plot)", fontsize=10)
    for t in thresholds_mm:
        left.axvline(t, color="grey", linestyle=":", linewidth=1)
        right.axvline(t, color="grey", linestyle=":", linewidth=1)
    left.legend(fontsize=8)
    right.set_xlabel("distance d (mm)")
    right.set_ylabel("%")
    right.set_ylim(0, 100)
    scores = ", ".join(
        f"F@{1e3 * s['threshold_m']:.0f}mm {100 * s['f_score']:.1f}%" for s in report["scores"]
        if s.get("f_score") is not None)
    right.set_title(scores or "fraction within d", fontsize=10)
    right.legend(fontsize=8, loc="lower right")
    figure.suptitle(os.path.basename(report["inputs"]["cloud"]) + " vs " + os.path.basename(report["inputs"]["mesh"]))
    paths = save(figure, out_dir, f"{stem}_errors", formats)

    coloured = report.get("coloured_ply")
    if coloured:
        low, high = (1e3 * v for v in coloured["range_m"])
        figure, axis = plt.subplots(figsize=(6, 1.0))
        bar = matplotlib.colorbar.ColorbarBase(axis, cmap=plt.get_cmap(coloured["colour_map"]),
                                               norm=matplotlib.colors.Normalize(low, high), orientation="horizontal")
        bar.set_label(f"distance to the ground-truth mesh (mm), clamped: {os.path.basename(coloured['path'])}")
        paths += save(figure, out_dir, f"{stem}_legend", formats)
    return paths


def plot_trajectory(report, stem, out_dir, formats):
    matched = report["matched"]
    gt = np.asarray(matched["gt_positions"], dtype=float)
    est = np.asarray(matched["est_positions_aligned"], dtype=float)
    times = np.asarray(matched["timestamps"], dtype=float)
    figure, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    left.plot(gt[:, 0], gt[:, 1], color="black", linewidth=1.5, label="ground truth")
    left.plot(est[:, 0], est[:, 1], color="tab:red", linewidth=1, label="estimate (aligned)")
    left.set_aspect("equal", adjustable="datalim")
    left.set_xlabel("x (m)")
    left.set_ylabel("y (m)")
    left.set_title("top view")
    left.legend(fontsize=8)
    error_mm = 1e3 * np.linalg.norm(est - gt, axis=1)
    right.plot(times - times[0], error_mm, color="tab:red", linewidth=1)
    ate = report["ate"]
    rpe = report["rpe"]
    right.set_title(f"ATE RMSE {ate['rmse_mm']:.2f} mm; RPE({rpe['delta_s']} s) "
                    f"{rpe['translation']['rmse_mm']:.2f} mm, {rpe['rotation']['rmse_deg']:.3f} deg")
    right.set_xlabel("time (s)")
    right.set_ylabel("position error after alignment (mm)")
    figure.suptitle(os.path.basename(report["inputs"]["estimate"]) + " vs " +
                    os.path.basename(report["inputs"]["ground_truth"]))
    return save(figure, out_dir, f"{stem}_trajectory", formats)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("reports", nargs="+", help="JSON reports written by panoscan eval")
    parser.add_argument("--out", default=None, help="output folder (default: beside each report)")
    parser.add_argument("--format", choices=["png", "svg", "both"], default="png")
    args = parser.parse_args(argv)
    formats = ["png", "svg"] if args.format == "both" else [args.format]
    status = 0
    for path in args.reports:
        try:
            with open(path, encoding="utf-8") as f:
                report = json.load(f)
        except (OSError, json.JSONDecodeError) as error:
            print(f"plot_eval: {path}: {error}", file=sys.stderr)
            status = 2
            continue
        out_dir = args.out or os.path.dirname(os.path.abspath(path))
        os.makedirs(out_dir, exist_ok=True)
        stem = os.path.splitext(os.path.basename(path))[0]
        kind = report.get("kind")
        try:
            if kind == "cloud_evaluation":
                written = plot_cloud(report, stem, out_dir, formats)
            elif kind == "trajectory_evaluation":
                written = plot_trajectory(report, stem, out_dir, formats)
            else:
                print(f"plot_eval: {path}: kind: unknown report kind {kind!r}", file=sys.stderr)
                status = 2
                continue
        except (KeyError, TypeError, ValueError) as error:
            print(f"plot_eval: {path}: missing or malformed field {error}", file=sys.stderr)
            status = 2
            continue
        for p in written:
            print(p)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
