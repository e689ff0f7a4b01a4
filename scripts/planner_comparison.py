#!/usr/bin/env python3
"""The two planners side by side: the benchmark and the density study, one run per planner.

usage: planner_comparison.py --benchmark NAME=RUN_DIR ... --density NAME=STUDY_DIR ...
                             [--out DIR]

RUN_DIR is a `quadtune run` directory (its results.sqlite and validation.csv), STUDY_DIR a `quadtune study`
directory (its validation.csv); NAME labels the planner. Writes DIR/comparison.png:

  (A) best f_l so far against flights in tuning, BO+PSO, mean over the repeats, with the mean
      of the default flights as a dashed line;
  (B) held-out validation of the benchmark: mean f_l with its 95% confidence interval per
      method, failures included at the failure value (the run's validation.csv);
  (C) held-out flight time against obstacle spacing in the density study, defaults and BO+PSO's
      recommended points (completed flights; mean ± 1.96 standard errors);

and DIR/comparison.md with the same numbers as tables. Needs Debian's python3-matplotlib.

    python3 scripts/planner_comparison.py \\
        --benchmark ipopt=results/full/benchmark ego=results/full/benchmark_ego \\
        --density ipopt=results/full/density ego=results/full/density_ego \\
        --out docs/results/planners
"""
import argparse
import collections
import csv
import math
import pathlib
import statistics
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "experiments" / "python"))
import quadtune  # noqa: E402  (the project's store reader)

METHODS = ["default", "random", "pso", "bo", "bo_pso"]
LABELS = {"default": "Default", "random": "Random", "pso": "PSO only", "bo": "BO only",
          "bo_pso": "BO+PSO"}
COLOURS = ["#1b6ca8", "#d1495b", "#2e8b57", "#8a5a9e"]


def named_dirs(pairs, option):
    out = {}
    for pair in pairs:
        name, sep, path = pair.partition("=")
        if not sep or not name or not path:
            sys.exit(f"planner_comparison.py: {option} {pair}: expected NAME=DIR")
        if not pathlib.Path(path).is_dir():
            sys.exit(f"planner_comparison.py: {option} {pair}: {path} is not a directory")
        out[name] = pathlib.Path(path)
    return out


def interval(values):
    """(mean, half-width of the normal 95% interval: 1.96 standard errors) of `values`."""
    m = statistics.mean(values)
    if len(values) < 2:
        return m, 0.0
    return m, 1.96 * statistics.stdev(values) / math.sqrt(len(values))


def best_so_far(long_rows, method):
    """Mean over repeats of the best f_l after each flight of `method`'s trials."""
    trials = collections.defaultdict(list)
    for r in long_rows:
        if r["method"] == method:
            trials[r["repeat"]].append((r["iteration"], r["index"], r["value"]))
    curves = []
    for flights in trials.values():
        flights.sort()
        best, curve = math.inf, []
        for _, _, value in flights:
            best = min(best, value)
            curve.append(best)
        curves.append(curve)
    if not curves:
        return []
    n = min(len(c) for c in curves)
    return [statistics.mean(c[k] for c in curves) for k in range(n)]


def benchmark_numbers(run):
    rows = quadtune.rows(str(run))
    held_out = {}  # the run's own held-out table (validation.csv, written by quadtune)
    with open(run / "validation.csv", newline="") as f:
        for row in csv.DictReader(f):
            held_out[row["method"]] = ((float(row["mean"]), float(row["ci"])),
                                       int(row["collision_free"]), int(row["flights"]))
    defaults = [r["value"] for r in rows["long"] if r["method"] == "default"]
    curve = best_so_far(rows["long"], "bo_pso")
    return {"curve": curve, "default_mean": statistics.mean(defaults) if defaults else math.nan,
            "held_out": held_out}


def density_numbers(study):
    cells = collections.defaultdict(list)
    with open(study / "validation.csv", newline="") as f:
        for row in csv.DictReader(f):
            if row["completed"] == "1":
                cells[(row["label"], row["method"])].append(float(row["flight_time"]))
    out = {}
    for (label, method), times in cells.items():
        out.setdefault(label, {})[method] = interval(times) + (len(times),)
    return out


def figure(bench, density, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13.5, 4.2), constrained_layout=True)
    names = sorted(set(bench) | set(density))
    colour = {n: COLOURS[i % len(COLOURS)] for i, n in enumerate(names)}

    ax = axes[0]
    for name, b in bench.items():
        flights = range(1, len(b["curve"]) + 1)
        ax.plot(flights, b["curve"], color=colour[name], label=f"{name}: BO+PSO")
        ax.axhline(b["default_mean"], color=colour[name], linestyle="--", linewidth=1,
                   label=f"{name}: defaults")
    ax.set_xlabel("flights")
    ax.set_ylabel("best f_l so far (s), mean over repeats")
    ax.set_title("(A) tuning at 1.3 m", loc="left")
    ax.legend(frameon=False, fontsize=8)

    ax = axes[1]
    width = 0.8 / max(1, len(bench))
    for i, (name, b) in enumerate(bench.items()):
        xs, ms, hs = [], [], []
        for k, method in enumerate(METHODS):
            if method in b["held_out"]:
                (m, h), _, _ = b["held_out"][method]
                xs.append(k + (i - (len(bench) - 1) / 2) * width)
                ms.append(m)
                hs.append(h)
        ax.errorbar(xs, ms, yerr=hs, fmt="o", color=colour[name], capsize=3, label=name)
    ax.set_xticks(range(len(METHODS)), [LABELS[m] for m in METHODS], fontsize=8)
    ax.set_ylabel("held-out f_l (s), mean ± 95% interval")
    ax.set_title("(B) held-out maps, benchmark", loc="left")
    ax.legend(frameon=False, fontsize=8)

    ax = axes[2]
    for name, d in density.items():
        labels = sorted(d, key=float, reverse=True)
        spacing = [float(s) for s in labels]
        for method, style in (("default", "--"), ("bo_pso", "-")):
            points = [(s, d[l][method]) for s, l in zip(spacing, labels) if method in d[l]]
            if not points:
                continue
            ax.errorbar([p[0] for p in points], [p[1][0] for p in points],
                        yerr=[p[1][1] for p in points], color=colour[name], linestyle=style,
                        marker="o", capsize=3, label=f"{name}: {LABELS[method]}")
    ax.invert_xaxis()
    ax.set_xlabel("obstacle spacing (m), denser →")
    ax.set_ylabel("held-out flight time (s), completed flights")
    ax.set_title("(C) flight time against spacing", loc="left")
    ax.legend(frameon=False, fontsize=8)
    fig.savefig(path, dpi=150)


def tables(bench, density):
    names = list(bench) or list(density)
    lines = ["## Benchmark (1.3 m)", "",
             "| | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    row = [f"{bench[n]['curve'][-1]:.2f}" if bench.get(n, {}).get("curve") else "–" for n in names]
    lines.append("| BO+PSO best f_l after the last flight (mean over repeats) | " +
                 " | ".join(row) + " |")
    row = [f"{bench[n]['default_mean']:.2f}" if n in bench else "–" for n in names]
    lines.append("| defaults, mean f_l of the default flights | " + " | ".join(row) + " |")
    for method in METHODS:
        cells = []
        for n in names:
            h = bench.get(n, {}).get("held_out", {}).get(method)
            cells.append(f"{h[0][0]:.2f} ± {h[0][1]:.2f}, {h[1]}/{h[2]} collision-free"
                         if h else "–")
        lines.append(f"| held-out f_l, {LABELS[method]} | " + " | ".join(cells) + " |")
    lines += ["", "## Density study: held-out flight time (s, completed flights, mean ± 95%)", "",
              "| spacing (m) | " + " | ".join(f"{n}: defaults | {n}: BO+PSO" for n in names) +
              " |", "|---|" + "---|---|" * len(names)]
    labels = sorted({l for d in density.values() for l in d}, key=float, reverse=True)
    for label in labels:
        cells = []
        for n in names:
            for method in ("default", "bo_pso"):
                c = density.get(n, {}).get(label, {}).get(method)
                cells.append(f"{c[0]:.2f} ± {c[1]:.2f} (n={c[2]})" if c else "–")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--benchmark", nargs="+", default=[], metavar="NAME=RUN_DIR")
    ap.add_argument("--density", nargs="+", default=[], metavar="NAME=STUDY_DIR")
    ap.add_argument("--out", default="results/planners")
    args = ap.parse_args()
    if not args.benchmark and not args.density:
        sys.exit("planner_comparison.py: give --benchmark and/or --density")
    bench = {n: benchmark_numbers(p) for n, p in named_dirs(args.benchmark, "--benchmark").items()}
    density = {n: density_numbers(p) for n, p in named_dirs(args.density, "--density").items()}
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    figure(bench, density, out / "comparison.png")
    (out / "comparison.md").write_text(tables(bench, density))
    print((out / "comparison.md").read_text())


if __name__ == "__main__":
    main()
