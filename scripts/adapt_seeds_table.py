#!/usr/bin/env python3
"""Markdown table of `quadtune adapt` runs of one experiment on several seeds.

usage: adapt_seeds_table.py DIR   (DIR/seed_N/summary.json, as scripts/full_results.sh writes)

Per seed: the adapted flight's time, collisions and emergency stops, the mean chosen v_des in
dense (< 1.5 m spacing) and sparse zones, and the trials slower than the drone at P_s by
outcome; then the means over the seeds.
"""
import csv
import json
import pathlib
import statistics
import sys


def slower_trials(flight_dir):
    """Counts (all, accepted) of the trials whose v_des is below the speed at their P_s."""
    speed = {}
    with open(flight_dir / "segments.csv", newline="") as f:
        for row in csv.DictReader(f):
            speed[row["segment"]] = float(row["speed_s"])
    total = accepted = 0
    with open(flight_dir / "trials.csv", newline="") as f:
        for row in csv.DictReader(f):
            s = speed.get(row["segment"])
            if s is None or not float(row["v_des"]) < s:
                continue
            total += 1
            accepted += row["success"] == "1"
    return total, accepted


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    root = pathlib.Path(sys.argv[1])
    runs = sorted(root.glob("seed_*/summary.json"), key=lambda p: int(p.parent.name[5:]))
    if not runs:
        sys.exit(f"{root}: no seed_*/summary.json")
    print("| seed | t_f (s) | collisions | emergency stops | chosen v_des dense / sparse (m/s) "
          "| slower trials accepted |")
    print("|---|---|---|---|---|---|")
    dense, sparse, times, lower = [], [], [], 0
    for path in runs:
        summary = json.loads(path.read_text())
        flight = next(f for f in summary["flights"] if f["adapted"])
        finding = summary.get("finding", {})  # absent when a zone kind had no adopted plan
        d = finding.get("dense_mean_chosen_v_des")
        s = finding.get("sparse_mean_chosen_v_des")
        total, accepted = slower_trials(path.parent / flight["directory"])
        cell = "–" if d is None or s is None else f"{d:.2f} / {s:.2f}"
        print(f"| {path.parent.name[5:]} | {flight['flight_time']:.2f} | {flight['collisions']} "
              f"| {flight['emergency_stops']} | {cell} | {accepted} of {total} |")
        times.append(flight["flight_time"])
        if d is not None and s is not None:
            dense.append(d)
            sparse.append(s)
            lower += d < s
    print()
    print(f"Over {len(runs)} seeds: mean t_f {statistics.mean(times):.1f} s; mean chosen v_des "
          f"{statistics.mean(dense):.2f} m/s in dense zones, {statistics.mean(sparse):.2f} m/s in "
          f"sparse ones (both known on {len(dense)} seeds), lower in dense zones on {lower}.")


if __name__ == "__main__":
    main()
