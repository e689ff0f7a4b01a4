"""Held-out validation tables for quadtune runs and studies (Debian's python3 packages).

A validation flight is one parameter set (a trial's recommended point, or the defaults) flown on
one held-out map; every set flies the same maps with the same flight seeds, so two sets compare
pairwise, map by map. The functions here take a list of flights, each a dict with
    method, repeat, map (held-out map index), value (f_l), completed (bool), n_c, n_e, params (dict)
and write the tables; `quadtune_plot.py run` and `study` call them.
"""
import math
import statistics

try:
    from scipy import stats as _stats
except ImportError:  # pragma: no cover - python3-scipy is installed by scripts/setup.sh
    _stats = None

from quadtune_methods import LABELS, ORDER  # noqa: E402,F401  (one naming of the methods)


def read_store(con, path):
    """The validation flights of a run store (sqlite3 connection to `path`): kind 'validation'
    rows; a row whose params or terms are not JSON raises quadtune.DamagedStore naming it."""
    from quadtune import json_field
    repeats = {tid: rep for tid, rep in con.execute("SELECT id, repeat FROM trial")}
    flights = []
    for row_id, tid, method, iteration, value, terms, params, state in con.execute(
            "SELECT id, trial_id, method, iteration, value, terms, params, state FROM evaluation "
            "WHERE kind = 'validation' ORDER BY trial_id, iteration"):
        t = json_field(terms, path, row_id, "terms")
        flights.append(dict(method=method, repeat=repeats.get(tid, -1), map=iteration,
                            value=value, completed=t.get("completed", 0.0) > 0.5,
                            n_c=t.get("n_c", 0.0), n_e=t.get("n_e", 0.0),
                            state=state, params=json_field(params, path, row_id, "params")))
    # A `default` trial recommends the defaults; their flights are stored once (trial id 0).
    return flights


def mean_ci(values, level=0.95):
    """Mean and the half-width of its Student-t confidence interval."""
    values = list(values)
    if not values:
        return float("nan"), float("nan")
    m = statistics.fmean(values)
    if len(values) < 2:
        return m, float("nan")
    sd = statistics.stdev(values)
    t = _stats.t.ppf(0.5 + level / 2, len(values) - 1) if _stats else 1.96
    return m, t * sd / math.sqrt(len(values))


def paired_p(diffs):
    """Two-sided Wilcoxon signed-rank p of paired differences (NaN when all are zero or too few)."""
    diffs = [d for d in diffs if d == d]
    if _stats is None or len(diffs) < 2 or all(d == 0 for d in diffs):
        return float("nan")
    import warnings
    with warnings.catch_warnings():  # ties or zero differences: scipy's normal approximation
        warnings.simplefilter("ignore", UserWarning)
        return float(_stats.wilcoxon(diffs, alternative="two-sided").pvalue)


def near_bounds(params, space, fraction=0.02):
    """Names of the parameters within `fraction` of a bound, measured on the parameter's own scale
    (logarithmic where the space says log)."""
    out = []
    for p in space:
        v = params.get(p["name"])
        lo, hi = float(p["lower"]), float(p["upper"])
        if v is None or hi <= lo:
            continue
        if p.get("log") and lo > 0 and v > 0:
            u = (math.log(v) - math.log(lo)) / (math.log(hi) - math.log(lo))
        else:
            u = (v - lo) / (hi - lo)
        if u <= fraction:
            out.append(p["name"] + "↓")
        elif u >= 1 - fraction:
            out.append(p["name"] + "↑")
    return out


def space_of(config_text):
    """The parameter box of an experiment's stored YAML text: [{name, lower, upper, log}]."""
    import yaml
    config = yaml.safe_load(config_text) or {}
    return [dict(name=p["name"], lower=p["lower"], upper=p["upper"], log=bool(p.get("log")))
            for p in config.get("parameters", [])]


def summarise(flights, space):
    """One row per method: flights, mean f_l ± 95% CI, completion and collision-free rates,
    emergency stops, paired tests against the defaults and BO+PSO, parameters near a bound."""
    by_key = {(f["method"], f["repeat"], f["map"]): f for f in flights}
    defaults = {f["map"]: f for f in flights if f["method"] == "default"}
    methods = [m for m in ORDER if any(f["method"] == m for f in flights)]
    methods += sorted({f["method"] for f in flights} - set(methods))
    rows = []
    for m in methods:
        own = [f for f in flights if f["method"] == m]
        mean, half = mean_ci(f["value"] for f in own)
        vs_default = [f["value"] - defaults[f["map"]]["value"] for f in own
                      if f["map"] in defaults] if m != "default" else []
        vs_bopso = [f["value"] - by_key[("bo_pso", f["repeat"], f["map"])]["value"] for f in own
                    if ("bo_pso", f["repeat"], f["map"]) in by_key] if m != "bo_pso" else []
        bounds = sorted({b for f in own for b in near_bounds(f["params"], space)})
        points = {f["repeat"] for f in own}
        default_params = next((f["params"] for f in flights if f["method"] == "default"), None)
        # Trials whose candidates all failed (re-flights or races) hand back the defaults.
        fallback = len({f["repeat"] for f in own if f["params"] == default_params}) \
            if m != "default" else 0
        completed = sum(f["completed"] for f in own)
        rows.append(dict(method=m, points=len(points), fallback=fallback, flights=len(own),
                         mean=mean, ci=half,
                         completed=completed,
                         collision_free=sum(f["completed"] and f["n_c"] == 0 for f in own),
                         emergency_stops=sum(f["n_e"] for f in own),
                         p_default=paired_p(vs_default), p_bopso=paired_p(vs_bopso),
                         diff_default=statistics.fmean(vs_default) if vs_default else float("nan"),
                         median_diff_default=(statistics.median(vs_default) if vs_default
                                              else float("nan")),
                         near_bounds=bounds))
    return rows


def fmt(v, digits=2):
    return "–" if v != v else "{:.{}f}".format(v, digits)


def markdown(rows, maps):
    """The validation table in Markdown."""
    lines = [
        "Held-out validation: each trial's recommended point (with `race:` enabled, the "
        "incumbent that won its races against the defaults; otherwise the first of its "
        "best-ranked candidates, by posterior mean for BO and BO+PSO and by f_l for PSO and "
        "Random, whose re-flights on fresh maps pass the experiment's `recommend` check; a trial "
        "that hands back the defaults is counted under 'defaults handed back') and the defaults, "
        "each flown on the same {} held-out maps (no trial flew them) with the "
        "same flight seeds. f_l = t_f + t_f·n_c + w_e·n_e; a flight that does not finish scores "
        "the failure value. CI: 95% Student-t interval of the mean over all flights. Δ: the "
        "per-map difference to the defaults on the same map (negative: better). p: two-sided "
        "Wilcoxon signed-rank test of the per-map paired differences. Near a bound: parameters "
        "within 2% of a bound (↓ lower, ↑ upper) in any recommended point.".format(maps),
        "",
        "| " + " | ".join(HEADER) + " |",
        "|---" * len(HEADER) + "|",
    ]
    lines += ["| " + " | ".join(cells(r)) + " |" for r in rows]
    return "\n".join(lines) + "\n"


HEADER = ["method", "points", "defaults handed back", "flights", "mean f_l ± 95% CI",
          "Δ vs Default: mean, median", "completed", "collision-free", "emergency stops",
          "p vs Default", "p vs BO+PSO", "near a bound"]


def cells(r):
    """One method's row of the validation table as printed (tuning.md and the report)."""
    return [LABELS.get(r["method"], r["method"]), str(r["points"]),
            str(r["fallback"]) if r["method"] != "default" else "–", str(r["flights"]),
            "{} ± {}".format(fmt(r["mean"]), fmt(r["ci"])),
            "{}, {}".format(fmt(r["diff_default"]), fmt(r["median_diff_default"])),
            "{}/{}".format(r["completed"], r["flights"]),
            "{}/{}".format(r["collision_free"], r["flights"]),
            "{:.0f}".format(r["emergency_stops"]), fmt(r["p_default"], 3), fmt(r["p_bopso"], 3),
            ", ".join(r["near_bounds"]) or "none"]


CSV_FIELDS = ["method", "points", "fallback", "flights", "mean", "ci", "diff_default", "median_diff_default",
              "completed",
              "collision_free", "emergency_stops", "p_default", "p_bopso", "near_bounds"]


def csv_row(r):
    return [r[k] if k != "near_bounds" else " ".join(r[k]) for k in CSV_FIELDS]
