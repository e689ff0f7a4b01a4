#!/usr/bin/python3
"""quadtune's tuners beside what a researcher would pick instead, on the same held-out maps.

For one experiment (a planner at one density) and its finished `quadtune run` store:
  1. Optuna's TPE sampler and irace tune the experiment's parameter box, `--repeats` times with
     the experiment's flight budget (scripts/peers/optuna_tpe.py, irace_tune.R); candidate k of
     repeat r flies tuning map k of repeat r, the maps quadtune's methods fly;
  2. an oracle grid over v_des × h_pl (the other parameters at their defaults) flies the held-out
     maps; its best point is the "oracle";
  3. every recommended point (quadtune's trials from the store's validation rows, the peers', the
     oracle's) is compared on the held-out maps, with the map and flight seeds of `quadtune run`'s
     validation, so every flight pairs map by map.
Writes (appending rows for this planner and spacing) OUT/heldout.csv, one row per held-out flight,
OUT/summary.csv and OUT/summary.md (mean f_l, collision-free rate, share of the oracle's gain
captured, trials handing back the defaults, paired Wilcoxon test against bo_pso), and
OUT/heldout_<planner>_<forest>_<spacing>.png.

    scripts/peers/peers.py experiments/benchmark.yaml --store results/benchmark \
        --planner ipopt --spacing 1.3 --repeats 5 --out docs/results/peers
"""
import argparse
import csv
import itertools
import json
import math
import os
import sqlite3
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import peerlib

HERE = os.path.dirname(os.path.abspath(__file__))
COLUMNS = ["planner", "forest", "spacing", "tuner", "repeat", "map_index", "map_seed", "f_l", "collisions",
           "emergency_stops", "completed", "t_f", "params"]
TUNERS = ["default", "oracle", "bo_pso", "bo", "pso", "random", "irace", "optuna_tpe"]


def store_flights(store):
    """Held-out flights of a `quadtune run` store: (tuner, repeat, rows) per recommended point."""
    path = os.path.join(store, "results.sqlite") if os.path.isdir(store) else store
    con = sqlite3.connect("file:{}?mode=ro".format(path), uri=True)
    repeats = {tid: rep for tid, rep in con.execute("SELECT id, repeat FROM trial")}
    out = {}
    for tid, method, iteration, value, terms, params, map_seed in con.execute(
            "SELECT trial_id, method, iteration, value, terms, params, map_seed FROM evaluation "
            "WHERE kind = 'validation' ORDER BY trial_id, iteration"):
        if method == "default" and tid != 0:
            continue  # the defaults are flown once, under trial id 0
        t = json.loads(terms) if terms else {}
        key = ("default", 0) if tid == 0 else (method, repeats[tid])
        out.setdefault(key, []).append(dict(
            map_index=iteration, map_seed=map_seed, f_l=value, collisions=t.get("n_c", 0.0),
            emergency_stops=t.get("n_e", 0.0), completed=t.get("completed", 0.0),
            t_f=t.get("t_f", float("nan")), params=params))
    con.close()
    return out


def held_out(experiment, point, maps, sets):
    rows = peerlib.evaluate(experiment, point, "heldout", 0, count=maps, threads=2, sets=sets)
    return [dict(map_index=int(r["index"]), map_seed=r["map_seed"], f_l=r["value"],
                 collisions=r.get("n_c", 0.0), emergency_stops=r.get("n_e", 0.0),
                 completed=r.get("completed", 0.0), t_f=r.get("t_f", float("nan")),
                 params=json.dumps(point, sort_keys=True)) for r in rows]


def run_optuna(experiment, repeat, budget, sets, out_dir):
    out = os.path.join(out_dir, "optuna_tpe_r{}.json".format(repeat))
    cmd = ["/usr/bin/python3", os.path.join(HERE, "optuna_tpe.py"), experiment, "--repeat",
           str(repeat), "--budget", str(budget), "--out", out] + \
        [x for s in sets for x in ("--set", s)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(out) as f:
        return json.load(f)


def run_irace(experiment, repeat, budget, box_file, sets, out_dir):
    out = os.path.join(out_dir, "irace_r{}.json".format(repeat))
    cmd = ["Rscript", os.path.join(HERE, "irace_tune.R"), experiment, str(repeat), str(budget),
           str(2000 + repeat), out, box_file] + list(sets)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL,
                   env=dict(os.environ, QUADTUNE=peerlib.QUADTUNE))
    with open(out) as f:
        return json.load(f)


def peers(experiment, repeats, budget, sets, work):
    """Recommended points of Optuna TPE and irace, repeat by repeat (two at a time)."""
    box_file = os.path.join(work, "box.tsv")
    with open(box_file, "w") as f:
        f.write("name\tlower\tupper\tlog\tinteger\n")
        for p in peerlib.box(experiment):
            f.write("{}\t{!r}\t{!r}\t{:d}\t{:d}\n".format(p["name"], p["lower"], p["upper"],
                                                           p["log"], p["integer"]))
    jobs = []
    with ThreadPoolExecutor(max_workers=2) as pool:
        for r in range(repeats):
            jobs.append(("optuna_tpe", r, pool.submit(run_optuna, experiment, r, budget, sets,
                                                      work)))
            jobs.append(("irace", r, pool.submit(run_irace, experiment, r, budget, box_file,
                                                 sets, work)))
        return [(tuner, r, job.result()["params"]) for tuner, r, job in jobs]


def grid_axes(specs, default):
    """The oracle grid's axes from `--grid NAME=V1,V2,…` options (`default` when none), as
    [(name, [values])]; the grid is every combination of the axes' values."""
    axes = []
    for spec in specs or default:
        name, sep, values = spec.partition("=")
        if not sep or not name or not values:
            raise SystemExit("--grid {!r}: expected NAME=V1,V2,… (e.g. v_des=2,3,4)".format(spec))
        try:
            axes.append((name, [float(v) for v in values.split(",")]))
        except ValueError:
            raise SystemExit("--grid {!r}: the values must be numbers".format(spec))
    return axes


def oracle(experiment, maps, sets, axes):
    """Every grid point's held-out flights (the other parameters at their defaults); returns
    (best point, its rows, table of (value per axis…, mean f_l))."""
    table = []
    best = None
    for values in itertools.product(*(v for _, v in axes)):
        point = {name: value for (name, _), value in zip(axes, values)}
        rows = held_out(experiment, point, maps, sets)
        mean = statistics.fmean(r["f_l"] for r in rows)
        table.append(tuple(values) + (mean,))
        if best is None or mean < best[2]:
            best = (point, rows, mean)
    return best[0], best[1], table


def write_grid(path, axes, table):
    """The oracle grid's table as CSV: one column per axis, then mean_f_l."""
    with open(path, "w") as f:
        f.write(",".join([name for name, _ in axes] + ["mean_f_l"]) + "\n")
        for row in table:
            f.write(",".join(str(x) for x in row) + "\n")


def signed_rank_p(a, b):
    """Two-sided Wilcoxon signed-rank p of paired per-map means (scipy), nan when undefined."""
    try:
        from scipy.stats import wilcoxon
        if all(x == y for x, y in zip(a, b)):
            return float("nan")
        return float(wilcoxon(a, b).pvalue)
    except Exception:  # too few pairs
        return float("nan")


def summarise(rows, defaults_point):
    """Per tuner: flights, mean f_l, collision-free share, completion, repeats handing back the
    defaults, share of the oracle's gain, p against bo_pso (per-map means over repeats)."""
    by = {}
    for r in rows:
        by.setdefault(r["tuner"], []).append(r)

    def per_map(tuner):
        maps = {}
        for r in by.get(tuner, []):
            maps.setdefault(r["map_index"], []).append(r["f_l"])
        return {k: statistics.fmean(v) for k, v in maps.items()}

    d = statistics.fmean(r["f_l"] for r in by["default"])
    o = statistics.fmean(r["f_l"] for r in by["oracle"])
    ref = per_map("bo_pso") if "bo_pso" in by else None
    out = []
    for tuner in TUNERS:
        if tuner not in by:
            continue
        fl = by[tuner]
        mean = statistics.fmean(r["f_l"] for r in fl)
        points = {}
        for r in fl:
            points[r["repeat"]] = r["params"]
        handed_default = sum(1 for p in points.values() if same_point(p, defaults_point))
        p = float("nan")
        if ref is not None and tuner != "bo_pso":
            mine = per_map(tuner)
            keys = sorted(set(mine) & set(ref))
            p = signed_rank_p([mine[k] for k in keys], [ref[k] for k in keys])
        out.append(dict(tuner=tuner, repeats=len(points), flights=len(fl), mean_f_l=mean,
                        collision_free=sum(1 for r in fl if r["collisions"] == 0 and
                                           r["completed"] == 1) / len(fl),
                        completed=sum(1 for r in fl if r["completed"] == 1) / len(fl),
                        gain_share=(d - mean) / (d - o) if d > o else float("nan"),
                        defaults_handed_back=handed_default if tuner not in ("default", "oracle")
                        else "", p_vs_bo_pso=p))
    return out


def same_point(params_json, defaults):
    p = json.loads(params_json)
    return all(abs(p.get(k, v) - v) <= 1e-9 * max(1.0, abs(v)) for k, v in defaults.items())


def figure(summary, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 0.45 * len(summary) + 1.4))
    order = sorted(summary, key=lambda s: -s["mean_f_l"])
    ys = range(len(order))
    ax.barh(list(ys), [s["mean_f_l"] for s in order],
            color=["0.55" if s["tuner"] in ("default", "oracle") else "tab:blue" for s in order])
    ax.set_yticks(list(ys))
    ax.set_yticklabels(["{} ({:.0%} of the oracle's gain)".format(s["tuner"], s["gain_share"])
                        if s["tuner"] not in ("default", "oracle") and not
                        math.isnan(s["gain_share"]) else s["tuner"] for s in order], fontsize=8)
    ax.set_xlabel("mean f_l on the held-out maps (s), all repeats")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, axis="x")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def replace_rows(path, fields, planner, forest, spacing, rows):
    """Rewrites the CSV at `path`: its rows of other planners, forests or spacings, then `rows`."""
    kept = []
    if os.path.exists(path):
        with open(path) as f:
            kept = [r for r in csv.DictReader(f)
                    if not (r["planner"] == planner and r["forest"] == forest and
                            float(r["spacing"]) == spacing)]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in kept + rows:
            w.writerow(r)


def write(out_dir, planner, forest, spacing, rows, summary):
    """Rows of one planner, forest family (`thin`: forest_thin_*.yaml; `free_gap`: the density
    study's forest_*.yaml) and spacing into OUT/heldout.csv, summary.csv and summary.md."""
    os.makedirs(out_dir, exist_ok=True)
    rows = [dict(r, forest=forest) for r in rows]
    replace_rows(os.path.join(out_dir, "heldout.csv"), COLUMNS, planner, forest, spacing, rows)
    spath = os.path.join(out_dir, "summary.csv")
    fields = ["planner", "forest", "spacing", "tuner", "repeats", "flights", "mean_f_l", "collision_free",
              "completed", "gain_share", "defaults_handed_back", "p_vs_bo_pso"]
    replace_rows(spath, fields, planner, forest, spacing,
                 [dict(s, planner=planner, forest=forest, spacing=spacing) for s in summary])
    with open(spath) as f:
        everything = list(csv.DictReader(f))
    with open(os.path.join(out_dir, "summary.md"), "w") as f:
        f.write("| planner | forest | spacing (m) | tuner | repeats | held-out flights | mean f_l | "
                "collision-free | completed | share of the oracle's gain | defaults handed back "
                "| p vs bo_pso |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n")
        for s in everything:
            def num(key, fmt):
                v = s[key]
                try:
                    x = float(v)
                    return "–" if math.isnan(x) else fmt.format(x)
                except ValueError:
                    return v or "–"
            f.write("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n".format(
                s["planner"], s["forest"], s["spacing"], s["tuner"], s["repeats"], s["flights"],
                num("mean_f_l", "{:.2f}"), num("collision_free", "{:.0%}"),
                num("completed", "{:.0%}"), num("gain_share", "{:.0%}"),
                s["defaults_handed_back"] or "–", num("p_vs_bo_pso", "{:.3f}")))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("experiment")
    ap.add_argument("--store", required=True, help="the experiment's finished `quadtune run` "
                    "directory (or results.sqlite): its trials' held-out rows")
    ap.add_argument("--planner", required=True)
    ap.add_argument("--spacing", type=float, required=True)
    ap.add_argument("--forest", default="thin", help="forest family label of the rows: thin "
                    "(forest_thin_*.yaml, the benchmark's) or free_gap (forest_*.yaml)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--budget", type=int, default=None, help="flights (default: the experiment's)")
    ap.add_argument("--maps", type=int, default=None,
                    help="held-out maps (default: the experiment's validation.maps)")
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE for the experiment")
    ap.add_argument("--grid", action="append", metavar="NAME=V1,V2,…",
                    help="an axis of the oracle grid (default: v_des=1.5,2,…,5 and h_pl=6,7.5,9)")
    ap.add_argument("--no-peers", action="store_true", help="the oracle and the store only")
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    import yaml
    with open(a.experiment) as f:
        doc = yaml.safe_load(f)
    budget = a.budget or int(doc["budget"]["flights"])
    maps = a.maps or int(doc.get("validation", {}).get("maps", 20))
    work = os.path.join(a.out, "work_{}_{}".format(a.planner, a.spacing))
    os.makedirs(work, exist_ok=True)
    defaults = {p["name"]: p["default"] for p in peerlib.box(a.experiment)}
    rows = []

    def add(tuner, repeat, flights):
        for r in flights:
            rows.append(dict(r, planner=a.planner, spacing=a.spacing, tuner=tuner, repeat=repeat))

    for (tuner, repeat), flights in sorted(store_flights(a.store).items()):
        add(tuner, repeat, flights)
    print("store: {} held-out flights".format(len(rows)), flush=True)
    axes = grid_axes(a.grid, ["v_des=1.5,2,2.5,3,3.5,4,4.5,5", "h_pl=6,7.5,9"])
    best, best_rows, grid = oracle(a.experiment, maps, a.set, axes)
    add("oracle", 0, best_rows)
    write_grid(os.path.join(work, "oracle_grid.csv"), axes, grid)
    print("oracle: {} (mean f_l {:.2f})".format(best, statistics.fmean(
        r["f_l"] for r in best_rows)), flush=True)
    if not a.no_peers:
        for tuner, repeat, point in peers(a.experiment, a.repeats, budget, a.set, work):
            add(tuner, repeat, held_out(a.experiment, point, maps, a.set))
            print("{} repeat {}: {}".format(tuner, repeat, point), flush=True)
    summary = summarise(rows, defaults)
    write(a.out, a.planner, a.forest, a.spacing, rows, summary)
    figure(summary, os.path.join(a.out, "heldout_{}_{}_{}.png".format(a.planner, a.forest, a.spacing)),
           "{} planner, {} m forests: held-out mean f_l per tuner".format(a.planner, a.spacing))
    for s in summary:
        print("{tuner:>11}: mean f_l {mean_f_l:.2f}, collision-free {collision_free:.0%}, "
              "gain share {gain_share:.0%}".format(**s))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
