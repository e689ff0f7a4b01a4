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


class DamagedStore(ValueError):
    """A results store that cannot be read as one: the message names the file, and the row and
    column where one is at fault."""


def json_field(text, path, row_id, column):
    """The JSON object stored in `column` of evaluation `row_id` ({} for NULL or empty);
    DamagedStore naming the file, the row and the column when it is not a JSON object."""
    if not text:
        return {}
    try:
        value = json.loads(text)
    except ValueError as e:
        raise DamagedStore("{}: damaged results store: evaluation {}: {} is not JSON ({})".format(
            path, row_id, column, e)) from None
    if not isinstance(value, dict):
        raise DamagedStore("{}: damaged results store: evaluation {}: {} is not a JSON object"
                           .format(path, row_id, column))
    return value


def store_path(path):
    """The results.sqlite file of `path` (the file itself or a run directory holding it)."""
    candidate = os.path.join(path, "results.sqlite") if os.path.isdir(path) else path
    if not os.path.isfile(candidate):
        raise FileNotFoundError(f"{path}: no results store (results.sqlite) there")
    return candidate


def connect(path):
    """A read-only connection to a quadtune store; DamagedStore when the file is not one."""
    file = store_path(path)
    con = sqlite3.connect("file:" + os.path.abspath(file) + "?mode=ro", uri=True)
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    except sqlite3.DatabaseError as e:
        con.close()
        raise DamagedStore("{}: not a readable quadtune results store ({})".format(file, e)) \
            from None
    if not {"evaluation", "trial", "experiment"} <= tables:
        con.close()
        raise DamagedStore("{}: not a quadtune results store (no evaluation, trial and "
                           "experiment tables)".format(file))
    return con


def _seed(value, file, row_id, column):
    """A stored seed as an int in [0, 2^64), None when absent; DamagedStore otherwise."""
    if value is None or value == "" or value == 0:
        return None
    try:
        seed = int(value)
    except (TypeError, ValueError):
        seed = -1
    if not 0 <= seed < 2 ** 64 or (isinstance(value, float) and value != seed):
        raise DamagedStore("{}: damaged results store: evaluation {}: {} is {!r}, not a seed (an "
                           "integer in [0, 2^64))".format(file, row_id, column, value))
    return seed


def rows(path):
    """{kind: [dict per evaluation]} for every kind in KINDS (standard library)."""
    out = {k: [] for k in KINDS}
    file = store_path(path)
    with connect(path) as db:
        query = ("SELECT e.id, e.trial_id, e.method, t.repeat, e.kind, e.iteration, e.idx, e.status,"
                 " e.value, e.wall_s, e.map_seed, e.flight_seed, e.params, e.terms, t.map_seed"
                 " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id"
                 " ORDER BY e.kind, e.trial_id, e.iteration, e.idx")
        for r in db.execute(query):
            kind = r[4]
            row = dict(zip(FIXED, r[:12]))
            row["map_seed"] = _seed(r[10], file, r[0], "map_seed")
            if row["map_seed"] is None and kind != "short":
                row["map_seed"] = _seed(r[14], file, r[0], "the trial's map_seed")
            row["flight_seed"] = _seed(r[11], file, r[0], "flight_seed")
            for source, prefix in ((json_field(r[12], file, r[0], "params"), "param_"),
                                   (json_field(r[13], file, r[0], "terms"), "term_")):
                for name, value in source.items():
                    row[prefix + name if name in FIXED else name] = value
            out.setdefault(kind, []).append(row)
    return out


def parameter_names(path):
    """({kind: [parameter names]}, {kind: [term names]}) in the order the store records them."""
    params, terms = {}, {}
    file = store_path(path)
    with connect(path) as db:
        for row_id, kind, p, t in db.execute("SELECT id, kind, params, terms FROM evaluation"):
            for names, text, column in ((params.setdefault(kind, []), p, "params"),
                                        (terms.setdefault(kind, []), t, "terms")):
                for n in json_field(text, file, row_id, column):
                    if n not in names:
                        names.append(n)
    return params, terms


def trials(path):
    """The trial table as dicts (id, method, repeat, map_seed, status, best_params, best_value)."""
    with connect(path) as db:
        cur = db.execute("SELECT id, method, repeat, map_seed, status, best_params, best_value"
                         " FROM trial ORDER BY id")
        names = [c[0] for c in cur.description]
        return [dict(zip(names, r)) for r in cur]


def experiment(path):
    """The experiment row as a dict (name, config text, seed, version, machine, threads, mode)."""
    with connect(path) as db:
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
