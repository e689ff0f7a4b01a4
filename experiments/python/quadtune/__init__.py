"""Reading quadtune results stores (results.sqlite) from Python.

    import sys; sys.path.insert(0, "<quadtune>/experiments/python")
    import quadtune
    r = quadtune.load("results/main/tuning/results.sqlite")   # or the run directory
    r.long      # pandas DataFrame: one row per flight (f_l), one column per parameter and term
    r.short     # one row per short-term evaluation (f_s on recorded planning queries)
    r.race      # racing flights (race: enabled), r.incumbent the outcome of each race
    r.validation, r.trials, r.experiment

The tables have the columns of `quadtune export STORE --tidy DIR`: id, trial_id, method, repeat,
kind, iteration, index, status, value, wall_s, map_seed, flight_seed, then one column per
parameter and one per objective term (a name clashing with a fixed column gets the prefix
"param_" or "term_"). `rows()` gives the same rows as plain dicts with the standard library only;
`load()` needs pandas (Debian: python3-pandas). Stores are opened read-only.
"""

import collections
import json
import os
import sqlite3

FIXED = ["id", "trial_id", "method", "repeat", "kind", "iteration", "index", "status", "value",
         "wall_s", "map_seed", "flight_seed"]
KINDS = ["long", "short", "validation", "recheck", "race", "incumbent"]

Results = collections.namedtuple(
    "Results", "long short validation recheck race incumbent trials experiment")


def store_path(path):
    """The results.sqlite file of `path` (the file itself or a run directory holding it)."""
    candidate = os.path.join(path, "results.sqlite") if os.path.isdir(path) else path
    if not os.path.isfile(candidate):
        raise FileNotFoundError(f"{path}: no results store (results.sqlite) there")
    return candidate


def _connect(path):
    uri = "file:" + os.path.abspath(store_path(path)) + "?mode=ro"
    return sqlite3.connect(uri, uri=True)


def _seed(row_seed, trial_seed, kind):
    if row_seed:
        return int(row_seed)
    return int(trial_seed) if trial_seed and kind != "short" else None


def rows(path):
    """{kind: [dict per evaluation]} for every kind in KINDS (standard library)."""
    out = {k: [] for k in KINDS}
    with _connect(path) as db:
        query = ("SELECT e.id, e.trial_id, e.method, t.repeat, e.kind, e.iteration, e.idx, e.status,"
                 " e.value, e.wall_s, e.map_seed, e.flight_seed, e.params, e.terms, t.map_seed"
                 " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id"
                 " ORDER BY e.kind, e.trial_id, e.iteration, e.idx")
        for r in db.execute(query):
            kind = r[4]
            row = dict(zip(FIXED, r[:12]))
            row["map_seed"] = _seed(r[10], r[14], kind)
            row["flight_seed"] = int(r[11]) if r[11] else None
            for source, prefix in ((json.loads(r[12] or "{}"), "param_"),
                                   (json.loads(r[13] or "{}"), "term_")):
                for name, value in source.items():
                    row[prefix + name if name in FIXED else name] = value
            out.setdefault(kind, []).append(row)
    return out


def parameter_names(path):
    """({kind: [parameter names]}, {kind: [term names]}) in the order the store records them."""
    params, terms = {}, {}
    with _connect(path) as db:
        for kind, p, t in db.execute("SELECT kind, params, terms FROM evaluation"):
            for names, text in ((params.setdefault(kind, []), p), (terms.setdefault(kind, []), t)):
                for n in json.loads(text or "{}"):
                    if n not in names:
                        names.append(n)
    return params, terms


def trials(path):
    """The trial table as dicts (id, method, repeat, map_seed, status, best_params, best_value)."""
    with _connect(path) as db:
        cur = db.execute("SELECT id, method, repeat, map_seed, status, best_params, best_value"
                         " FROM trial ORDER BY id")
        names = [c[0] for c in cur.description]
        return [dict(zip(names, r)) for r in cur]


def experiment(path):
    """The experiment row as a dict (name, config text, seed, version, machine, threads, mode)."""
    with _connect(path) as db:
        cur = db.execute("SELECT id, name, config, seed, version, machine, threads, mode, started"
                         " FROM experiment ORDER BY id LIMIT 1")
        names = [c[0] for c in cur.description]
        row = cur.fetchone()
        return dict(zip(names, row)) if row else {}


def load(path):
    """Results of the store at `path` as pandas DataFrames (see the module documentation)."""
    import pandas as pd  # Debian: python3-pandas; only load() needs it

    by_kind = rows(path)
    params, terms = parameter_names(path)

    def frame(kind):
        columns = FIXED + [("param_" + n if n in FIXED else n) for n in params.get(kind, [])]
        columns += [("term_" + n if n in FIXED else n) for n in terms.get(kind, [])]
        df = pd.DataFrame(by_kind.get(kind, []), columns=columns)
        for seed in ("map_seed", "flight_seed"):
            df[seed] = df[seed].astype("UInt64")
        return df

    return Results(long=frame("long"), short=frame("short"), validation=frame("validation"),
                   recheck=frame("recheck"), race=frame("race"), incumbent=frame("incumbent"),
                   trials=pd.DataFrame(trials(path)),
                   experiment=pd.Series(experiment(path)))
