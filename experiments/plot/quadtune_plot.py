#!/usr/bin/python3
"""Figures for quadtune outputs (matplotlib, Debian's python3 packages).

Called by `quadtune plot`, or directly:
    quadtune_plot.py flight DIR [--out PNG]  top-down view of a flight: obstacles, flown and
                                             planned paths, speed over time
    quadtune_plot.py flights DIR... --out D  several flights (e.g. one per obstacle density):
                                             stacked top-down views, flight time against spacing,
                                             and a Markdown table
    quadtune_plot.py run DIR [--out D]       a tuning run (DIR/results.sqlite from `quadtune run`):
                                             best-so-far f_l per method, f_l per iteration, the
                                             number of re-solves, Markdown/CSV tables with
                                             Mann–Whitney U tests between methods
    quadtune_plot.py study DIR               a study (`quadtune study`): validation and 90%-of-
                                             optimum table, sweep figure, refinement figures
    quadtune_plot.py bench CSV [--out PNG]   thread scaling from `quadtune bench --csv`
    quadtune_plot.py scale-model CSV [--out PNG]
                                             stored evaluations/s against MPI ranks from
                                             scripts/scale_model.sh, with the ideal line
    quadtune_plot.py sweep DIR               Sobol' indices of a `quadtune sweep` (DIR/sweep.png)
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

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
matplotlib.use("Agg")
import quadtune  # noqa: E402  (experiments/python/quadtune: the store reader)
import quadtune_methods as qm  # noqa: E402  (method names, colours, final values)
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


def flight_turn_index(flight, summary):
    """Index of the row where a go-and-return flight turns back (closest to the goal), or None
    for a flight that ends nearer the goal than the start (a go-to flight)."""
    goal, start = summary.get("goal"), summary.get("start")
    if not goal or not start or not flight.get("x"):
        return None
    def dist(i, p):
        return math.hypot(flight["x"][i] - p[0], flight["y"][i] - p[1])
    last = len(flight["x"]) - 1
    if dist(last, start) >= dist(last, goal):
        return None
    return min(range(len(flight["x"])), key=lambda i: dist(i, goal))


def plot_flight(directory, out=None):
    """A flight (`quadtune fly` output): top-down views of the outbound and the return leg (one
    panel each; a go-to flight has one), with cylinders, rings, every planned trajectory of that
    leg, the flown path and the reference; below, speed and height against time on their own
    axes, the turn marked. The legend sits beside the panels."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    with open(os.path.join(directory, "obstacles.json")) as f:
        obstacles = json.load(f)
    flight = read_csv(os.path.join(directory, "flight.csv"))
    summary = {}
    if os.path.exists(os.path.join(directory, "summary.json")):
        with open(os.path.join(directory, "summary.json")) as f:
            summary = json.load(f)
    plans = {}
    plans_path = os.path.join(directory, "plans.csv")
    if os.path.exists(plans_path):
        plans = read_csv(plans_path)
    turn = flight_turn_index(flight, summary)
    t_turn = flight["t"][turn] if turn is not None else None
    n = len(flight["t"])
    legs = [("outbound leg", 0, turn + 1), ("return leg", turn, n)] if turn is not None else \
        [("flight", 0, n)]

    fig = plt.figure(figsize=(13, 3.4 * len(legs) + 3.2))
    grid = fig.add_gridspec(len(legs) + 1, 2, height_ratios=[1.25] * len(legs) + [1],
                            hspace=0.45, wspace=0.22)
    xs, ys = flight["x"], flight["y"]
    pad = 1.5
    xlim = (min(xs) - pad, max(xs) + pad)
    ylim = (min(min(ys) - pad, -4), max(max(ys) + pad, 4))
    top_axes = []
    for k, (name, i0, i1) in enumerate(legs):
        ax = fig.add_subplot(grid[k, :])
        top_axes.append(ax)
        draw_obstacles(ax, obstacles)
        if plans:
            ids, t0s = plans["plan"], plans["t0"]
            start = 0
            for i in range(1, len(ids) + 1):
                if i == len(ids) or ids[i] != ids[start]:
                    on_leg = t_turn is None or ((t0s[start] < t_turn) == (k == 0))
                    if on_leg:
                        ax.plot(plans["x"][start:i], plans["y"][start:i], color="tab:orange",
                                lw=0.7, alpha=0.55)
                    start = i
        if "ref_x" in flight:
            ax.plot(flight["ref_x"][i0:i1], flight["ref_y"][i0:i1], color="k", lw=0.6, ls="--",
                    alpha=0.6)
        ax.plot(xs[i0:i1], ys[i0:i1], color="tab:blue", lw=1.7)
        for key, marker in (("start", "o"), ("goal", "*")):
            if key in summary:
                ax.plot(summary[key][0], summary[key][1], marker, ms=11, color="tab:green",
                        mec="k", mew=0.5)
        ax.set_aspect("equal")
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title("({}) {}, top-down: t = {:.1f}–{:.1f} s".format(
            "AB"[k], name, flight["t"][i0], flight["t"][i1 - 1]), loc="left", fontsize=10)
    handles = [Patch(color="0.35", alpha=0.8, label="cylinder"),
               Line2D([], [], color="tab:brown", lw=3, label="ring (footprint)"),
               Line2D([], [], color="tab:orange", lw=0.8, label="planned trajectories"),
               Line2D([], [], color="tab:blue", lw=1.7, label="flown path"),
               Line2D([], [], color="k", lw=0.6, ls="--", label="reference"),
               Line2D([], [], marker="o", ls="", color="tab:green", mec="k", label="start"),
               Line2D([], [], marker="*", ls="", ms=10, color="tab:green", mec="k",
                      label="goal")]
    top_axes[0].legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                       borderaxespad=0)
    if summary:
        fig.suptitle("t_f = {:.2f} s, collisions {}, emergency stops {}, rings {}".format(
            summary.get("flight_time", float("nan")), summary.get("collisions", "?"),
            summary.get("emergency_stops", "?"), len(obstacles.get("rings", []))),
            x=0.01, ha="left", fontsize=11)

    ax_v = fig.add_subplot(grid[len(legs), 0])
    ax_h = fig.add_subplot(grid[len(legs), 1], sharex=ax_v)
    speed = [math.sqrt(a * a + b * b + c * c)
             for a, b, c in zip(flight["vx"], flight["vy"], flight["vz"])]
    ax_v.plot(flight["t"], speed, color="tab:blue", lw=1.2, label="flown")
    if "ref_vx" in flight:
        ref_speed = [math.sqrt(a * a + b * b + c * c)
                     for a, b, c in zip(flight["ref_vx"], flight["ref_vy"], flight["ref_vz"])]
        ax_v.plot(flight["t"], ref_speed, color="k", ls="--", lw=0.8, label="reference")
    ax_h.plot(flight["t"], flight["z"], color="tab:blue", lw=1.2, label="flown")
    if "ref_z" in flight:
        ax_h.plot(flight["t"], flight["ref_z"], color="k", ls="--", lw=0.8, label="reference")
    for ax, label, letter in ((ax_v, "speed (m/s)", "C"), (ax_h, "height z (m)", "D")):
        if t_turn is not None:
            ax.axvline(t_turn, color="0.4", lw=0.8, ls=":")
            ax.text(t_turn, 1.0, " turn", transform=ax.get_xaxis_transform(), fontsize=8,
                    va="top", color="0.3")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(label)
        ax.set_title("({}) {}".format(letter, label.split(" (")[0]), loc="left", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=2,
                  frameon=False)
    out = out or os.path.join(directory, "flight_topdown.png")
    fig.savefig(out, dpi=120, bbox_inches="tight")
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


class _Colours(dict):
    """Method key -> colour, from quadtune_methods (shared with tuning.md and the report)."""

    def __missing__(self, key):
        return qm.colour(key)

    def get(self, key, default=None):
        return qm.colour(key)


COLORS = _Colours()
LABELS = qm.LABELS


def mean_std(values):
    values = list(values)
    if not values:
        return float("nan"), float("nan")
    return statistics.fmean(values), (statistics.stdev(values) if len(values) > 1 else 0.0)


def load_run(path):
    """Per trial: method, repeat, the f_l sequence of its flights (tuning and racing, in the order
    flown), the parameters of each flight, whether each flight failed (did not finish, by its
    state, or f_l at objective.failure_value), the number of re-solves (θ_s candidates ×
    queries_per_eval) before each flight, and the f_s of each θ_s candidate."""
    con = quadtune.connect(path)
    config = con.execute("SELECT config FROM experiment ORDER BY id LIMIT 1").fetchone()
    queries_per_eval = 1
    failure_value = float("inf")
    if config:
        try:
            import yaml
            doc = yaml.safe_load(config[0]) or {}
            queries_per_eval = int(doc.get("budget", {}).get("queries_per_eval", 4))
            failure_value = float(doc.get("objective", {}).get("failure_value", 1000.0))
        except Exception:  # the figure still works, counting θ_s candidates
            queries_per_eval = 1
    trials = {}
    for tid, method, repeat, best_value, best_params in con.execute(
            "SELECT id, method, repeat, best_value, best_params FROM trial ORDER BY id"):
        trials[tid] = {"method": method, "repeat": repeat, "best_value": best_value,
                       "best_params": best_params, "long": [], "params": [], "short_before": [],
                       "long_failed": [], "short_values": [], "shorts": 0, "failed": 0}
    for row_id, tid, kind, value, status, state, params in con.execute(
            "SELECT id, trial_id, kind, value, status, state, params FROM evaluation "
            "ORDER BY trial_id, id"):
        t = trials.get(tid)
        if t is None:
            continue
        if kind == "short":
            t["shorts"] += queries_per_eval
            t["short_values"].append((t["shorts"], value))
        elif kind in ("long", "race"):  # every flight, racing flights included, in order
            t["long"].append(value)
            t["params"].append(quadtune.json_field(params, path, row_id, "params"))
            t["short_before"].append(t["shorts"])
            # Failed: the flight did not finish (any state but ok and collision: timeout,
            # stalled, solver_failure, diverged, error, ...) or scored the failure value.
            failed = state not in ("ok", "collision") or value >= failure_value
            t["long_failed"].append(failed)
            t["failed"] += failed
    con.close()
    return [t for t in trials.values() if t["long"]]


def best_so_far(values):
    out, cur = [], float("inf")
    for v in values:
        cur = min(cur, v)
        out.append(cur)
    return out


def iterations_to_fraction(values, fraction=0.9):
    """First flight (1-based) whose best-so-far f_l is within the fraction of the final optimum:
    best_k <= f* / fraction (f_l is minimised, e.g. 90%: at most 11% above the final best)."""
    b = best_so_far(values)
    target = b[-1] / fraction
    for k, v in enumerate(b, start=1):
        if v <= target:
            return k
    return len(b)


def method_order(trials):
    return qm.order(t["method"] for t in trials)


def final_value(t):
    """A trial's final value (quadtune_methods.final_value): best f_l found, or for the defaults
    the mean f_l of their flights."""
    return qm.final_value(t["method"], t["long"])


def mean_ci95(values):
    """Mean and the half-width of its 95% confidence interval (Student t; 0 for one value)."""
    values = list(values)
    m = statistics.fmean(values)
    if len(values) < 2:
        return m, 0.0
    from scipy.stats import t as student_t
    half = student_t.ppf(0.975, len(values) - 1) * statistics.stdev(values) / math.sqrt(len(values))
    return m, half


def _plain_log_ticks(axis):
    """Log-axis ticks at 1, 2 and 5 per decade, written as plain numbers."""
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter
    axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    formatter = ScalarFormatter()
    formatter.set_scientific(False)
    axis.set_major_formatter(formatter)
    axis.set_minor_formatter(NullFormatter())


def plot_run(directory, out_dir=None):
    """Figures and tables of a tuning run (tuning.png): (A) best f_l so far, one panel per method
    (each repeat thin, the median thick, the defaults' mean dashed); (B) f_l of every flight, one
    panel per method, completed flights as dots and failed ones (f_l = failure_value) counted in
    a strip above; (C) BO+PSO's short-term search: best f_s so far against the re-solves run;
    (D) final values ranked, mean with 95% CI and every repeat. A table of final values with
    Mann–Whitney U tests between methods."""
    trials = load_run(os.path.join(directory, "results.sqlite"))
    methods = method_order(trials)
    tuned = [m for m in methods if m != "default"]
    rows = []
    finals = {}
    mean_default = None
    for method in methods:
        runs = [t for t in trials if t["method"] == method]
        finals[method] = [final_value(t) for t in runs]
        if method == "default":
            mean_default = statistics.fmean(v for t in runs for v in t["long"])
            rows.append(dict(method=method, repeats=len(runs), flights=len(runs[0]["long"]),
                             finals=finals[method], early10=mean_default, early25=mean_default,
                             k90=float("nan"), shorts=0.0, failed=sum(t["failed"] for t in runs),
                             params=runs[0]["best_params"]))
            continue
        n = min(len(t["long"]) for t in runs)
        best = [best_so_far(t["long"][:n]) for t in runs]
        at = lambda k: statistics.fmean(b[min(k, n) - 1] for b in best)  # noqa: E731
        k90_each = [iterations_to_fraction(t["long"][:n]) for t in runs]
        rows.append(dict(method=method, repeats=len(runs), flights=n, finals=finals[method],
                         early10=at(max(1, n // 10)), early25=at(max(1, n // 4)),
                         k90_each=k90_each, k90=statistics.fmean(k90_each),
                         shorts=statistics.fmean(t["shorts"] for t in runs),
                         failed=sum(t["failed"] for t in runs),
                         params=min(runs, key=lambda t: t["best_value"])["best_params"]))

    from matplotlib.gridspec import GridSpec
    from matplotlib.lines import Line2D
    cols = max(2, len(tuned))
    fig = plt.figure(figsize=(3.4 * cols + 1.0, 10.5))
    grid = GridSpec(3, cols, figure=fig, height_ratios=[1, 1, 1.05], hspace=0.55, wspace=0.08)
    completed = [v for t in trials if t["method"] != "default"
                 for v, bad in zip(t["long"], t["long_failed"]) if not bad]
    # (A) convergence: the y range of the trials' final quarter and the defaults, so that the
    # first flights' large values do not flatten the part that matters.
    finals_all = [v for m in tuned for v in finals[m]]
    a_lo = min(finals_all + ([mean_default] if mean_default else [])) if finals_all else 0.0
    a_hi = max([mean_default or 0.0] + finals_all)
    a_pad = 0.25 * (a_hi - a_lo + 1e-9)
    axes_a = []
    for i, method in enumerate(tuned):
        ax = fig.add_subplot(grid[0, i], sharey=axes_a[0] if axes_a else None)
        axes_a.append(ax)
        runs = [t for t in trials if t["method"] == method]
        n = min(len(t["long"]) for t in runs)
        xs = list(range(1, n + 1))
        best = [best_so_far(t["long"][:n]) for t in runs]
        c = COLORS.get(method, "0.3")
        for b in best:
            ax.plot(xs, b, color=c, lw=0.7, alpha=0.45)
        ax.plot(xs, [statistics.median(col) for col in zip(*best)], color=c, lw=2.2)
        if mean_default is not None:
            ax.axhline(mean_default, color=COLORS["default"], lw=1.2, ls="--")
        ax.set_title("{} ({} repeats)".format(LABELS.get(method, method), len(runs)), fontsize=10)
        ax.set_xlabel("flight")
        ax.grid(alpha=0.3)
        if i == 0:
            ax.set_ylabel("best f_l so far (s)")
        else:
            ax.tick_params(labelleft=False)
    if axes_a:
        axes_a[0].set_ylim(a_lo - a_pad, a_hi + 2 * a_pad)
        handles = [Line2D([], [], color="0.3", lw=0.7, alpha=0.6, label="one repeat"),
                   Line2D([], [], color="0.3", lw=2.2, label="median over repeats")]
        if mean_default is not None:
            handles.append(Line2D([], [], color=COLORS["default"], ls="--",
                                  label="Default (mean f_l)"))
        axes_a[-1].legend(handles=handles, fontsize=7, loc="upper right")
        axes_a[0].annotate("(A) convergence; early values above the panel are clipped",
                           xy=(0, 1.18), xycoords="axes fraction", fontsize=11, weight="bold")
    # (B) every flight: completed ones as dots on a log axis (they span a decade and more);
    # failures (f_l = failure_value) as ticks in the strip at the top, counted in the title.
    axes_b = []
    b_lo = min(completed) if completed else 1.0
    b_hi = max(completed) if completed else 10.0
    for i, method in enumerate(tuned):
        ax = fig.add_subplot(grid[1, i], sharey=axes_b[0] if axes_b else None)
        axes_b.append(ax)
        runs = [t for t in trials if t["method"] == method]
        c = COLORS.get(method, "0.3")
        ok_x, ok_y, bad_x = [], [], []
        for t in runs:
            for k, (v, bad) in enumerate(zip(t["long"], t["long_failed"]), start=1):
                (bad_x if bad else ok_x).append(k)
                if not bad:
                    ok_y.append(v)
        ax.scatter(ok_x, ok_y, s=6, color=c, alpha=0.45, lw=0)
        top = b_hi * 1.6
        ax.scatter(bad_x, [top] * len(bad_x), marker="|", s=60, color="k", lw=0.8)
        ax.axhline(b_hi * 1.25, color="0.6", lw=0.6)
        if mean_default is not None:
            ax.axhline(mean_default, color=COLORS["default"], lw=1.2, ls="--")
        n_flights = sum(len(t["long"]) for t in runs)
        ax.set_title("{}: {} of {} flights failed".format(LABELS.get(method, method),
                                                          len(bad_x), n_flights), fontsize=9)
        ax.set_yscale("log")
        ax.set_xlabel("flight")
        ax.grid(alpha=0.3, which="both")
        if i == 0:
            ax.set_ylabel("f_l of the flight (s)")
        else:
            ax.tick_params(labelleft=False)
    if axes_b:
        axes_b[0].set_ylim(b_lo / 1.15, b_hi * 2.0)
        _plain_log_ticks(axes_b[0].yaxis)
        axes_b[0].text(0.01, 0.97, "failed", transform=axes_b[0].transAxes, fontsize=7,
                       va="top", color="k")
        axes_b[0].annotate("(B) f_l of every flight; failed flights (f_l = failure value) as "
                           "ticks in the top strip", xy=(0, 1.18), xycoords="axes fraction",
                           fontsize=11, weight="bold")
    # (C) the short-term search of BO+PSO: best f_s so far against the re-solves it took.
    bottom = grid[2, :].subgridspec(1, 2, wspace=0.45)
    ax_c = fig.add_subplot(bottom[0, 0])
    shorts = [t for t in trials if t["short_values"]]
    for t in shorts:
        xs = [r for r, _ in t["short_values"]]
        ax_c.plot(xs, best_so_far(v for _, v in t["short_values"]),
                  color=COLORS.get(t["method"], "0.3"), lw=1.0, alpha=0.7)
    if shorts:
        ax_c.set_xscale("log")  # most of the search's progress is in its first re-solves
        ax_c.set_yscale("log")
        _plain_log_ticks(ax_c.yaxis)
        ax_c.set_title("(C) BO+PSO: best f_s so far per repeat", loc="left",
                       fontsize=11, weight="bold")
    else:
        ax_c.text(0.5, 0.5, "no θ_s candidates in this run", ha="center", va="center",
                  transform=ax_c.transAxes)
        ax_c.set_title("(C) short-term search", loc="left", fontsize=11, weight="bold")
    ax_c.set_xlabel("re-solves (θ_s candidates × queries each)")
    ax_c.set_ylabel("best f_s so far (objective units)")
    ax_c.grid(alpha=0.3, which="both")
    # (D) final values, ranked: every repeat, and the mean with its 95% CI.
    ax_d = fig.add_subplot(bottom[0, 1])
    ranked = sorted(methods, key=lambda m: statistics.fmean(finals[m]), reverse=True)
    for y, method in enumerate(ranked):
        c = COLORS.get(method, "0.3")
        m, ci = mean_ci95(finals[method])
        ax_d.scatter(finals[method], [y + 0.18] * len(finals[method]), s=12, color=c, alpha=0.5,
                     lw=0)
        ax_d.errorbar(m, y, xerr=ci, fmt="o", color=c, capsize=4, ms=7)
    ax_d.set_yticks(range(len(ranked)))
    ax_d.set_yticklabels([LABELS.get(m, m) for m in ranked])
    ax_d.set_ylim(-0.6, len(ranked) - 0.4)
    ax_d.set_xlabel("final f_l (s): best of the trial; Default: mean of its flights")
    ax_d.set_title("(D) final values: mean ± 95% CI", loc="left", fontsize=11,
                   weight="bold")
    ax_d.grid(alpha=0.3, axis="x")
    out_dir = out_dir or directory
    os.makedirs(out_dir, exist_ok=True)
    figure = os.path.join(out_dir, "tuning.png")
    fig.savefig(figure, dpi=120, bbox_inches="tight")
    plt.close(fig)

    try:
        from scipy.stats import mannwhitneyu
    except ImportError:  # pragma: no cover - python3-scipy is installed by scripts/setup.sh
        mannwhitneyu = None

    def p_value(a, b):
        if mannwhitneyu is None or len(a) < 2 or len(b) < 2 or a == b:
            return float("nan")
        return float(mannwhitneyu(a, b, alternative="two-sided").pvalue)

    reference = "bo_pso" if "bo_pso" in finals else None
    k90_reference = next((r["k90_each"] for r in rows if r["method"] == reference), None)
    table = os.path.join(out_dir, "tuning.md")
    csv_path = os.path.join(out_dir, "tuning.csv")
    with open(table, "w") as f, open(csv_path, "w", newline="") as fc:
        w = csv.writer(fc)
        w.writerow(["method", "repeats", "flights", "final_mean", "final_std", "final_min",
                     "best_at_10pct", "best_at_25pct", "flights_to_90pct", "resolves",
                     "failed", "p_vs_default", "p_vs_bo_pso", "p_flights_to_90pct_vs_bo_pso",
                     "best_params"])
        f.write("Final value: best f_l of the trial's flights, tuning and racing flights "
                "(Default: mean f_l of its flights). Early columns: mean best f_l after 10% and "
                "25% of the flights. p: two-sided Mann–Whitney U test of the final values over "
                "repeats, and p (flights to 90%) the same test of each trial's flights to 90% "
                "of its own final value. Failed: flights that did not finish (state timeout, "
                "stalled, diverged, solver_failure, error, ...). Best parameters: the best "
                "trial's best flight.\n\n")
        f.write("| method | repeats | flights | final f_l (mean ± std) | min | after 10% | "
                "after 25% | flights to 90% of optimum | re-solves | failed | "
                "p vs Default | p vs BO+PSO | p (flights to 90%) vs BO+PSO | best parameters |\n")
        f.write("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            m, s = mean_std(r["finals"])
            pd_ = p_value(r["finals"], finals["default"]) if "default" in finals and \
                r["method"] != "default" else float("nan")
            pb = p_value(r["finals"], finals[reference]) if reference and \
                r["method"] != reference else float("nan")
            pk = p_value(r["k90_each"], k90_reference) if k90_reference and "k90_each" in r \
                and r["method"] != reference else float("nan")
            fmt_p = lambda p: "–" if p != p else "{:.3f}".format(p)  # noqa: E731
            f.write("| {} | {} | {} | {:.2f} ± {:.2f} | {:.2f} | {:.2f} | {:.2f} | {} | {:.0f} | "
                    "{} | {} | {} | {} | `{}` |\n".format(
                        LABELS.get(r["method"], r["method"]), r["repeats"], r["flights"], m, s,
                        min(r["finals"]), r["early10"], r["early25"],
                        "–" if r["k90"] != r["k90"] else "{:.1f}".format(r["k90"]),
                        r["shorts"], r["failed"], fmt_p(pd_), fmt_p(pb), fmt_p(pk), r["params"]))
            w.writerow([r["method"], r["repeats"], r["flights"], m, s, min(r["finals"]),
                        r["early10"], r["early25"], r["k90"], r["shorts"], r["failed"], pd_, pb,
                        pk, r["params"]])
    validation = plot_validation(directory, out_dir)
    store = os.path.join(directory, "results.sqlite")
    con = quadtune.connect(store)
    tuned = qm.tuned_parameters(con, store)
    con.close()
    with open(table, "a") as f:
        f.write("\n" + qm.parameters_markdown(tuned))
    return [figure, table, csv_path] + validation


def plot_validation(directory, out_dir=None):
    """The held-out validation of a run (kind 'validation' rows): a table appended to
    tuning.md, validation.csv, and validation.png: (A) mean f_l with its 95% CI per method on the
    held-out maps, ranked; (B) n_d, the count of θ_s changes the BO discount has seen, against
    the flight, for the BO+PSO trials."""
    import quadtune_validation as qv
    store = os.path.join(directory, "results.sqlite")
    con = quadtune.connect(store)
    flights = qv.read_store(con, store)
    config = con.execute("SELECT config FROM experiment ORDER BY id LIMIT 1").fetchone()
    n_d = {}
    for tid, iteration, idx, terms in con.execute(
            "SELECT e.trial_id, e.iteration, e.idx, e.terms FROM evaluation e JOIN trial t "
            "ON t.id = e.trial_id WHERE e.kind = 'long' AND t.method = 'bo_pso' "
            "ORDER BY e.trial_id, e.id"):
        n_d.setdefault(tid, []).append(json.loads(terms).get("n_d", float("nan")))
    con.close()
    if not flights:
        return []
    space = qv.space_of(config[0]) if config else []
    rows = qv.summarise(flights, space)
    maps = len({f["map"] for f in flights})
    out_dir = out_dir or directory
    with open(os.path.join(out_dir, "tuning.md"), "a") as f:
        f.write("\n" + qv.markdown(rows, maps))
    csv_path = os.path.join(out_dir, "validation.csv")
    with open(csv_path, "w", newline="") as fc:
        w = csv.writer(fc)
        w.writerow(qv.CSV_FIELDS)
        for r in rows:
            w.writerow(qv.csv_row(r))
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(11, 3.8),
                                     gridspec_kw={"width_ratios": [1.2, 1]})
    ranked = sorted(rows, key=lambda r: r["mean"], reverse=True)  # the best at the top
    ys = list(range(len(ranked)))
    for y, r in zip(ys, ranked):
        c = COLORS.get(r["method"], "0.3")
        ax_a.errorbar(r["mean"], y, xerr=0 if r["ci"] != r["ci"] else r["ci"], fmt="o",
                      color=c, capsize=4, ms=7)
    ax_a.set_yticks(ys)
    ax_a.set_yticklabels(["{} ({}/{} collision-free)".format(
        LABELS.get(r["method"], r["method"]), r["collision_free"], r["flights"]) for r in ranked])
    ax_a.set_xlabel("mean f_l on held-out maps (s; 95% CI)")
    ax_a.set_title("(A) held-out validation, {} maps".format(maps))
    ax_a.grid(alpha=0.3, axis="x")
    for tid, values in sorted(n_d.items()):
        ax_b.step(range(1, len(values) + 1), values, where="post", color=COLORS.get("bo_pso"),
                  alpha=0.7, lw=1.2)
    from matplotlib.ticker import MaxNLocator
    ax_a.set_ylim(-0.6, len(ranked) - 0.4)
    ax_b.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax_b.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_b.set_xlabel("long-term evaluation (flight)")
    ax_b.set_ylabel("n_d (θ_s changes so far)")
    ax_b.set_title("(B) BO+PSO: discount count n_d per trial")
    ax_b.grid(alpha=0.3)
    fig.tight_layout()
    figure = os.path.join(out_dir, "validation.png")
    fig.savefig(figure, dpi=120)
    plt.close(fig)
    return [figure, csv_path]


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# Axis titles for the swept keys of the shipped studies (any other key is shown as it is).
SWEEP_AXIS_LABELS = {
    "planner.layout_file": "layout: mean obstacle spacing (m)",
    "planner.drone": "drone",
}


def study_validation_tables(out_dir, study, validation):
    """Per point, the held-out validation of the last stage's recommended points against the
    defaults (quadtune_validation.markdown), appended to out_dir/study.md;
    out_dir/study_validation.csv."""
    import quadtune_validation as qv
    if not validation:
        return []
    csv_path = os.path.join(out_dir, "study_validation.csv")
    with open(os.path.join(out_dir, "study.md"), "a") as f, open(csv_path, "w", newline="") as fc:
        w = csv.writer(fc)
        w.writerow(["point"] + qv.CSV_FIELDS)
        for p, point in enumerate(study["points"]):
            last = point["stages"][-1]
            flights = [dict(method=r["method"], repeat=int(r["repeat"]), map=int(r["flight"]),
                            value=float(r["f_l"]), completed=r["completed"] == "1",
                            n_c=float(r["collisions"]), n_e=float(r["emergency_stops"]),
                            params=json.loads(r["params"]) if r["params"] else {})
                       for r in validation if int(r["point"]) == p and
                       (r["method"] == "default" or r["source_stage"] == last["name"])]
            if not flights:
                continue
            rows = qv.summarise(flights, last.get("space", []))
            f.write("\n### {} = {}\n\n".format(study.get("sweep_key") or "point", point["label"]))
            f.write(qv.markdown(rows, len({x["map"] for x in flights})))
            for r in rows:
                w.writerow([point["label"]] + qv.csv_row(r))
    return [csv_path]


def plot_study(directory, out=None):
    """Tables and figures of a study (`quadtune study`): per point the validation flights of the
    tuned parameters against the defaults and the flights needed to reach 90% of the optimum
    (the paper's density table); with stages, the refinement figure (normalised parameters and
    f_l over the flights of every stage, and the validation of each stage's result). Written to
    `out` (default: the study directory)."""
    out_dir = out or directory
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(directory, "study.json")) as f:
        study = json.load(f)
    validation = []
    vpath = os.path.join(directory, "validation.csv")
    if os.path.exists(vpath):
        validation = read_rows(vpath)
    outputs = []
    rows = []
    for p, point in enumerate(study["points"]):
        last = point["stages"][-1]
        trials = load_run(os.path.join(directory, last["store"]))
        tuned = [t for t in trials if t["method"] != "default"]
        method = "bo_pso" if any(t["method"] == "bo_pso" for t in tuned) else (
            tuned[0]["method"] if tuned else "default")
        runs = [t for t in tuned if t["method"] == method]
        k90 = [iterations_to_fraction(t["long"]) for t in runs]
        s90 = [t["short_before"][k - 1] for t, k in zip(runs, k90)]
        v = [r for r in validation if int(r["point"]) == p]
        tuned_v = [r for r in v if r["method"] == method and r["source_stage"] == last["name"]]
        default_v = [r for r in v if r["method"] == "default"]
        ft = [float(r["flight_time"]) for r in tuned_v]
        fd = [float(r["flight_time"]) for r in default_v]
        row = dict(label=point["label"], method=method, tuned=mean_std(ft),
                   tuned_fl=mean_std(float(r["f_l"]) for r in tuned_v),
                   default=mean_std(fd), default_fl=mean_std(float(r["f_l"]) for r in default_v),
                   max_e=max([int(r["emergency_stops"]) for r in tuned_v], default=0),
                   collisions=sum(int(r["collisions"]) for r in tuned_v),
                   completed="{}/{}".format(sum(int(r["completed"]) for r in tuned_v), len(tuned_v)),
                   k90=mean_std(k90), s90=mean_std(s90), flights=len(tuned_v))
        rows.append(row)

    table = os.path.join(out_dir, "study.md")
    csv_path = os.path.join(out_dir, "study.csv")
    key = study.get("sweep_key") or "point"
    with open(table, "w") as f, open(csv_path, "w", newline="") as fc:
        w = csv.writer(fc)
        w.writerow([key, "method", "validation_flights", "flight_time_mean", "flight_time_std",
                    "f_l_mean", "max_emergency_stops", "collisions", "completed",
                    "default_flight_time_mean", "default_flight_time_std", "default_f_l_mean",
                    "resolves_to_90pct_mean", "resolves_to_90pct_std",
                    "flights_to_90pct_mean", "flights_to_90pct_std"])
        f.write("Validation: {} held-out maps (no trial flew them) per tuned trial, flown with the "
                "recommended point of each trial and with the defaults on the same maps. 90% of "
                "optimum: first flight whose best f_l so far is within f*/0.9 of the trial's "
                "final best f*; re-solves: the planning queries re-solved before it.\n\n"
                .format(study.get("validation_flights")))
        f.write("| {} | method | flight time (s) | f_l | max emergency stops | collisions | "
                "completed | defaults: flight time (s) | defaults: f_l | 90% optimum: "
                "re-solves | 90% optimum: flights |\n".format(key))
        f.write("|---|---|---|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write("| {} | {} | {:.2f} ± {:.2f} | {:.2f} | {} | {} | {} | {:.2f} ± {:.2f} | "
                    "{:.2f} | {:.0f} ± {:.0f} | {:.1f} ± {:.1f} |\n".format(
                        r["label"], LABELS.get(r["method"], r["method"]), r["tuned"][0],
                        r["tuned"][1], r["tuned_fl"][0], r["max_e"], r["collisions"],
                        r["completed"], r["default"][0], r["default"][1], r["default_fl"][0],
                        r["s90"][0], r["s90"][1], r["k90"][0], r["k90"][1]))
            w.writerow([r["label"], r["method"], r["flights"], r["tuned"][0], r["tuned"][1],
                        r["tuned_fl"][0], r["max_e"], r["collisions"], r["completed"],
                        r["default"][0], r["default"][1], r["default_fl"][0], r["s90"][0],
                        r["s90"][1], r["k90"][0], r["k90"][1]])
    outputs += [table, csv_path]
    outputs += study_validation_tables(out_dir, study, validation)

    if len(rows) > 1:
        labels = [r["label"] for r in rows]
        xs = list(range(len(rows)))
        fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(12, 4.2))
        ax_a.errorbar(xs, [r["tuned"][0] for r in rows], yerr=[r["tuned"][1] for r in rows],
                      fmt="o-", color="tab:red", capsize=4, label="tuned")
        ax_a.errorbar(xs, [r["default"][0] for r in rows], yerr=[r["default"][1] for r in rows],
                      fmt="s--", color="tab:green", capsize=4, label="defaults")
        ax_a.set_title("(A) validation flight time (mean ± std)")
        ax_a.set_ylim(bottom=0)
        ax_a.set_ylabel("flight time t_f (s)")
        ax_b.errorbar(xs, [r["k90"][0] for r in rows], yerr=[r["k90"][1] for r in rows],
                      fmt="o-", color="tab:blue", capsize=4)
        ax_b.set_ylabel("flights to 90% of the optimum")
        ax_b.set_ylim(bottom=0)
        # The re-solves before that flight follow the flights (a fixed number per flight): they
        # are in study.md, not drawn again here.
        ax_b.set_title("(B) flights to reach 90% of the optimum (mean ± std)")
        for ax in (ax_a, ax_b):
            ax.set_xticks(xs)
            ax.set_xticklabels(labels)
            ax.set_xlabel(SWEEP_AXIS_LABELS.get(key, key))
            ax.grid(alpha=0.3)
        ax_a.legend(fontsize=8)
        fig.tight_layout()
        figure = os.path.join(out_dir, "study_sweep.png")
        fig.savefig(figure, dpi=120)
        plt.close(fig)
        outputs.append(figure)

    for p, point in enumerate(study["points"]):
        if len(point["stages"]) < 2:
            continue
        figure = plot_refinement(directory, study, p, validation, out_dir)
        outputs.append(figure)
    return outputs


def _stage_config(store):
    """The experiment file stored with a run (YAML text parsed), {} when unreadable."""
    try:
        import yaml
        con = sqlite3.connect("file:{}?mode=ro".format(store), uri=True)
        row = con.execute("SELECT config FROM experiment ORDER BY id LIMIT 1").fetchone()
        con.close()
        return (yaml.safe_load(row[0]) or {}) if row else {}
    except Exception:
        return {}


def _unit(prm, x):
    """A parameter value on the figure's normalised scale: 0 at its lower bound, 1 at its upper,
    log-scaled for log parameters."""
    lo, hi = prm["lower"], prm["upper"]
    if prm.get("log"):
        x, lo, hi = math.log(x), math.log(lo), math.log(hi)
    return (x - lo) / (hi - lo) if hi > lo else 0.5


def _bo_unit(prm, x):
    """A parameter value in BO's unit coordinates: as _unit, but an integer parameter's unit
    interval spans half a cell beyond its bounds."""
    if prm.get("type") == "integer":
        lo, hi = prm["lower"], prm["upper"]
        return (x - lo + 0.5) / (hi - lo + 1.0)
    return _unit(prm, x)


def _bo_unit_to_plot(prm, u):
    """BO's unit coordinate on the figure's normalised scale (see _bo_unit)."""
    if prm.get("type") == "integer":
        lo, hi = prm["lower"], prm["upper"]
        x = lo - 0.5 + u * (hi - lo + 1.0)
        return min(1.0, max(0.0, (x - lo) / (hi - lo))) if hi > lo else 0.5
    return u


def moving_bounds(trial, space, config, start):
    """The damped moving bounds of BO (paper Sec. III-E) per flight of `trial`, per parameter, on
    the figure's normalised scale: before flight i, the bounds current when it was asked.
    Rebuilt from the stored flights: lo ← λ lo + (1 − λ)(θ* − r), hi likewise with + r, after each
    told flight, θ* the best flight so far (BO's incumbent is its posterior-mean best; the best
    observed flight stands in for it). None when the stage did not move its bounds."""
    mb = (config.get("bo") or {}).get("moving_bounds") or {}
    if not mb or not mb.get("enabled", True):
        return None
    lam, r = float(mb.get("damping", 0.8)), float(mb.get("half_width", 0.1))
    integer = {q["name"] for q in config.get("parameters", []) if q.get("type") == "integer"}
    space = [dict(prm, type="integer") if prm["name"] in integer else prm for prm in space]
    names = [prm["name"] for prm in space]
    if start:
        lo = [max(0.0, _bo_unit(prm, start[prm["name"]]) - r) for prm in space]
        hi = [min(1.0, _bo_unit(prm, start[prm["name"]]) + r) for prm in space]
    else:
        lo, hi = [0.0] * len(names), [1.0] * len(names)
    bounds = []
    best, best_value = None, float("inf")
    for params, value in zip(trial["params"], trial["long"]):
        bounds.append((list(lo), list(hi)))
        if value < best_value:
            best, best_value = params, value
        u = [_bo_unit(prm, best.get(prm["name"], prm["lower"])) for prm in space]
        lo = [min(1.0, max(0.0, lam * a + (1 - lam) * (b - r))) for a, b in zip(lo, u)]
        hi = [min(1.0, max(0.0, lam * a + (1 - lam) * (b + r))) for a, b in zip(hi, u)]
    return [([_bo_unit_to_plot(prm, x) for prm, x in zip(space, b[0])],
             [_bo_unit_to_plot(prm, x) for prm, x in zip(space, b[1])]) for b in bounds]


def plot_refinement(directory, study, p, validation, out_dir=None):
    """The refinement figure of study point `p`: (A) each tuned parameter per flight over the
    stages, with the moving bounds of a stage that uses them; (B) f_l per flight and the best so
    far; (C) the validation flights of the defaults and of each stage's result."""
    point = study["points"][p]
    space = point["stages"][-1]["space"]
    cmap = plt.get_cmap("tab10")
    fig = plt.figure(figsize=(2.6 * len(space) + 1.0, 8.6))
    grid = fig.add_gridspec(2, 1, height_ratios=[1, 1.15], hspace=0.45)
    top = grid[0].subgridspec(1, len(space), wspace=0.12)
    bottom = grid[1].subgridspec(1, 2, wspace=0.28, width_ratios=[1.5, 1])
    axes_a = [fig.add_subplot(top[0, j]) for j in range(len(space))]
    ax_b = fig.add_subplot(bottom[0, 0])
    ax_c = fig.add_subplot(bottom[0, 1])
    offset = 0
    boundaries = []
    banded = set()
    for k, stage in enumerate(point["stages"]):
        store = os.path.join(directory, stage["store"])
        trials = [t for t in load_run(store) if t["method"] != "default"]
        if not trials:
            continue
        t = min(trials, key=lambda t: t["best_value"])
        xs = [offset + i + 1 for i in range(len(t["long"]))]
        bounds = moving_bounds(t, space, _stage_config(store), stage.get("start"))
        for j, prm in enumerate(space):
            ax = axes_a[j]
            vals = [_unit(prm, params.get(prm["name"], float("nan"))) for params in t["params"]]
            if bounds:
                banded.add(k)
                ax.fill_between(xs, [b[0][j] for b in bounds], [b[1][j] for b in bounds],
                                step="mid",
                                color=cmap(k), alpha=0.2, lw=0)
            ax.plot(xs, vals, ".", color=cmap(k), ms=4)
        ax_b.plot(xs, t["long"], ".", color=cmap(k), ms=5)
        ax_b.plot(xs, best_so_far(t["long"]), "-", color=cmap(k),
                  label="{}: f_l per flight (dots), best so far (line)".format(stage["name"]))
        if k > 0:
            boundaries.append(offset + 0.5)
        offset += len(t["long"])
    for j, prm in enumerate(space):
        ax = axes_a[j]
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(prm["name"], fontsize=10)
        ax.set_xlabel("flight")
        ax.set_yticks([0, 0.5, 1])
        if j == 0:
            ax.set_ylabel("value, 0 = lower bound, 1 = upper\n(log scale for log parameters)")
        else:
            ax.set_yticklabels([])
        ax.set_xticks([x for x in ax.get_xticks() if 0 < x <= offset])
        ax.set_xlim(0, offset + 1)
        ax.grid(alpha=0.3)
    for ax in axes_a + [ax_b]:
        for x in boundaries:
            ax.axvline(x, color="k", lw=1, ls=":")
    from matplotlib.patches import Patch
    handles = [Patch(color=cmap(k), alpha=0.6 if k in banded else 1.0,
                     label=s_["name"] + (" (band: moving bounds)" if k in banded else ""))
               for k, s_ in enumerate(point["stages"])]
    axes_a[-1].legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                      borderaxespad=0)
    axes_a[0].annotate("(A) tuned parameters per flight; dotted: next stage; band: BO's "
                       "damped moving bounds", xy=(0, 1.2), xycoords="axes fraction",
                       fontsize=11, weight="bold")
    ax_b.set_title("(B) f_l per flight and best so far", loc="left", fontsize=11,
                   weight="bold")
    ax_b.set_xlabel("flight (stages in order)")
    ax_b.set_ylabel("f_l (s)")
    ax_b.set_yscale("log")  # a failed flight (f_l = failure value) beside values of 20-40 s
    _plain_log_ticks(ax_b.yaxis)
    ax_b.legend(fontsize=8, loc="upper right")
    ax_b.grid(alpha=0.3, which="both")
    v = [r for r in validation if int(r["point"]) == p]
    groups = [("defaults", [r for r in v if r["method"] == "default"])]
    for stage in point["stages"]:
        groups.append(("{} result".format(stage["name"]),
                       [r for r in v if r["source_stage"] == stage["name"]]))
    groups = [(name, g) for name, g in groups if g]
    # Every flight as a dot, the median as a bar across (a failed flight's f_l is far above the
    # others, so the median, not the mean, marks the middle).
    for i, (name, g) in enumerate(groups):
        values = sorted(float(r["f_l"]) for r in g)
        jitter = [i + 0.25 * ((k % 7) / 6.0 - 0.5) for k in range(len(values))]
        ax_c.plot(jitter, values, ".", color=cmap(i), ms=6, alpha=0.7)
        med = statistics.median(values)
        ax_c.plot([i - 0.3, i + 0.3], [med, med], color="k", lw=2)
    ax_c.set_xticks(range(len(groups)))
    ax_c.set_xticklabels([name for name, _ in groups], rotation=15, fontsize=8)
    ax_c.set_xlim(-0.6, len(groups) - 0.4)
    ax_c.set_ylabel("f_l of the validation flight (s)")
    if groups and min(float(r["f_l"]) for _, g in groups for r in g) > 0:
        ax_c.set_yscale("log")
        _plain_log_ticks(ax_c.yaxis)
    ax_c.set_title("(C) validation in the {} world;\nbar: median".format(
        point["stages"][-1]["name"]), loc="left", fontsize=11, weight="bold")
    ax_c.grid(alpha=0.3, axis="y", which="both")
    fig.suptitle("{} — {}".format(study["name"], point["label"]), x=0.01, ha="left")
    figure = os.path.join(out_dir or directory, "refinement_{}.png".format(
        "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in point["label"])))
    fig.savefig(figure, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return figure


def plot_bench(csv_path, out=None):
    """Thread scaling (`quadtune bench --csv`): (A) flights/s and re-solves/s as speed-up over
    one thread, each point labelled with its measured rate; (B) parallel efficiency. Ticks sit
    at the thread counts measured."""
    from matplotlib.ticker import FixedLocator, MaxNLocator, PercentFormatter
    rows = read_rows(csv_path)
    threads = [int(r["threads"]) for r in rows]
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(11, 4))
    for key, label, unit, color in (("flights_per_s", "flights", "flights/s", "tab:blue"),
                                    ("resolves_per_s", "re-solves", "re-solves/s",
                                     "tab:orange")):
        vals = [float(r[key]) for r in rows]
        speedup = [v / vals[0] for v in vals]
        ax_a.plot(threads, speedup, "o-", color=color, label=label)
        for t, s_, v in zip(threads, speedup, vals):
            ax_a.annotate("{:.3g} {}".format(v, unit), (t, s_), textcoords="offset points",
                          xytext=(6, -12 if key == "flights_per_s" else 6), fontsize=7,
                          color=color)
        ax_b.plot(threads, [100.0 * v / vals[0] / t for v, t in zip(vals, threads)], "o-",
                  color=color, label=label)
    ax_a.plot(threads, threads, "k:", label="ideal (= threads)")
    ax_a.set_title("(A) speed-up over 1 thread", loc="left")
    ax_a.set_ylabel("speed-up (× one thread)")
    ax_a.yaxis.set_major_locator(MaxNLocator(integer=True, nbins=6))
    ax_a.set_ylim(0, max(threads) * 1.15)
    ax_b.set_title("(B) parallel efficiency", loc="left")
    ax_b.set_ylabel("efficiency (speed-up / threads)")
    ax_b.set_ylim(0, 110)
    ax_b.yaxis.set_major_formatter(PercentFormatter())
    cores = rows[0].get("cores")
    for ax in (ax_a, ax_b):
        ax.xaxis.set_major_locator(FixedLocator(threads))
        ax.set_xlim(min(threads) - 0.5, max(threads) + 0.5)
        ax.set_xlabel("worker threads" + (" (machine: {} cores)".format(cores) if cores else ""))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    out = out or os.path.splitext(csv_path)[0] + ".png"
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return [out]


def plot_scale_model(csv_path, out=None):
    """The scale model of distributed runs (scripts/scale_model.sh): stored evaluations per second
    against MPI ranks (log-log), the ideal line (ranks × the single process's rate) and the
    resident memory per rank."""
    with open(csv_path, newline="") as f:
        rows = sorted(csv.DictReader(f), key=lambda r: int(r["ranks"]))
    ranks = [int(r["ranks"]) for r in rows]
    rate = [float(r["evals_per_s"]) for r in rows]
    ideal = [float(r["ideal_per_s"]) for r in rows]
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(11, 4))
    ax_a.plot(ranks, rate, "o-", color="tab:blue", label="stored evaluations/s (measured)")
    ax_a.plot(ranks, ideal, "k:", label="ideal: ranks × one process's rate")
    for x, y in zip(ranks, rate):
        ax_a.annotate("{:.0f}".format(y), (x, y), textcoords="offset points", xytext=(4, -12),
                      fontsize=7)
    ax_a.set_xscale("log", base=2)
    ax_a.set_yscale("log")
    ax_a.set_xlabel("MPI ranks × 1 thread (sleep planner, on {} cores)".format(
        rows[0].get("cores", "?")))
    ax_a.set_ylabel("stored evaluations per second")
    ax_a.set_title("(A) rank 0's store against ranks")
    measured = [r for r in rows if r.get("rss_rank_mib")]  # a run may lack its memory figures
    ax_b.plot([int(r["ranks"]) for r in measured], [float(r["rss_rank_mib"]) for r in measured],
              "o-", color="tab:green", label="a rank ≠ 0 (median)")
    ax_b.plot([int(r["ranks"]) for r in measured], [float(r["rss_root_mib"]) for r in measured],
              "s-", color="tab:red", label="rank 0")
    ax_b.set_xscale("log", base=2)
    ax_b.set_xlabel("MPI ranks")
    ax_b.set_ylabel("peak resident memory (MiB)")
    ax_b.set_title("(B) memory per rank")
    for ax in (ax_a, ax_b):
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = out or os.path.splitext(csv_path)[0] + ".png"
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


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
    p.add_argument("--out", default=None, help="output folder (default: the run directory)")
    p = sub.add_parser("study", help="figures and tables of a study directory")
    p.add_argument("directory")
    p.add_argument("--out", default=None, help="output folder (default: the study directory)")
    p = sub.add_parser("bench", help="thread-scaling figure of a `quadtune bench --csv` file")
    p.add_argument("csv")
    p.add_argument("--out", default=None)
    p = sub.add_parser("adapt", help="velocity along the path and top-down view of `quadtune adapt`")
    p.add_argument("directory")
    p.add_argument("--out", default=None, help="figure (PNG; default: DIR/adapt.png)")
    p = sub.add_parser("scale-model", help="stored evaluations/s against MPI ranks "
                       "(scripts/scale_model.sh CSV)")
    p.add_argument("csv")
    p.add_argument("--out", default=None)
    p = sub.add_parser("sweep", help="Sobol' index figure of a `quadtune sweep` directory")
    p.add_argument("directory")
    p.add_argument("--out", default=None, help="figure (PNG; default: DIR/sweep.png)")
    args = parser.parse_args(argv)
    if args.what == "scale-model":
        print(plot_scale_model(args.csv, args.out))
        return 0
    if args.what == "sweep":
        print(plot_sweep(args.directory, args.out))
        return 0
    if args.what == "adapt":
        print(plot_adapt(args.directory, args.out))
        return 0
    if args.what == "run":
        for path in plot_run(args.directory, args.out):
            print(path)
    elif args.what == "study":
        for path in plot_study(args.directory, args.out):
            print(path)
    elif args.what == "bench":
        for path in plot_bench(args.csv, args.out):
            print(path)
    elif args.what == "flight":
        print(plot_flight(args.directory, args.out))
    elif args.what == "flights":
        for path in plot_flights(args.directories, args.out):
            print(path)
    return 0


# ---- `adapt`: the changing-environment experiment (`quadtune adapt` output) ----------------------

def _adapt_zone_shading(ax, zones, label=True):
    """Shades the density zones (x-ranges) in alternating greys and labels them with the spacing."""
    for i, z in enumerate(zones):
        ax.axvspan(z["x_min"], z["x_max"], color="0.88" if i % 2 == 0 else "0.95", lw=0, zorder=0)
        if label:
            ax.text(0.5 * (z["x_min"] + z["x_max"]), 0.97, "spacing {:.1f} m".format(z["spacing"]),
                    transform=ax.get_xaxis_transform(), ha="center", va="top", fontsize=9,
                    color="0.25")


def plot_adapt(directory, out=None):
    """DIR/adapt.png: (A) v_des in force and actual speed along the corridor for the adapted flight
    and the fixed-v_des baselines, with every BO trial (v_des proposed at P_s) and the chosen ones;
    (B) top-down view of the layout with the adapted flight coloured by speed."""
    from matplotlib.collections import LineCollection
    with open(os.path.join(directory, "summary.json")) as f:
        summary = json.load(f)
    zones = summary.get("zones", [])
    flights = summary["flights"]
    fig, (ax, ax_top) = plt.subplots(2, 1, figsize=(13, 8.5), gridspec_kw={"height_ratios": [1.3, 1]})
    _adapt_zone_shading(ax, zones)
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:brown"]
    for i, fl in enumerate(flights):
        path = read_csv(os.path.join(directory, fl["directory"], "path.csv"))
        if not path:
            continue
        c = colors[i % len(colors)]
        ls = "-" if fl["adapted"] else "--"
        name = "adapted" if fl["adapted"] else "fixed v_des = {:g}".format(fl["v_des"])
        ax.plot(path["x"], path["speed"], color=c, ls=ls, lw=1.4 if fl["adapted"] else 1.0,
                label=name + ": actual speed")
        ax.step(path["x"], path["v_des"], where="post", color=c, ls=ls, lw=2.2 if fl["adapted"] else 0.8,
                alpha=0.5, label=name + ": desired v_des")
        trials_path = os.path.join(directory, fl["directory"], "trials.csv")
        if fl["adapted"] and os.path.exists(trials_path):
            with open(trials_path, newline="") as f:
                trials = list(csv.DictReader(f))
            ok = [t for t in trials if t["success"] == "1"]
            bad = [t for t in trials if t["success"] != "1"]
            chosen = [t for t in trials if t["chosen"] == "1"]
            ax.scatter([float(t["p_s_x"]) for t in ok], [float(t["v_des"]) for t in ok], s=6,
                       color="0.45", alpha=0.6, zorder=3, label="BO trial at P_s")
            if bad:
                ax.scatter([float(t["p_s_x"]) for t in bad], [float(t["v_des"]) for t in bad], s=10,
                           marker="x", color="0.3", alpha=0.6, zorder=3, label="failed trial")
            ax.scatter([float(t["p_s_x"]) for t in chosen], [float(t["v_des"]) for t in chosen],
                       s=22, marker="D", color=c, edgecolor="k", lw=0.4, zorder=4,
                       label="chosen v_des (executed from P_s)")
    lo, hi = summary.get("v_des_bounds", [1.0, 6.0])
    for v in (lo, hi):
        ax.axhline(v, color="k", lw=0.5, ls=":")
    ax.set_xlabel("distance along the path: corridor x (m)")
    ax.set_ylabel("velocity (m/s)")
    ax.set_ylim(0.0, hi + 1.2)
    ax.set_title("Online v_des adaptation (R = {:g} m, {} BO trials per P_s, seed {})".format(
        summary.get("lookahead", float("nan")), summary.get("trials_per_segment", "?"),
        summary.get("seed", "?")))
    ax.legend(loc="upper left", fontsize=7, ncol=3, bbox_to_anchor=(0.0, 0.90))
    ax.grid(alpha=0.3)

    adapted = next((fl for fl in flights if fl["adapted"]), flights[0])
    adir = os.path.join(directory, adapted["directory"])
    with open(os.path.join(adir, "obstacles.json")) as f:
        obstacles = json.load(f)
    _adapt_zone_shading(ax_top, zones, label=False)
    draw_obstacles(ax_top, obstacles)
    path = read_csv(os.path.join(adir, "path.csv"))
    if path:
        pts = list(zip(path["x"], path["y"]))
        segs = [[pts[k], pts[k + 1]] for k in range(len(pts) - 1)]
        lc = LineCollection(segs, cmap="viridis", linewidths=2.4, zorder=5)
        lc.set_array(path["speed"][:-1])
        ax_top.add_collection(lc)
        cb = fig.colorbar(lc, ax=ax_top, pad=0.01, fraction=0.03)
        cb.set_label("speed (m/s)")
    for z in zones:
        ax_top.axvline(z["x_min"], color="0.5", lw=0.6, ls="--")
    ax_top.set_aspect("equal")
    xs = [z["x_min"] for z in zones] + [z["x_max"] for z in zones]
    if xs:
        ax_top.set_xlim(min(xs) - 1, max(xs) + 1)
        ax.set_xlim(min(xs) - 1, max(xs) + 1)
    ax_top.set_ylim(-5.5, 5.5)
    ax_top.set_xlabel("x (m)")
    ax_top.set_ylabel("y (m)")
    ax_top.set_title("Adapted flight, top-down: t_f = {:.2f} s, collisions {}, emergency stops {}".format(
        adapted["flight_time"], adapted["collisions"], adapted["emergency_stops"]))
    fig.tight_layout()
    out = out or os.path.join(directory, "adapt.png")
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


# ---- `sweep`: Sobol' indices of a parameter sweep (`quadtune sweep` output) ---------------------

_SWEEP_OUTPUT_TITLES = {
    "f_l": "long-term objective f_l = t_f + t_f·n_c + w_e·n_e (s)",
    "t_f": "flight time t_f (s)",
    "n_c": "collisions n_c (count)",
    "n_e": "emergency stops n_e (count)",
    "f_s": "short-term objective f_s (mean over recorded queries)",
}


def plot_sweep(directory, out_path=None):
    """DIR/sweep.png: one panel per output (f_l, its terms, f_s), horizontal bars of the first-order
    S1 and total-effect ST Sobol' index of every parameter with 95% bootstrap whiskers, one colour
    per layout (obstacle density)."""
    import numpy as np
    with open(os.path.join(directory, "indices.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise SystemExit("no rows in " + os.path.join(directory, "indices.csv"))
    outputs, layouts, params = [], [], []
    for r in rows:
        for seq, key in ((outputs, "output"), (layouts, "layout"), (params, "parameter")):
            if r[key] not in seq:
                seq.append(r[key])
    kinds = {r["parameter"]: r["kind"] for r in rows}
    spacing = {r["layout"]: r["spacing"] for r in rows}
    spearman = {r["layout"]: r["spearman_fs_fl"] for r in rows}
    table = {(r["layout"], r["output"], r["parameter"]): r for r in rows}

    def num(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return float("nan")

    def layout_name(lay):
        sp = num(spacing.get(lay))
        return "{} ({:g} m spacing)".format(lay, sp) if math.isfinite(sp) else lay

    ncols = min(3, len(outputs))
    nrows = (len(outputs) + ncols - 1) // ncols
    height = (0.5 * len(params) * max(1, len(layouts)) + 1.6) * nrows
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, height), squeeze=False)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    y = np.arange(len(params))
    band = 0.8 / max(1, len(layouts))
    for k, out in enumerate(outputs):
        ax = axes[k // ncols][k % ncols]
        any_value = False
        for g, lay in enumerate(layouts):
            c = colors[g % len(colors)]
            for j, (idx, alpha, hatch) in enumerate((("S1", 0.9, None), ("ST", 0.35, "//"))):
                vals, lo, hi = [], [], []
                for p in params:
                    r = table.get((lay, out, p), {})
                    v = num(r.get(idx))
                    vals.append(v if math.isfinite(v) else 0.0)
                    any_value = any_value or math.isfinite(v)
                    lo.append(max(0.0, v - num(r.get(idx + "_lo"))) if math.isfinite(v) else 0.0)
                    hi.append(max(0.0, num(r.get(idx + "_hi")) - v) if math.isfinite(v) else 0.0)
                offset = -0.4 + band * g + band * (0.25 + 0.5 * j)
                ax.barh(y + offset, vals, height=band * 0.5, color=c, alpha=alpha, hatch=hatch,
                        edgecolor=c, xerr=[lo, hi], error_kw={"elinewidth": 0.8, "capsize": 2},
                        label="{}: {}".format(idx, layout_name(lay)) if k == 0 else None)
                for yy, v in zip(y + offset, vals):
                    if v > 1.2 or v < -0.2:  # beyond the axis: print the estimate at the edge
                        ax.text(1.19 if v > 0 else -0.19, yy, "{:.2g}".format(v), fontsize=7,
                                ha="right" if v > 0 else "left", va="center", color="k")
        ax.set_yticks(y)
        ax.set_yticklabels(["{} ({})".format(p, "θ_s" if kinds.get(p) == "short" else "θ_l")
                            for p in params])
        ax.invert_yaxis()
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_xlim(-0.2, 1.2)
        ax.set_xlabel("Sobol' index (share of output variance, dimensionless)")
        ax.set_ylabel("parameter")
        ax.set_title(_SWEEP_OUTPUT_TITLES.get(out, out), fontsize=10)
        ax.grid(axis="x", alpha=0.3)
        if not any_value:
            ax.text(0.5, 0.5, "constant over the design: no indices", transform=ax.transAxes,
                    ha="center", va="center", color="0.3")
    for k in range(len(outputs), nrows * ncols):
        axes[k // ncols][k % ncols].axis("off")
    rho = "; ".join("{}: {}".format(lay, "{:.2f}".format(num(spearman[lay]))
                                     if math.isfinite(num(spearman[lay])) else "n/a")
                    for lay in layouts)
    n = rows[0].get("N", "?")
    maps = rows[0].get("maps", "?")
    fig.suptitle("Parameter importance: S1 (solid) and ST (hatched), 95% bootstrap intervals; "
                 "N = {}, {} maps per point. Spearman ρ(f_s, f_l): {}".format(n, maps, rho),
                 fontsize=10)
    fig.legend(loc="lower center", ncol=min(4, 2 * len(layouts)), fontsize=8)
    fig.tight_layout(rect=(0, 0.06, 1, 0.95))
    out_png = out_path or os.path.join(directory, "sweep.png")
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    return out_png


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
