#!/usr/bin/python3
"""Golden regression set: fixed Ipopt flights and a tiny experiment's store, compared bit for bit.

Usage: golden_test.py QUADTUNE SOURCE_DIR [--regenerate]

Flies `quadtune fly --planner ipopt --layout-options assets/layouts/forest_thin_1p3.yaml` (the
1.3 m thin forest) for the seeds in SEEDS and runs
experiments/tiny.yaml with the budgets in TINY_SETS, then compares a SHA-256 digest of every
deterministic output (and, for reading, the flights' metrics) with test/golden/expected.json.
Left out are only the measured wall-clock values: solve and wall times of a flight
(`mean_solve_time`, `max_solve_time`, `wall_time`, the `solve_time_s` column of plan_steps.csv)
and of the store (`wall_s`, `started`, `finished`), the store's machine and version, and the
evaluation row ids (their order follows the threads; rows are compared by their unique key).
Exit status 0 when everything matches, 1 when something differs (each difference is listed).

Regenerate the expected values after a change that is meant to alter flights or stored results:
  /usr/bin/python3 test/golden/golden_test.py build/experiments/quadtune . --regenerate
and commit test/golden/expected.json with the change that explains it.
"""

import hashlib
import json
import pathlib
import sqlite3
import subprocess
import sys
import tempfile

SEEDS = (1, 2, 3)
SPACING = "1.3"
TINY_SETS = ("budget.flights=3", "validation.maps=2")
FLIGHT_TIMING_KEYS = ("mean_solve_time", "max_solve_time", "wall_time")
STORE_SKIPPED_COLUMNS = {
    "experiment": ("started", "machine", "version"),
    "trial": ("finished",),
    "evaluation": ("id", "wall_s", "started", "finished"),
}
STORE_ORDER = {
    "experiment": "id",
    "trial": "experiment_id, method, repeat",
    "evaluation": "trial_id, kind, iteration, idx",
}


def Digest(data):
  return hashlib.sha256(data if isinstance(data, bytes) else data.encode()).hexdigest()


def Run(command):
  done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
  if done.returncode != 0:
    sys.exit(f"golden: {' '.join(command)} exited with {done.returncode}:\n{done.stdout[-3000:]}")


def CsvWithout(path, column):
  lines = path.read_text().splitlines()
  header = lines[0].split(",")
  drop = header.index(column)
  return "\n".join(",".join(f for i, f in enumerate(line.split(",")) if i != drop)
                   for line in lines)


def Flight(quadtune, source, seed, work):
  out = work / f"flight_{seed}"
  Run([quadtune, "fly", "--planner", "ipopt", "--layout-options",
       str(source / "assets" / "layouts" / "forest_thin_1p3.yaml"), "--seed", str(seed),
       "--out", str(out), "--no-plot"])
  summary = json.loads((out / "summary.json").read_text())
  for key in FLIGHT_TIMING_KEYS:
    summary.pop(key)
  return {
      "metrics": summary,
      "flight.csv": Digest((out / "flight.csv").read_bytes()),
      "plans.csv": Digest((out / "plans.csv").read_bytes()),
      "plan_steps.csv": Digest(CsvWithout(out / "plan_steps.csv", "solve_time_s")),
      "obstacles.json": Digest((out / "obstacles.json").read_bytes()),
  }


def Store(quadtune, source, work):
  out = work / "tiny"
  command = [quadtune, "run", str(source / "experiments" / "tiny.yaml"), "--out", str(out),
             "--threads", "2"]
  for item in TINY_SETS:
    command += ["--set", item]
  Run(command)
  db = sqlite3.connect(out / "results.sqlite")
  tables = {}
  for table, order in STORE_ORDER.items():
    columns = [row[1] for row in db.execute(f"PRAGMA table_info({table})")
               if row[1] not in STORE_SKIPPED_COLUMNS[table]]
    rows = db.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY {order}").fetchall()
    # repr keeps every bit of a REAL.
    text = "\n".join(repr(row) for row in rows)
    tables[table] = {"rows": len(rows), "sha256": Digest(text)}
  db.close()
  return tables


def Differences(expected, actual, where=""):
  if isinstance(expected, dict) and isinstance(actual, dict):
    found = []
    for key in sorted(set(expected) | set(actual)):
      found += Differences(expected.get(key), actual.get(key), f"{where}/{key}")
    return found
  return [] if expected == actual else [f"{where}: expected {expected!r}, got {actual!r}"]


def main():
  if len(sys.argv) not in (3, 4) or (len(sys.argv) == 4 and sys.argv[3] != "--regenerate"):
    sys.exit(__doc__)
  quadtune, source = sys.argv[1], pathlib.Path(sys.argv[2]).resolve()
  expected_path = source / "test" / "golden" / "expected.json"
  with tempfile.TemporaryDirectory(prefix="quadtune_golden_") as tmp:
    work = pathlib.Path(tmp)
    actual = {
        "flights": {f"spacing_{SPACING}_seed_{s}": Flight(quadtune, source, s, work) for s in SEEDS},
        "tiny_store": Store(quadtune, source, work),
    }
  if len(sys.argv) == 4:
    expected_path.write_text(json.dumps(actual, indent=1, sort_keys=True) + "\n")
    print(f"wrote {expected_path}")
    return 0
  expected = json.loads(expected_path.read_text())
  found = Differences(expected, actual)
  for line in found:
    print(line)
  if found:
    print(f"{len(found)} difference(s) from {expected_path}; regenerate only when the change is "
          "meant to alter results (see the header of this script)")
    return 1
  print(f"{len(SEEDS)} flights and the tiny store match {expected_path}")
  return 0


if __name__ == "__main__":
  sys.exit(main())
