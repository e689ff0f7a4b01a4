"""Shared by the peer tuners (scripts/peers/): the experiment's parameter box, and flights of one
point through `quadtune evaluate` on the experiment's own tuning or held-out maps.

Every peer tunes the same planner, box and maps as `quadtune run`: candidate k of repeat r flies
tuning map k of repeat r (Experiment::FlightMapSeed, the maps quadtune's own methods fly), and a
recommended point flies the held-out maps with the map and flight seeds of `quadtune run`'s
validation."""

import csv
import io
import os
import subprocess
import sys

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
QUADTUNE = os.environ.get("QUADTUNE", os.path.join(ROOT, "build", "experiments", "quadtune"))


def box(experiment):
    """The tuned parameters of an experiment file, in file order: dicts with name, lower, upper,
    log, integer, default."""
    with open(experiment) as f:
        doc = yaml.safe_load(f)
    out = []
    for p in doc["parameters"]:
        out.append({"name": p["name"], "lower": float(p["lower"]), "upper": float(p["upper"]),
                    "log": bool(p.get("log", False)), "integer": p.get("type") == "integer",
                    "default": float(p["default"])})
    return out


def evaluate(experiment, point, maps, first, count=1, repeat=0, threads=1, sets=()):
    """Flies `point` ({name: value}) on maps first … first+count−1 of kind `maps` (tuning,
    heldout, race); returns one dict per flight (value = f_l, terms as floats)."""
    cmd = [QUADTUNE, "--log-level", "warn", "evaluate", experiment, "--maps", maps,
           "--first", str(first), "--count", str(count), "--repeat", str(repeat),
           "--threads", str(threads)]
    for name, value in sorted(point.items()):
        cmd += ["--param", "{}={!r}".format(name, float(value))]
    for s in sets:
        cmd += ["--set", s]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.stderr.write(done.stderr)
        raise RuntimeError("quadtune evaluate failed ({}): {}".format(done.returncode,
                                                                    " ".join(cmd)))
    rows = []
    for r in csv.DictReader(io.StringIO(done.stdout)):
        row = {}
        for k, v in r.items():
            if k in ("map_seed", "flight_seed"):
                row[k] = int(v)
                continue
            try:
                row[k] = float(v) if v != "" else float("nan")
            except ValueError:
                row[k] = v
        rows.append(row)
    return rows
