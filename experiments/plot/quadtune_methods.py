"""The one naming and colouring of tuning methods, and the definitions the figures, tuning.md and
the report (experiments/report/quadtune_report.py) share: a trial's final value and the table of
tuned parameters. Standard library only.

    METHODS                   key, label and colour (hex) of every method, in display order
    label(m), colour(m)       of a method key (an unknown key: the key itself, a spare colour)
    order(keys)               the keys in display order
    final_value(m, values)    a trial's final value from the f_l of its flights
    tuned_parameters(store)   each trial's recommended point beside the defaults
    parameters_markdown(t)    that table in Markdown (tuning.md)
"""
import statistics

# key, label, colour: matplotlib's tab10 colours as hex, so that plotly draws the same ones.
METHODS = [
    {"key": "default", "label": "Default", "colour": "#2ca02c"},
    {"key": "random", "label": "Random", "colour": "#7f7f7f"},
    {"key": "pso", "label": "PSO only", "colour": "#9467bd"},
    {"key": "bo", "label": "BO only", "colour": "#1f77b4"},
    {"key": "bo_pso", "label": "BO+PSO", "colour": "#d62728"},
]
_BY_KEY = {m["key"]: m for m in METHODS}
# Colours of method keys not in METHODS, in order of first use.
SPARE_COLOURS = ["#ff7f0e", "#8c564b", "#e377c2", "#bcbd22", "#17becf"]
_spare = {}

LABELS = {m["key"]: m["label"] for m in METHODS}
ORDER = [m["key"] for m in METHODS]

FINAL_VALUE = ("final value: the best f_l of the trial's flights (tuning and racing flights); "
               "Default: the mean f_l of its flights")


def label(method):
    return _BY_KEY[method]["label"] if method in _BY_KEY else method


def colour(method):
    if method in _BY_KEY:
        return _BY_KEY[method]["colour"]
    if method not in _spare:
        _spare[method] = SPARE_COLOURS[len(_spare) % len(SPARE_COLOURS)]
    return _spare[method]


def order(keys):
    """The distinct keys of `keys`, known methods first in METHODS order, then the rest sorted."""
    keys = set(keys)
    return [k for k in ORDER if k in keys] + sorted(keys - set(ORDER))


def table(keys):
    """[{key, label, colour}] of `keys` in display order (the report's data)."""
    return [{"key": k, "label": label(k), "colour": colour(k)} for k in order(keys)]


def final_value(method, values):
    """A trial's final value (FINAL_VALUE): the best f_l of its flights, or for the defaults the
    mean f_l of their flights."""
    values = list(values)
    return statistics.fmean(values) if method == "default" else min(values)


def fmt_param(value):
    """A parameter value as the tables print it (4 significant digits)."""
    return "{:.4g}".format(float(value))


def tuned_parameters(con, path):
    """Each trial's recommended point beside the defaults, from a run store (sqlite3 connection
    `con` to `path`): {"parameters": [{name, default, lower, upper, log}], "points": [{method,
    label, repeat, source, params, heldout_mean, defaults}]}. The recommended point is the one
    the trial flew in the held-out validation (what it hands back); a trial without validation
    flights shows the parameters of its best flight (source "best flight")."""
    import quadtune
    config = con.execute("SELECT config FROM experiment ORDER BY id LIMIT 1").fetchone()
    space = []
    if config:
        import yaml
        doc = yaml.safe_load(config[0]) or {}
        space = [{"name": p["name"], "default": p.get("default"), "lower": p.get("lower"),
                  "upper": p.get("upper"), "log": bool(p.get("log"))}
                 for p in doc.get("parameters", []) or []]
    validated = {}
    for row_id, tid, params, value in con.execute(
            "SELECT id, trial_id, params, value FROM evaluation WHERE kind = 'validation' "
            "ORDER BY id"):
        v = validated.setdefault(tid, {"params": quadtune.json_field(params, path, row_id,
                                                                      "params"), "values": []})
        v["values"].append(value)
    points = []
    default_point = None
    for tid, method, repeat, best_params in con.execute(
            "SELECT id, method, repeat, best_params FROM trial ORDER BY id"):
        if method == "default":
            if default_point is None:
                default_point = quadtune.json_field(best_params, path, tid, "best_params", "trial")
            continue
        if tid in validated:
            params, source = validated[tid]["params"], "recommended"
            heldout = statistics.fmean(validated[tid]["values"])
        else:
            params = quadtune.json_field(best_params, path, tid, "best_params", "trial")
            source, heldout = "best flight", None
        points.append({"method": method, "label": label(method), "repeat": repeat,
                       "source": source, "params": params, "heldout_mean": heldout})
    defaults = {p["name"]: p["default"] for p in space if p["default"] is not None}
    if not defaults and default_point:
        defaults = default_point
    if not space:
        names = list(defaults) or sorted({k for p in points for k in p["params"]})
        space = [{"name": n, "default": defaults.get(n), "lower": None, "upper": None,
                  "log": False} for n in names]
    for p in points:
        p["defaults"] = bool(defaults) and all(
            abs(float(p["params"].get(n, float("nan"))) - float(v)) <= 1e-12 * max(1, abs(v))
            for n, v in defaults.items())
    rank = {k: i for i, k in enumerate(order(p["method"] for p in points))}
    points.sort(key=lambda p: (rank[p["method"]], p["repeat"]))
    heldout_default = validated.get(0, {}).get("values")
    return {"parameters": space, "points": points,
            "default_heldout_mean": statistics.fmean(heldout_default) if heldout_default else None}


def parameter_cells(t):
    """(header, rows) of the tuned-parameter table as printed (the same strings in tuning.md
    and the report): one row per parameter, the defaults then one column per trial, and a last
    row with each point's held-out mean f_l."""
    header = ["parameter", "range", "Default"] + [
        "{} r{}".format(p["label"], p["repeat"]) for p in t["points"]]
    rows = []
    for prm in t["parameters"]:
        rng = "–" if prm["lower"] is None else "[{}, {}]{}".format(
            fmt_param(prm["lower"]), fmt_param(prm["upper"]), " log" if prm["log"] else "")
        rows.append([prm["name"], rng, "–" if prm["default"] is None else fmt_param(prm["default"])]
                    + [fmt_param(p["params"][prm["name"]]) if prm["name"] in p["params"] else "–"
                       for p in t["points"]])
    fmt_mean = lambda v: "–" if v is None else "{:.2f}".format(v)  # noqa: E731
    rows.append(["held-out mean f_l", "", fmt_mean(t["default_heldout_mean"])] + [
        fmt_mean(p["heldout_mean"]) + (" (= defaults)" if p["defaults"] else "")
        for p in t["points"]])
    return header, rows


PARAMETERS_CAPTION = (
    "Tuned parameters: each trial's recommended point (the point it hands back, flown in the "
    "held-out validation; a trial without validation flights: its best flight's point) beside the "
    "defaults. r: the repeat. (= defaults): the trial handed back the defaults.")


def parameters_markdown(t):
    """The tuned-parameter table in Markdown (tuning.md)."""
    if not t["points"] and not t["parameters"]:
        return ""
    header, rows = parameter_cells(t)
    lines = [PARAMETERS_CAPTION, "", "| " + " | ".join(header) + " |",
             "|---" * len(header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"
