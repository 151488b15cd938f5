#!/usr/bin/python3
"""Draws the CSV of bench_caustic_convergence (integrator, passes, seconds, rmse) as a log-log
chart of RMS error against wall time, one line per integrator, with the fitted slope of each.

    /usr/bin/python3 bench/atlas/plot_convergence.py out/bench/caustic_convergence.csv [OUT.png]

The PNG goes beside the CSV unless OUT.png is given.
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from run_atlas import label_log_ticks  # noqa: E402  (the atlas's tick labelling)


def slope(points):
    """Least-squares slope of log(rmse) against log(seconds)."""
    xs = [math.log(p[0]) for p in points]
    ys = [math.log(p[1]) for p in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return (sum((x - mx) * (y - my) for x, y in zip(xs, ys)) /
            sum((x - mx) ** 2 for x in xs))


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    source = sys.argv[1]
    target = sys.argv[2] if len(sys.argv) == 3 else os.path.splitext(source)[0] + ".png"
    curves = {}
    with open(source) as f:
        for row in csv.DictReader(f):
            curves.setdefault(row["integrator"], []).append(
                (float(row["seconds"]), float(row["rmse"]), int(row["passes"])))
    fig, ax = plt.subplots(figsize=(8, 5.5))
    for name, points in curves.items():
        ax.loglog([p[0] for p in points], [p[1] for p in points], "o-", markersize=4,
                  label="%s (%d to %d passes; fitted slope %.2f)" % (
                      name, points[0][2], points[-1][2], slope(points)))
    ax.set_xlabel("wall time (seconds, 2 threads)")
    ax.set_ylabel("RMS error (radiance) over the crop's pixels and channels")
    ax.set_title("Caustic scene, 128 x 96 crop: error against time\n"
                 "reference: progressive photon mapper, 2048 passes, another seed")
    label_log_ticks(ax)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(target, dpi=90)
    print("chart: %s" % target)


if __name__ == "__main__":
    main()
