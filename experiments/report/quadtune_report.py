#!/usr/bin/env python3
"""Writes DIR/report.html: one self-contained page (opens offline, from disk) of a quadtune run,
study or flight directory. Called by `quadtune report DIR`, which first flies the stored flights
to replay into DIR/report_flights/.

    quadtune_report.py DIR [--out FILE]

The page holds the data as JSON and inlines plotly.js (charts) and three.js (3-D replay) from
experiments/report/js/node_modules (installed by scripts/setup.sh with `npm ci`; another folder:
$QUADTUNE_REPORT_JS). Standard library only.
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
import quadtune  # noqa: E402  (experiments/python/quadtune: the store reader)


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


def ranks(values):
    """Ranks 1..n, ties sharing their mean rank."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    r = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2.0 + 1.0
        i = j + 1
    return r


def spearman(x, y):
    """Spearman's rank correlation; None when either side is constant or n < 3."""
    if len(x) < 3:
        return None
    rx, ry = ranks(x), ranks(y)
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx = sum((a - mx) ** 2 for a in rx)
    syy = sum((b - my) ** 2 for b in ry)
    if sxx == 0 or syy == 0:
        return None
    return sxy / math.sqrt(sxx * syy)


def run_data(directory):
    stores = stores_under(directory)
    several = len(stores) > 1
    series, finals, flights, importance = [], [], [], []
    params_order = []
    experiment_names = []
    for label, path in stores:
        exp = quadtune.experiment(path)
        experiment_names.append(exp.get("name", "?"))
        by_kind = quadtune.rows(path)
        names, _ = quadtune.parameter_names(path)
        for n in names.get("long", []):
            if n not in params_order:
                params_order.append(n)
        # Convergence: best f_l so far against flights, per trial; median and range per method.
        per_method = {}
        for r in by_kind["long"]:
            per_method.setdefault(r["method"], {}).setdefault(r["trial_id"], []).append(r)
        for method, trials in per_method.items():
            name = f"{label} · {method}" if several else method
            curves, final = [], []
            for rows in trials.values():
                rows.sort(key=lambda r: (r["iteration"], r["index"]))
                best, curve = math.inf, []
                for r in rows:
                    best = min(best, r["value"])
                    curve.append(best)
                curves.append(curve)
                final.append({"repeat": rows[0]["repeat"], "value": best})
            n = max(len(c) for c in curves)
            x, med, lo, hi = [], [], [], []
            for k in range(n):
                vals = [c[k] for c in curves if len(c) > k]
                x.append(k + 1)
                med.append(percentile(vals, 0.5))
                lo.append(min(vals))
                hi.append(max(vals))
            series.append({"name": name, "x": x, "median": med, "lo": lo, "hi": hi,
                           "trials": len(curves)})
            finals.append({"name": name, "values": final})
        for r in by_kind["long"]:
            flights.append({"series": f"{label} · {r['method']}" if several else r["method"],
                            "id": r["id"], "value": r["value"], "status": r["status"],
                            "state": r["state"], "message": r["message"],
                            "params": {p: r[p] for p in names.get("long", []) if p in r}})
        # Importance proxy: |Spearman ρ| of each parameter with the objective, per kind, over
        # the successful evaluations only (state ok).
        for kind, objective in (("long", "f_l (flights)"), ("short", "f_s (re-solves)")):
            ok = [r for r in by_kind[kind] if r["state"] == "ok"]
            for p in names.get(kind, []):
                pairs = [(r[p], r["value"]) for r in ok if isinstance(r.get(p), (int, float))]
                rho = spearman([a for a, _ in pairs], [b for _, b in pairs])
                if rho is not None:
                    importance.append({"store": label, "objective": objective, "parameter": p,
                                       "rho": rho, "n": len(pairs)})
    return {"series": series, "finals": finals, "flights": flights, "importance": importance,
            "parameters": params_order, "stores": [s[0] for s in stores],
            "experiments": experiment_names}


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
