#!/usr/bin/env python3
"""Collisions, clearance and flight time against the desired speed v_des, per obstacle spacing
and planner.

usage: speed_table.py [--quadtune BIN] [--planners P ...] [--seeds FIRST LAST] [--speeds V ...]
                      [--spacings S ...] [--jobs J] [--out DIR]

Flies a go-and-return mission with every planner parameter at its default except v_des, on map
seeds FIRST..LAST of the thin forests (assets/layouts/forest_thin_S.yaml), with each planner P
(default: ipopt):

    quadtune fly --planner P --layout-options forest_thin_S.yaml --seed N --set v_des=V --no-plot

and writes DIR/speed.md (a Markdown table: per planner, spacing and v_des, completed flights,
flights free of collisions, the collision and emergency-stop counts, mean flight time and
f_l = t_f + t_f·n_c + 5·n_e, the share of flights keeping at least 5 cm
from every obstacle and the 10% quantile of the smallest clearance) and DIR/speed.csv (one row
per flight). Python 3 standard library and the quadtune binary only.
"""
import argparse
import concurrent.futures
import csv
import json
import pathlib
import statistics
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIELDS = ["planner", "spacing", "v_des", "seed", "status", "flight_time", "collisions", "emergency_stops",
          "min_clearance", "f_l"]
W_E = 5.0         # objective.long_term.w_e of the paper experiments
CLEARANCE = 0.05  # recommend.clearance of the paper experiments (m)


def fly(quadtune, planner, spacing, speed, seed, work):
    out = pathlib.Path(work) / f"{planner}_s{spacing}_v{speed}_{seed}"
    forest = ROOT / "assets" / "layouts" / ("forest_thin_" + f"{float(spacing):.1f}".replace(".", "p") + ".yaml")
    cmd = [str(quadtune), "fly", "--planner", planner, "--layout-options", str(forest), "--seed", str(seed),
           "--set", f"v_des={speed}", "--no-plot", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    summary = out / "summary.json"
    if not summary.exists():
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    s = json.loads(summary.read_text())
    t_f = s["flight_time"]
    return {"planner": planner, "spacing": spacing, "v_des": speed, "seed": seed, "status": s["status"],
            "flight_time": t_f, "collisions": s["collisions"],
            "emergency_stops": s["emergency_stops"], "min_clearance": s["min_clearance"],
            "f_l": t_f + t_f * s["collisions"] + W_E * s["emergency_stops"]}


def quantile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))]


def table(rows):
    lines = ["| planner | spacing (m) | v_des (m/s) | flights | completed | collision-free "
             "| collisions | emergency stops | mean t_f (s) | mean f_l "
             "| clearance ≥ 5 cm | 10% quantile of min clearance (m) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["planner"], r["spacing"], r["v_des"]) for r in rows},
                  key=lambda k: (k[0], -k[1], k[2]))
    for planner, spacing, speed in keys:
        cell = [r for r in rows
                if r["planner"] == planner and r["spacing"] == spacing and r["v_des"] == speed]
        n = len(cell)
        done = sum(r["status"] == "completed" for r in cell)
        free = sum(r["collisions"] == 0 for r in cell)
        kept = sum(r["min_clearance"] >= CLEARANCE for r in cell)
        lines.append(
            f"| {planner} | {spacing} | {speed} | {n} | {done}/{n} | {free}/{n} "
            f"| {sum(r['collisions'] for r in cell)} "
            f"| {sum(r['emergency_stops'] for r in cell)} "
            f"| {statistics.mean(r['flight_time'] for r in cell):.1f} "
            f"| {statistics.mean(r['f_l'] for r in cell):.1f} "
            f"| {kept}/{n} "
            f"| {quantile([r['min_clearance'] for r in cell], 0.1):.3f} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quadtune", default=str(ROOT / "build" / "experiments" / "quadtune"))
    ap.add_argument("--planners", nargs="+", default=["ipopt"])
    ap.add_argument("--seeds", nargs=2, type=int, default=[101, 116], metavar=("FIRST", "LAST"))
    ap.add_argument("--speeds", nargs="+", type=float, default=[2, 3, 4, 5, 6])
    ap.add_argument("--spacings", nargs="+", type=float, default=[3.0, 1.3, 0.9])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default="results/speed")
    args = ap.parse_args()
    if args.seeds[1] < args.seeds[0]:
        sys.exit(f"speed_table.py: --seeds {args.seeds[0]} {args.seeds[1]}: LAST below FIRST")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(p, s, v, n) for p in args.planners for s in args.spacings for v in args.speeds
            for n in range(args.seeds[0], args.seeds[1] + 1)]
    rows = []
    with tempfile.TemporaryDirectory() as work, \
            concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(fly, args.quadtune, *job, work) for job in jobs]
        for i, f in enumerate(concurrent.futures.as_completed(futures), 1):
            rows.append(f.result())
            print(f"\r{i}/{len(jobs)} flights", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    rows.sort(key=lambda r: (r["planner"], -r["spacing"], r["v_des"], r["seed"]))
    with open(out / "speed.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(rows)
    (out / "speed.md").write_text(table(rows))
    print(table(rows))


if __name__ == "__main__":
    main()
