#!/usr/bin/env python3
"""Writes DIR/report.html: one self-contained page (opens offline, from disk) of a quadtune run,
study or flight directory. Called by `quadtune report DIR`, which first flies the stored flights
to replay into DIR/report_flights/.

    quadtune_report.py DIR [--out FILE]

The page holds the data as JSON and inlines plotly.js (charts) and three.js (3-D replay) from
experiments/report/js/node_modules (installed by scripts/setup.sh with `npm ci`; another folder:
$QUADTUNE_REPORT_JS). Python 3 with numpy, scipy and yaml (Debian: python3-numpy,
python3-scipy, python3-yaml); the method names and colours, the final values and the tables
come from experiments/plot (quadtune_methods, quadtune_validation), as in tuning.md.
"""

import argparse
import base64
import csv
import glob
import html
import json
import math
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python"))
# The figure scripts' folder (method names, colours, tables): beside this one, or the folder of
# $QUADTUNE_PLOT_SCRIPT when that names the figure script elsewhere.
sys.path.insert(0, os.path.join(HERE, "..", "plot"))
if os.environ.get("QUADTUNE_PLOT_SCRIPT"):
    sys.path.insert(0, os.path.dirname(os.path.abspath(os.environ["QUADTUNE_PLOT_SCRIPT"])))
sys.path.insert(0, HERE)
import quadtune  # noqa: E402  (experiments/python/quadtune: the store reader)
import quadtune_methods as qm  # noqa: E402  (experiments/plot: method names, colours, finals)


def fail(message):
    print(f"quadtune report: {message}", file=sys.stderr)
    sys.exit(1)


def js_libraries():
    """(plotly source, three.core source, three.module source, OrbitControls source)."""
    root = os.environ.get("QUADTUNE_REPORT_JS", os.path.join(HERE, "js", "node_modules"))
    files = ["plotly.js-dist-min/plotly.min.js", "three/build/three.core.js",
             "three/build/three.module.js", "three/examples/jsm/controls/OrbitControls.js"]
    out = []
    for f in files:
        path = os.path.join(root, f)
        if not os.path.isfile(path):
            fail(f"{path} is missing: run scripts/setup.sh (it runs `npm ci` in "
                 f"experiments/report/js), or point $QUADTUNE_REPORT_JS at a node_modules folder")
        with open(path, encoding="utf-8") as fh:
            out.append(fh.read())
    return out


def data_url(source):
    return "data:text/javascript;base64," + base64.b64encode(source.encode()).decode()


# ---------------------------------------------------------------------------------------------
# Runs and studies


def stores_under(directory):
    """[(label, path)] of every results store under `directory` (a run: label "run")."""
    found = []
    for path in sorted(glob.glob(os.path.join(directory, "**", "results.sqlite"), recursive=True)):
        if "report_flights" in os.path.relpath(path, directory).split(os.sep):
            continue
        label = os.path.relpath(os.path.dirname(path), directory).replace(os.sep, "/")
        found.append(("run" if label == "." else label, path))
    return found


def percentile(values, q):
    s = sorted(values)
    pos = (len(s) - 1) * q
    lo, hi = math.floor(pos), math.ceil(pos)
    return s[lo] + (s[hi] - s[lo]) * (pos - lo)


def finite(v):
    """v as a float, None for NaN or infinity (JSON has neither)."""
    return None if v is None or v != v or v in (math.inf, -math.inf) else float(v)


def space_of(path):
    """The experiment's parameter box [{name, lower, upper, log}] (empty when not stored)."""
    import quadtune_validation as qv
    config = quadtune.experiment(path).get("config")
    return qv.space_of(config) if config else []


# The least number of evaluations an importance estimate is made from.
MIN_IMPORTANCE_N = 12
# Short-term evaluations used for the f_s importance at most (a seeded sample).
MAX_SHORT_N = 250


def importance_of(label, objective, rows, space, seed, contour=False):
    """Sobol' indices of a surrogate of log(value) over `rows` (quadtune_importance), and with
    `contour` the partial dependence of the surrogate's value on its two most important
    parameters; None with fewer than MIN_IMPORTANCE_N rows."""
    import numpy as np
    import quadtune_importance as qi
    names = [p for p in space if all(isinstance(r.get(p["name"]), (int, float)) for r in rows)]
    rows = [r for r in rows if r["value"] > 0]
    if len(rows) < MIN_IMPORTANCE_N or not names:
        return None
    X = np.column_stack([qi.scale([r[p["name"]] for r in rows], p["lower"], p["upper"], p["log"])
                         for p in names])
    result = qi.importance(X, [r["value"] for r in rows], seed)
    out = {"store": label, "objective": objective, "n": result["n"],
           "loo_r2": finite(result["loo_r2"]),
           "parameters": [p["name"] for p in names],
           "first": [finite(v) for v in result["first"]],
           "total": [finite(v) for v in result["total"]]}
    if contour and len(names) >= 2:
        i, j = [int(k) for k in np.argsort(-result["total"])[:2]]
        model = result["surrogate"]
        grid, values = qi.partial_dependence(model.predict, len(names), i, j, seed=seed + 2)
        px, py = names[i], names[j]
        out["contour"] = {
            "x": px["name"], "y": py["name"], "log_x": px["log"], "log_y": py["log"],
            "xs": [finite(v) for v in qi.unscale(grid, px["lower"], px["upper"], px["log"])],
            "ys": [finite(v) for v in qi.unscale(grid, py["lower"], py["upper"], py["log"])],
            "z": [[finite(math.exp(v)) for v in row] for row in values],
            "points": {"x": [r[px["name"]] for r in rows], "y": [r[py["name"]] for r in rows],
                       "value": [r["value"] for r in rows],
                       "method": [r["method"] for r in rows]}}
    return out


def validation_data(label, path):
    """The held-out validation of a store: the rows and the table cells of tuning.md's
    validation table (quadtune_validation), and every validation flight; None without any."""
    import quadtune_validation as qv
    con = quadtune.connect(path)
    try:
        flights = qv.read_store(con, path)
        config = con.execute("SELECT config FROM experiment ORDER BY id LIMIT 1").fetchone()
    finally:
        con.close()
    if not flights:
        return None
    rows = qv.summarise(flights, qv.space_of(config[0]) if config else [])
    return {"store": label, "maps": len({f["map"] for f in flights}), "header": qv.HEADER,
            "cells": [qv.cells(r) for r in rows],
            "rows": [{"method": r["method"], "mean": finite(r["mean"]), "ci": finite(r["ci"]),
                      "flights": r["flights"], "collision_free": r["collision_free"],
                      "completed": r["completed"], "p_default": finite(r["p_default"]),
                      "diff_default": finite(r["diff_default"])} for r in rows],
            "flights": [{"method": f["method"], "repeat": f["repeat"], "map": f["map"],
                         "value": f["value"], "state": f["state"]} for f in flights]}


def parameter_data(label, path):
    """The tuned-parameter table of a store as tuning.md prints it (quadtune_methods)."""
    con = quadtune.connect(path)
    try:
        tuned = qm.tuned_parameters(con, path)
    finally:
        con.close()
    if not tuned["points"] and not tuned["parameters"]:
        return None
    header, cells = qm.parameter_cells(tuned)
    return {"store": label, "header": header, "cells": cells,
            "points": [{"method": p["method"], "repeat": p["repeat"], "source": p["source"]}
                       for p in tuned["points"]]}


EVALUATION_FIELDS = ["id", "kind", "method", "repeat", "trial_id", "iteration", "value", "state",
                     "message", "n_c"]


def run_data(directory):
    stores = stores_under(directory)
    several = len(stores) > 1
    series, finals, flights, importance = [], [], [], []
    evaluations, validation, parameter_tables = [], [], []
    params_order, methods_seen = [], []
    experiment_names = []
    for number, (label, path) in enumerate(stores):
        exp = quadtune.experiment(path)
        experiment_names.append(exp.get("name", "?"))
        by_kind = quadtune.rows(path)
        names, _ = quadtune.parameter_names(path)
        space = space_of(path)
        for n in names.get("long", []):
            if n not in params_order:
                params_order.append(n)
        # Every flight of a trial in the order flown (tuning and racing flights): convergence
        # and final values (quadtune_methods.final_value, as tuning.md and tuning.png).
        per_method = {}
        for r in sorted(by_kind["long"] + by_kind["race"], key=lambda r: r["id"]):
            per_method.setdefault(r["method"], {}).setdefault(r["trial_id"], []).append(r)
        for method in qm.order(per_method):
            trials = per_method[method]
            if method not in methods_seen:
                methods_seen.append(method)
            name = f"{label} · {method}" if several else method
            curves, final = [], []
            for rows in trials.values():
                best, curve = math.inf, []
                for r in rows:
                    best = min(best, r["value"])
                    curve.append(best)
                curves.append(curve)
                final.append({"repeat": rows[0]["repeat"],
                              "value": qm.final_value(method, [r["value"] for r in rows])})
            n = max(len(c) for c in curves)
            x, med, lo, hi = [], [], [], []
            for k in range(n):
                vals = [c[k] for c in curves if len(c) > k]
                x.append(k + 1)
                med.append(percentile(vals, 0.5))
                lo.append(min(vals))
                hi.append(max(vals))
            series.append({"name": name, "method": method, "store": label, "x": x, "median": med,
                           "lo": lo, "hi": hi, "trials": len(curves)})
            finals.append({"name": name, "method": method, "store": label, "values": final})
        for r in by_kind["long"]:
            flights.append({"series": f"{label} · {r['method']}" if several else r["method"],
                            "method": r["method"], "id": r["id"], "value": r["value"],
                            "status": r["status"], "state": r["state"], "message": r["message"],
                            "params": {p: r[p] for p in names.get("long", []) if p in r}})
        for kind in ("long", "race", "validation", "short"):
            for r in by_kind[kind]:
                if r["method"] not in methods_seen:
                    methods_seen.append(r["method"])
                evaluations.append([label] + [r.get(k) for k in EVALUATION_FIELDS])
        # Importance: Sobol' indices of a surrogate fitted to the flights that finished (state ok
        # or collision: timeouts, stalls and other failures score the failure value) and to the
        # successful re-solves (state ok), a seeded sample of at most MAX_SHORT_N.
        finished = [r for r in by_kind["long"] + by_kind["race"]
                    if r["state"] in ("ok", "collision")]
        imp = importance_of(label, "f_l (flights that finished)", finished, space,
                            seed=1000 * number + 1, contour=True)
        if imp:
            importance.append(imp)
        ok_short = [r for r in by_kind["short"] if r["state"] == "ok"]
        if len(ok_short) > MAX_SHORT_N:
            import random
            ok_short = random.Random(1000 * number + 7).sample(ok_short, MAX_SHORT_N)
        imp = importance_of(label, "f_s (successful re-solves)", ok_short, space,
                            seed=1000 * number + 11)
        if imp:
            importance.append(imp)
        v = validation_data(label, path)
        if v:
            validation.append(v)
        t = parameter_data(label, path)
        if t:
            parameter_tables.append(t)
    return {"series": series, "finals": finals, "flights": flights, "importance": importance,
            "parameters": params_order, "stores": [s[0] for s in stores],
            "experiments": experiment_names, "methods": qm.table(methods_seen),
            "final_value": qm.FINAL_VALUE, "validation": validation,
            "parameters_caption": qm.PARAMETERS_CAPTION,
            "parameter_tables": parameter_tables,
            "evaluations": {"fields": ["store"] + EVALUATION_FIELDS, "rows": evaluations}}


# ---------------------------------------------------------------------------------------------
# Flights (3-D replay)


def rounded(v, digits=3):
    return round(float(v), digits)


def flight_data(directory, name):
    with open(os.path.join(directory, "summary.json"), encoding="utf-8") as fh:
        summary = json.load(fh)
    with open(os.path.join(directory, "obstacles.json"), encoding="utf-8") as fh:
        obstacles = json.load(fh)
    t, p, yaw = [], [], []
    with open(os.path.join(directory, "flight.csv"), encoding="utf-8") as fh:
        for r in csv.DictReader(fh):
            t.append(rounded(r["t"]))
            p.append([rounded(r["x"]), rounded(r["y"]), rounded(r["z"])])
            yaw.append(rounded(r["yaw"]))
    plans = {}
    plans_csv = os.path.join(directory, "plans.csv")
    if os.path.isfile(plans_csv):
        with open(plans_csv, encoding="utf-8") as fh:
            for r in csv.DictReader(fh):
                plan = plans.setdefault(int(r["plan"]), {"t0": rounded(r["t0"]), "p": []})
                plan["p"].append([rounded(r["x"]), rounded(r["y"]), rounded(r["z"])])
    return {"name": name, "summary": summary, "obstacles": obstacles, "t": t, "p": p, "yaw": yaw,
            "plans": [plans[k] for k in sorted(plans)]}


def replay_flights(directory):
    if os.path.isfile(os.path.join(directory, "flight.csv")):
        return [flight_data(directory, os.path.basename(os.path.abspath(directory)))]
    out = []
    for d in sorted(glob.glob(os.path.join(directory, "report_flights", "*", ""))):
        if os.path.isfile(os.path.join(d, "flight.csv")):
            out.append(flight_data(d, os.path.basename(os.path.normpath(d))))
    return out


# ---------------------------------------------------------------------------------------------


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dir", help="a `quadtune run`, `study` or `fly` output directory")
    parser.add_argument("--out", help="the page (default: DIR/report.html)")
    args = parser.parse_args()
    directory = args.dir
    if not os.path.isdir(directory):
        fail(f"{directory}: no such directory")
    is_flight = os.path.isfile(os.path.join(directory, "flight.csv"))
    if not is_flight and not stores_under(directory):
        fail(f"{directory}: holds no results.sqlite and no flight.csv")
    data = {"title": os.path.basename(os.path.abspath(directory)),
            "kind": "flight" if is_flight else
                    ("study" if os.path.isfile(os.path.join(directory, "study.json")) else "run"),
            "runs": None if is_flight else run_data(directory),
            "replays": replay_flights(directory)}
    plotly, three_core, three_module, orbit = js_libraries()
    three_module = three_module.replace("'./three.core.js'", "'three/core'")
    importmap = {"imports": {"three/core": data_url(three_core), "three": data_url(three_module),
                             "three/addons/controls/OrbitControls.js": data_url(orbit)}}
    with open(os.path.join(HERE, "report.html"), encoding="utf-8") as fh:
        page = fh.read()
    with open(os.path.join(HERE, "report.js"), encoding="utf-8") as fh:
        script = fh.read()
    # Every "<" (and ">", "&") as a JSON escape: no "</script" or "<!--" can end or change the
    # script element that holds the data.
    data_json = (json.dumps(data, separators=(",", ":"), allow_nan=False)
                 .replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026"))
    parts = {"TITLE": html.escape(data["title"]), "PLOTLY": plotly.replace("</script", "<\\/script"),
             "IMPORTMAP": json.dumps(importmap), "DATA": data_json, "SCRIPT": script}
    page = re.sub(r"\{\{([A-Z]+)\}\}", lambda m: parts[m.group(1)], page)  # one pass
    out = args.out or os.path.join(directory, "report.html")
    # Written whole or not at all: a full disk leaves the previous page (or none), never half.
    partial = out + ".partial"
    try:
        with open(partial, "w", encoding="utf-8") as fh:
            fh.write(page)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(partial, out)
    except OSError as e:
        if os.path.exists(partial):
            os.remove(partial)
        fail("{}: {}".format(out, e.strerror or e))
    print(f"quadtune report: wrote {out} ({len(page) / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
