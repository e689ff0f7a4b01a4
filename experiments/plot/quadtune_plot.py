#!/usr/bin/python3
"""Figures for quadtune outputs (matplotlib, Debian's python3 packages).

Called by `quadtune plot`, or directly:
    quadtune_plot.py flight DIR              top-down view of a flight: obstacles, flown and
                                             planned paths, speed over time
    quadtune_plot.py flights DIR... --out D  several flights (e.g. one per obstacle density):
                                             stacked top-down views, flight time against spacing,
                                             and a Markdown table
    quadtune_plot.py run DIR                 a tuning run (DIR/results.sqlite from `quadtune run`):
                                             best-so-far f_l per method, f_l per iteration, the
                                             number of short-term evaluations, a Markdown table
"""
import argparse
import csv
import json
import math
import os
import sqlite3
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in (rows[0].keys() if rows else [])}


def draw_obstacles(ax, obstacles, z_slice=None):
    """Cylinders as discs; rings (vertical tori) as their footprint segment in the xy-plane."""
    for c in obstacles.get("cylinders", []):
        ax.add_patch(Circle((c["x"], c["y"]), c["radius"], color="0.35", alpha=0.8, lw=0))
    for r in obstacles.get("rings", []):
        # The ring's axis points along yaw; its rim spans +-radius perpendicular to it.
        ux, uy = -math.sin(r["yaw"]), math.cos(r["yaw"])
        x0, y0 = r["x"] - ux * r["radius"], r["y"] - uy * r["radius"]
        x1, y1 = r["x"] + ux * r["radius"], r["y"] + uy * r["radius"]
        ax.plot([x0, x1], [y0, y1], color="tab:brown", lw=3, solid_capstyle="round", alpha=0.9)
        for (px, py) in ((x0, y0), (x1, y1)):
            ax.add_patch(Circle((px, py), r["thickness"] / 2, color="tab:brown", alpha=0.9, lw=0))


def plot_flight(directory, out=None):
    with open(os.path.join(directory, "obstacles.json")) as f:
        obstacles = json.load(f)
    flight = read_csv(os.path.join(directory, "flight.csv"))
    summary = {}
    if os.path.exists(os.path.join(directory, "summary.json")):
        with open(os.path.join(directory, "summary.json")) as f:
            summary = json.load(f)

    fig, (ax, axv) = plt.subplots(2, 1, figsize=(12, 7.5), gridspec_kw={"height_ratios": [2.2, 1]})
    draw_obstacles(ax, obstacles)
    plans_path = os.path.join(directory, "plans.csv")
    if os.path.exists(plans_path):
        plans = read_csv(plans_path)
        if plans:
            ids = plans["plan"]
            start = 0
            for i in range(1, len(ids) + 1):
                if i == len(ids) or ids[i] != ids[start]:
                    ax.plot(plans["x"][start:i], plans["y"][start:i], color="tab:orange", lw=0.8,
                            alpha=0.6, label="planned" if start == 0 else None)
                    start = i
    ax.plot(flight["x"], flight["y"], color="tab:blue", lw=1.6, label="flown")
    if "ref_x" in flight:
        ax.plot(flight["ref_x"], flight["ref_y"], color="k", lw=0.6, ls="--", alpha=0.6,
                label="reference")
    for key, marker, label in (("start", "o", "start"), ("goal", "*", "goal")):
        if key in summary:
            ax.plot(summary[key][0], summary[key][1], marker, ms=12, color="tab:green", label=label)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    title = "Flight, top-down"
    if summary:
        title += " — t_f = {:.2f} s, collisions {}, emergency stops {}".format(
            summary.get("flight_time", float("nan")), summary.get("collisions", "?"),
            summary.get("emergency_stops", "?"))
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    xs = flight["x"]
    pad = 2.0
    ax.set_xlim(min(xs) - pad, max(xs) + pad)
    ys = flight["y"]
    ax.set_ylim(min(min(ys) - pad, -4), max(max(ys) + pad, 4))

    speed = [math.sqrt(a * a + b * b + c * c) for a, b, c in zip(flight["vx"], flight["vy"], flight["vz"])]
    axv.plot(flight["t"], speed, color="tab:blue", label="speed")
    if "ref_vx" in flight:
        ref_speed = [math.sqrt(a * a + b * b + c * c)
                     for a, b, c in zip(flight["ref_vx"], flight["ref_vy"], flight["ref_vz"])]
        axv.plot(flight["t"], ref_speed, color="k", ls="--", lw=0.8, label="reference speed")
    axv.plot(flight["t"], flight["z"], color="tab:green", lw=0.8, label="height z (m)")
    axv.set_xlabel("t (s)")
    axv.set_ylabel("m/s, m")
    axv.grid(alpha=0.3)
    axv.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    out = out or os.path.join(directory, "flight_topdown.png")
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def load_flight(directory):
    with open(os.path.join(directory, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(directory, "obstacles.json")) as f:
        obstacles = json.load(f)
    return summary, obstacles, read_csv(os.path.join(directory, "flight.csv"))


def plot_flights(directories, out_dir):
    """Stacked top-down views, flight time and speed against spacing, and a Markdown table."""
    os.makedirs(out_dir, exist_ok=True)
    flights = [(d,) + load_flight(d) for d in directories]
    flights.sort(key=lambda f: -f[1].get("spacing_target", 0.0))

    fig, axes = plt.subplots(len(flights), 1, figsize=(12, 2.9 * len(flights)), squeeze=False)
    for ax, (d, summary, obstacles, flight) in zip(axes[:, 0], flights):
        draw_obstacles(ax, obstacles)
        ax.plot(flight["x"], flight["y"], color="tab:blue", lw=1.4)
        ax.plot(summary["start"][0], summary["start"][1], "o", color="tab:green", ms=9)
        ax.plot(summary["goal"][0], summary["goal"][1], "*", color="tab:green", ms=12)
        ax.set_aspect("equal")
        ax.set_xlim(-1.5, max(flight["x"]) + 1.5)
        ax.set_ylim(-5, 5)
        ax.set_ylabel("y (m)")
        ax.set_title("spacing {:.1f} m (achieved {:.2f} m): {} — t_f {:.1f} s, collisions {}, "
                     "emergency stops {}, mean speed {:.2f} m/s".format(
                         summary.get("spacing_target", float("nan")),
                         summary.get("spacing_achieved", float("nan")), summary["status"],
                         summary["flight_time"], summary["collisions"],
                         summary["emergency_stops"], summary["mean_speed"]), fontsize=9)
    axes[-1, 0].set_xlabel("x (m)")
    fig.tight_layout()
    topdown = os.path.join(out_dir, "flights_topdown.png")
    fig.savefig(topdown, dpi=110)
    plt.close(fig)

    spacing = [f[1].get("spacing_target", float("nan")) for f in flights]
    fig, ax = plt.subplots(figsize=(6.5, 4))
    ax.plot(spacing, [f[1]["flight_time"] for f in flights], "o-", color="tab:blue",
            label="flight time t_f (s)")
    ax.set_xlabel("average obstacle spacing (m)")
    ax.set_ylabel("flight time (s)")
    ax.invert_xaxis()
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(spacing, [f[1]["mean_speed"] for f in flights], "s--", color="tab:orange",
             label="mean speed (m/s)")
    ax2.set_ylabel("mean speed (m/s)")
    handles = ax.get_legend_handles_labels()
    handles2 = ax2.get_legend_handles_labels()
    ax.legend(handles[0] + handles2[0], handles[1] + handles2[1], loc="upper left", fontsize=8)
    ax.set_title("Go-and-return flights against obstacle density")
    fig.tight_layout()
    density = os.path.join(out_dir, "flight_time_vs_spacing.png")
    fig.savefig(density, dpi=120)
    plt.close(fig)

    table = os.path.join(out_dir, "flights.md")
    with open(table, "w") as f:
        f.write("| spacing target (m) | achieved (m) | status | t_f (s) | collisions | emergency "
                "stops | plans | failed plans | mean t_c (ms) | mean speed (m/s) |\n")
        f.write("|---|---|---|---|---|---|---|---|---|---|\n")
        for d, s_, _, _ in flights:
            f.write("| {:.1f} | {:.2f} | {} | {:.2f} | {} | {} | {} | {} | {:.1f} | {:.2f} |\n".format(
                s_.get("spacing_target", float("nan")), s_.get("spacing_achieved", float("nan")),
                s_["status"], s_["flight_time"], s_["collisions"], s_["emergency_stops"],
                s_["plans"], s_["failed_plans"], 1e3 * s_["mean_solve_time"], s_["mean_speed"]))
    return [topdown, density, table]


def load_run(path):
    """Per trial: method, repeat, the f_l sequence and the short-term counts before each flight."""
    con = sqlite3.connect("file:{}?mode=ro".format(path), uri=True)
    trials = {}
    for tid, method, repeat, best_value, best_params in con.execute(
            "SELECT id, method, repeat, best_value, best_params FROM trial ORDER BY id"):
        trials[tid] = {"method": method, "repeat": repeat, "best_value": best_value,
                       "best_params": best_params, "long": [], "short_before": [], "shorts": 0}
    for tid, kind, value, status in con.execute(
            "SELECT trial_id, kind, value, status FROM evaluation ORDER BY id"):
        t = trials.get(tid)
        if t is None:
            continue
        if kind == "short":
            t["shorts"] += 1
        else:
            t["long"].append(value)
            t["short_before"].append(t["shorts"])
    con.close()
    return [t for t in trials.values() if t["long"]]


def plot_run(directory):
    """Figures and a table of a tuning run, after the paper's benchmark figure."""
    trials = load_run(os.path.join(directory, "results.sqlite"))
    methods = []
    for t in trials:
        if t["method"] not in methods:
            methods.append(t["method"])
    colors = {"default": "tab:green", "random": "tab:gray", "pso": "tab:purple", "bo": "tab:blue",
              "bo_pso": "tab:red"}
    fig, (ax_a, ax_b, ax_c) = plt.subplots(1, 3, figsize=(16, 4.6))
    rows = []
    for method in methods:
        runs = [t for t in trials if t["method"] == method]
        n = min(len(t["long"]) for t in runs)
        best = []
        for t in runs:
            b, cur = [], float("inf")
            for v in t["long"][:n]:
                cur = min(cur, v)
                b.append(cur)
            best.append(b)
        xs = list(range(1, n + 1))
        mean = [statistics.fmean(col) for col in zip(*best)]
        lo = [min(col) for col in zip(*best)]
        hi = [max(col) for col in zip(*best)]
        c = colors.get(method, None)
        ax_a.plot(xs, mean, color=c, lw=1.8, label=method)
        if len(runs) > 1:
            ax_a.fill_between(xs, lo, hi, color=c, alpha=0.15)
        for t in runs:
            ax_b.plot(range(1, len(t["long"]) + 1), t["long"], ".", color=c, alpha=0.6,
                      label=method if t is runs[0] else None)
            if t["shorts"] > 0:
                ax_c.plot(range(1, len(t["short_before"]) + 1), t["short_before"], color=c,
                          label=method if t is runs[0] else None)
        finals = [b[-1] for b in best]
        rows.append((method, len(runs), n, statistics.fmean(finals),
                     statistics.pstdev(finals) if len(finals) > 1 else 0.0, min(finals),
                     statistics.fmean(t["shorts"] for t in runs), runs[0]["best_params"]))
    ax_a.set_title("(A) best f_l so far (mean; band: min–max over repeats)")
    ax_a.set_xlabel("long-term evaluation (flight)")
    ax_a.set_ylabel("f_l = t_f + t_f n_c + w_e n_e")
    ax_b.set_title("(B) f_l of each flight")
    ax_b.set_xlabel("long-term evaluation (flight)")
    ax_b.set_yscale("log")
    ax_c.set_title("(C) short-term evaluations before each flight")
    ax_c.set_xlabel("long-term evaluation (flight)")
    ax_c.set_ylabel("f_s evaluations (cumulative)")
    for ax in (ax_a, ax_b, ax_c):
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.tight_layout()
    figure = os.path.join(directory, "tuning.png")
    fig.savefig(figure, dpi=120)
    plt.close(fig)

    table = os.path.join(directory, "tuning.md")
    with open(table, "w") as f:
        f.write("| method | repeats | flights | final best f_l (mean ± std) | best | short-term "
                "evaluations | best parameters (first repeat) |\n|---|---|---|---|---|---|---|\n")
        for method, reps, n, mean, std, best, shorts, params in rows:
            f.write("| {} | {} | {} | {:.2f} ± {:.2f} | {:.2f} | {:.0f} | `{}` |\n".format(
                method, reps, n, mean, std, best, shorts, params))
    return [figure, table]


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    sub = parser.add_subparsers(dest="what", required=True)
    p = sub.add_parser("flight", help="top-down figure of one flight directory")
    p.add_argument("directory")
    p.add_argument("--out", default=None)
    p = sub.add_parser("flights", help="summary of several flight directories")
    p.add_argument("directories", nargs="+")
    p.add_argument("--out", required=True)
    p = sub.add_parser("run", help="figures and table of a tuning run directory")
    p.add_argument("directory")
    args = parser.parse_args(argv)
    if args.what == "run":
        for path in plot_run(args.directory):
            print(path)
    elif args.what == "flight":
        print(plot_flight(args.directory, args.out))
    elif args.what == "flights":
        for path in plot_flights(args.directories, args.out):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
