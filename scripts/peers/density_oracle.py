#!/usr/bin/python3
"""A density study's tuned points beside an oracle grid flown on the same held-out maps.

For a finished `quadtune study` over `planner.layout_file` (experiments/density_study*.yaml),
each sweep point's oracle is the best point of a grid (by default v_des × h_pl; `--grid
NAME=V1,V2,…` per axis, the other parameters at their defaults) flown through `quadtune evaluate`
on the study's held-out maps, with the map and flight seeds of its validation, so every flight
pairs map by map with the study's. Writes, replacing
the rows of this planner and these spacings, OUT/heldout.csv, OUT/summary.csv and
OUT/summary.md (as scripts/peers/peers.py does: mean f_l, collision-free rate, share of the
oracle's gain, trials handing back the defaults), OUT/heldout_<planner>_free_gap_<spacing>.png and
OUT/oracle_grid_<planner>_free_gap_<spacing>.csv, all under the forest label `free_gap`.
With `--peers LABEL`, Optuna's TPE sampler and irace also tune that sweep point `--repeats`
times with a study trial's flight budget (scripts/peers/peers.py), and their recommended points
fly the same held-out maps.

    scripts/peers/density_oracle.py experiments/density_study.yaml --study results/density \
        --planner ipopt --out docs/results/peers [--peers 1.3 --repeats 5]
"""
import argparse
import csv
import json
import os
import statistics
import sys

import yaml

import peerlib
import peers


def flatten(prefix, value):
    """`{a: {b: 1}}` under `planner` as ["planner.a.b=1"] (YAML scalars as written by yaml)."""
    if isinstance(value, dict):
        out = []
        for k, v in value.items():
            out += flatten("{}.{}".format(prefix, k), v)
        return out
    text = "true" if value is True else "false" if value is False else str(value)
    return ["{}={}".format(prefix, text)]


def study_points(study_file):
    """(experiment file, the sets shared by every point, [(label, sets of the point)])."""
    with open(study_file) as f:
        doc = yaml.safe_load(f)
    experiment = os.path.join(os.path.dirname(study_file), doc["experiment"])
    shared = flatten("planner", doc.get("override", {}).get("planner", {}))
    sweep = doc["sweep"]
    labels = sweep.get("labels", [str(v) for v in sweep["values"]])
    points = [(label, ["{}={}".format(sweep["key"], value)])
              for label, value in zip(labels, sweep["values"])]
    return experiment, shared, points


def study_budget(study_file, experiment):
    """Flights of one study trial: the study's `override.budget.flights`, else the experiment's."""
    with open(study_file) as f:
        doc = yaml.safe_load(f)
    flights = doc.get("override", {}).get("budget", {}).get("flights")
    if flights is None:
        with open(experiment) as f:
            flights = yaml.safe_load(f)["budget"]["flights"]
    return int(flights)


def study_rows(study_dir, label, planner):
    """The study's held-out flights of sweep point `label`, as peers.py rows."""
    rows = []
    with open(os.path.join(study_dir, "validation.csv")) as f:
        for r in csv.DictReader(f):
            if r["label"] != label:
                continue
            rows.append(dict(planner=planner, spacing=float(label), tuner=r["method"],
                             repeat=int(r["repeat"]), map_index=int(r["flight"]),
                             map_seed=int(r["map_seed"]), f_l=float(r["f_l"]),
                             collisions=float(r["collisions"]),
                             emergency_stops=float(r["emergency_stops"]),
                             completed=float(r["completed"]), t_f=float(r["flight_time"]),
                             params=r["params"]))
    return rows


def cached(path, key, compute):
    """compute(), kept as JSON in `path` with `key` and reused while the key is the same (the
    flights and the tuners are seeded, so the same key gives the same result)."""
    if os.path.exists(path):
        with open(path) as f:
            stored = json.load(f)
        if stored.get("key") == json.loads(json.dumps(key)) and "value" in stored:
            return stored["value"]
    value = compute()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(dict(key=key, value=value), f)
    return value


def cached_oracle(a, axes, experiment, maps, sets, label):
    """peers.oracle, kept in WORK/<planner>_<label>/oracle.json."""
    path = os.path.join(a.work, "{}_{}".format(a.planner, label), "oracle.json")
    key = dict(experiment=experiment, sets=sets, maps=maps, grid=axes)
    best, rows, grid = cached(path, key, lambda: list(peers.oracle(experiment, maps, sets, axes)))
    return best, rows, [tuple(g) for g in grid]


def cached_peers(a, experiment, budget, sets, label):
    """peers.peers, its points kept in WORK/<planner>_<label>/peers/points.json."""
    work = os.path.join(a.work, "{}_{}".format(a.planner, label), "peers")
    key = dict(experiment=experiment, sets=sets, budget=budget, repeats=a.repeats)
    os.makedirs(work, exist_ok=True)  # peers.peers writes its box and each tuner's output there
    points = cached(os.path.join(work, "points.json"), key,
                    lambda: peers.peers(experiment, a.repeats, budget, sets, work))
    return [tuple(p) for p in points]


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study_file")
    ap.add_argument("--study", required=True, help="the finished `quadtune study` directory")
    ap.add_argument("--planner", required=True)
    ap.add_argument("--grid", action="append", metavar="NAME=V1,V2,…",
                    help="an axis of the oracle grid (default: v_des=2,2.5,…,5 and h_pl=6,7.5,9)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--work", default="results/peers_oracle",
                    help="where the oracle grids' flights are kept for reuse")
    ap.add_argument("--peers", action="append", default=[], metavar="LABEL",
                    help="a sweep point where Optuna TPE and irace tune too (repeatable)")
    ap.add_argument("--repeats", type=int, default=5, help="repeats of each peer with --peers")
    a = ap.parse_args(argv)
    axes = peers.grid_axes(a.grid, ["v_des=2,2.5,3,3.5,4,4.5,5", "h_pl=6,7.5,9"])
    experiment, shared, points = study_points(a.study_file)
    defaults = {p["name"]: p["default"] for p in peerlib.box(experiment)}
    budget = study_budget(a.study_file, experiment) if a.peers else None
    for label, sets in points:
        rows = study_rows(a.study, label, a.planner)
        maps = len({r["map_index"] for r in rows})
        best, best_rows, grid = cached_oracle(a, axes, experiment, maps, shared + sets, label)
        spacing = float(label)
        rows += [dict(r, planner=a.planner, spacing=spacing, tuner="oracle", repeat=0)
                 for r in best_rows]
        if label in a.peers:
            for tuner, repeat, point in cached_peers(a, experiment, budget, shared + sets, label):
                rows += [dict(r, planner=a.planner, spacing=spacing, tuner=tuner, repeat=repeat)
                         for r in peers.held_out(experiment, point, maps, shared + sets)]
                print("{} m: {} repeat {}: {}".format(label, tuner, repeat, point), flush=True)
        os.makedirs(a.out, exist_ok=True)
        peers.write_grid(os.path.join(a.out, "oracle_grid_{}_free_gap_{}.csv".format(
            a.planner, label)), axes, grid)
        summary = peers.summarise(rows, defaults)
        peers.write(a.out, a.planner, "free_gap", spacing, rows, summary)
        peers.figure(summary, os.path.join(a.out, "heldout_{}_free_gap_{}.png".format(a.planner, label)),
                     "{} planner, {} m forests: held-out mean f_l".format(a.planner, label))
        print("{} m: oracle {} (mean f_l {:.2f})".format(
            label, best, statistics.fmean(r["f_l"] for r in best_rows)), flush=True)
        for s in summary:
            print("  {tuner:>8}: mean f_l {mean_f_l:.2f}, collision-free {collision_free:.0%}, "
                  "gain share {gain_share:.0%}, defaults handed back {defaults_handed_back}"
                  .format(**s), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
