"""Reading quadtune results stores (results.sqlite) from Python.

    import sys; sys.path.insert(0, "<quadtune>/experiments/python")
    import quadtune
    r = quadtune.load("results/main/tuning/results.sqlite")   # or the run directory
    r.long      # pandas DataFrame: one row per flight (f_l), one column per parameter and term
    r.short     # one row per short-term evaluation (f_s on recorded planning queries)
    r.race      # racing flights (race: enabled), r.incumbent the outcome of each race
    r.validation, r.trials, r.experiment

The tables have the columns of `quadtune export STORE --tidy DIR`: id, repeat, then the
evaluation table's columns as the store lists them in its `stored_column` table (written from
the C++ column list, EvaluationColumns in engine/store/result_store.cpp): trial_id, method, kind,
iteration, index, value, status, state (what became of the evaluation: ok, collision, timeout,
stalled, diverged, solver_failure, error, ...), message (the reason), wall_s, started, finished,
map_seed, flight_seed, then one column per parameter and one per objective term (a name clashing
with a fixed column gets the prefix the list gives: "param_" or "term_"). `rows()` gives the same
rows as plain dicts with the standard library only; `load()` needs pandas (Debian:
python3-pandas) and types the columns by the list (enums as categoricals, seeds as UInt64,
integers as Int64). Stores are opened read-only.
"""

import collections
import json
import os
import sqlite3

KINDS = ["long", "short", "validation", "recheck", "race", "incumbent"]
# Columns of every tidy row that are not in the evaluation table: the row's id and its trial's
# repeat.
KEYS = ["id", "repeat"]

Results = collections.namedtuple(
    "Results", "long short validation recheck race incumbent trials experiment")
Column = collections.namedtuple("Column", "name sql type names prefix")


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
    if "stored_column" not in tables:
        con.close()
        raise DamagedStore("{}: a results store without its column list (no stored_column "
                           "table): written by an older quadtune; export it with that version"
                           .format(file))
    return con


def columns(path, table="evaluation"):
    """The columns of `table` (evaluation, trial or experiment) as the store lists them
    (Column: name, sql, type, names, prefix), in order."""
    with connect(path) as db:
        return [Column(name, sql, kind, names.split(",") if names else [], prefix or "")
                for name, sql, kind, names, prefix in db.execute(
                    "SELECT name, sql, type, names, prefix FROM stored_column"
                    " WHERE tbl = ? ORDER BY position", (table,))]


def fixed_columns(path):
    """The tidy columns every row has (KEYS, then the store's columns but its JSON objects)."""
    return KEYS + [c.name for c in columns(path) if c.type != "object"]


def _seed(value, file, where, column):
    """A stored seed as an int in [0, 2^64), None when absent; DamagedStore otherwise."""
    if value is None or value == "" or value == 0:
        return None
    try:
        seed = int(value)
    except (TypeError, ValueError):
        seed = -1
    if not 0 <= seed < 2 ** 64 or (isinstance(value, float) and value != seed):
        raise DamagedStore("{}: damaged results store: {}: {} is {!r}, not a seed (an "
                           "integer in [0, 2^64))".format(file, where, column, value))
    return seed


def _value(column, value, file, where):
    """One stored value of row `where` ("evaluation 5") checked against its column;
    DamagedStore naming the row and the column otherwise."""
    if column.type == "seed":
        return _seed(value, file, where, column.name)
    if column.type == "enum" and value not in column.names:
        raise DamagedStore("{}: damaged results store: {}: {} is {!r}, not one of {}"
                           .format(file, where, column.name, value, ", ".join(column.names)))
    return value


def rows(path):
    """{kind: [dict per evaluation]} for every kind in KINDS (standard library)."""
    out = {k: [] for k in KINDS}
    file = store_path(path)
    listed = columns(path)
    fixed = set(fixed_columns(path))
    with connect(path) as db:
        query = ("SELECT e.id, t.repeat, t.map_seed, "
                 + ", ".join("e." + c.sql for c in listed)
                 + " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id"
                 " ORDER BY e.kind, e.trial_id, e.iteration, e.idx")
        for r in db.execute(query):
            row = {"id": r[0], "repeat": r[1]}
            objects = []
            for column, value in zip(listed, r[3:]):
                if column.type == "object":
                    objects.append((column, json_field(value, file, r[0], column.name)))
                else:
                    row[column.name] = _value(column, value, file, "evaluation {}".format(r[0]))
            if row.get("map_seed") is None and row.get("kind") != "short":
                row["map_seed"] = _seed(r[2], file, "evaluation {}".format(r[0]),
                                        "the trial's map_seed")
            for column, source in objects:
                for name, value in source.items():
                    row[column.prefix + name if name in fixed else name] = value
            out.setdefault(row.get("kind"), []).append(row)
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
    """The trial table as dicts: id, then the columns the store lists for it (experiment_id,
    method, repeat, map_seed, status, best_params, best_value, finished)."""
    listed = columns(path, "trial")
    file = store_path(path)
    with connect(path) as db:
        out = []
        for r in db.execute("SELECT id, " + ", ".join(c.sql for c in listed)
                            + " FROM trial ORDER BY id"):
            row = {"id": r[0]}
            for column, value in zip(listed, r[1:]):
                row[column.name] = _value(column, value, file, "trial {}".format(r[0])) \
                    if value is not None else None
            out.append(row)
        return out


def experiment(path):
    """The experiment row as a dict: id, then the columns the store lists for it (name, config
    text, seed, version, machine, threads, mode, started)."""
    listed = columns(path, "experiment")
    with connect(path) as db:
        row = db.execute("SELECT id, " + ", ".join(c.sql for c in listed)
                         + " FROM experiment ORDER BY id LIMIT 1").fetchone()
        return dict(zip(["id"] + [c.name for c in listed], row)) if row else {}


def load(path):
    """Results of the store at `path` as pandas DataFrames (see the module documentation)."""
    import pandas as pd  # Debian: python3-pandas; only load() needs it

    by_kind = rows(path)
    params, terms = parameter_names(path)
    listed = columns(path)
    fixed = fixed_columns(path)
    dtypes = {"id": "Int64", "repeat": "Int64"}
    for c in listed:
        if c.type == "integer":
            dtypes[c.name] = "Int64"
        elif c.type == "seed":
            dtypes[c.name] = "UInt64"
        elif c.type == "real":
            dtypes[c.name] = "float64"
        elif c.type == "enum":
            dtypes[c.name] = pd.CategoricalDtype(c.names)
    prefixes = {c.name: c.prefix for c in listed if c.type == "object"}

    def frame(kind):
        names = list(fixed)
        for source, column in ((params, "params"), (terms, "terms")):
            names += [(prefixes[column] + n if n in fixed else n) for n in source.get(kind, [])]
        df = pd.DataFrame(by_kind.get(kind, []), columns=names)
        return df.astype({k: v for k, v in dtypes.items() if k in df.columns})

    return Results(long=frame("long"), short=frame("short"), validation=frame("validation"),
                   recheck=frame("recheck"), race=frame("race"), incumbent=frame("incumbent"),
                   trials=pd.DataFrame(trials(path)),
                   experiment=pd.Series(experiment(path)))
