"""quadtune from Python: results stores as DataFrames (load, rows: pure Python), and through the
extension module quadtune._core (built from the C++, docs/python.md) the ask/tell optimisers
(BayesOpt, PSO, RandomSearch, Complementary: tune.py), experiment runs (run, resume) and
planners written in Python (register_planner: engine.py). The build puts the package in
build/python (PYTHONPATH=build/python); cmake --install puts it in site-packages.

    import quadtune
    r = quadtune.load("results/main/tuning/results.sqlite")   # or the run directory
    r.long      # pandas DataFrame: one row per flight (f_l)
    r.short     # one row per short-term evaluation (f_s on recorded planning queries)
    r.race      # racing flights (race: enabled), r.incumbent the outcome of each race
    r.validation, r.recheck, r.trials, r.experiment

`load()` gives the tables of `quadtune export STORE --tidy DIR`, typed (it needs pandas;
Debian: python3-pandas): number (0-based, the store's evaluation order), id, repeat, then the
evaluation table's columns as the store lists them in its `stored_column` table (written from
the C++ list, EvaluationColumns in engine/store/result_store.cpp) under their tidy names (TIDY_NAMES:
`status` left out, `message` as state_reason, `wall_s` as duration, `started` and `finished` as
datetime_start and datetime_complete), then params_<name> per parameter and terms_<name> per
objective term. Integers (integer parameters included) are Int64, seeds UInt64, enums (method,
kind, state) categoricals,
timestamps UTC datetimes, and the terms the list types (n_c, plans, ... integers; completed,
success, ... booleans) Int64 and boolean. `state` says what became of an evaluation: ok,
collision, timeout, stalled, diverged, solver_failure, error, incomplete, cancelled; state_reason
says why in words. `trials` has best_params as a dict per trial and finished as a datetime.

`rows()` gives the evaluation rows as stored, as plain dicts with the standard library only (the
params and terms keys merged in, a key clashing with a column prefixed). Stores are opened
read-only.
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


def json_field(text, path, row_id, column, table="evaluation"):
    """The JSON object stored in `column` of `table` row `row_id` ({} for NULL or empty);
    DamagedStore naming the file, the row and the column when it is not a JSON object."""
    if not text:
        return {}
    try:
        value = json.loads(text)
    except ValueError as e:
        raise DamagedStore("{}: damaged results store: {} {}: {} is not JSON ({})".format(
            path, table, row_id, column, e)) from None
    if not isinstance(value, dict):
        raise DamagedStore("{}: damaged results store: {} {}: {} is not a JSON object"
                           .format(path, table, row_id, column))
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
    """The columns every row of rows() has (KEYS, then the store's columns but its JSON
    objects)."""
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


# Stored evaluation columns under another name in the tidy tables (None: left out).
TIDY_NAMES = {"status": None, "message": "state_reason", "wall_s": "duration",
              "started": "datetime_start", "finished": "datetime_complete"}
# Columns of every tidy row before the store's own: the evaluation order, the row's id and its
# trial's repeat.
TIDY_KEYS = ["number", "id", "repeat"]


def tidy_name(name):
    """The tidy name of stored evaluation column `name` (None when left out)."""
    return TIDY_NAMES.get(name, name)


def key_types(column):
    """{key: "integer" | "boolean"} of an object column (its typed keys, in `names`)."""
    return dict(n.rsplit(":", 1) for n in column.names if ":" in n)


def tidy_rows(path):
    """({kind: [dict per evaluation, tidy names]}, {kind: {object column: [keys in order]}})
    in the store's evaluation order (standard library)."""
    file = store_path(path)
    listed = columns(path)
    out, keys = {k: [] for k in KINDS}, {}
    with connect(path) as db:
        query = ("SELECT e.id, t.repeat, t.map_seed, "
                 + ", ".join("e." + c.sql for c in listed)
                 + " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id ORDER BY e.id")
        for number, r in enumerate(db.execute(query)):
            where = "evaluation {}".format(r[0])
            row = {"number": number, "id": r[0], "repeat": r[1]}
            stored = dict(zip((c.name for c in listed), r[3:]))
            for column in listed:
                value = stored[column.name]
                if column.type == "object":
                    seen = keys.setdefault(stored.get("kind"), {}).setdefault(column.name, [])
                    for name, v in json_field(value, file, r[0], column.name).items():
                        row[column.prefix + name] = v
                        if name not in seen:
                            seen.append(name)
                elif tidy_name(column.name) is not None:
                    row[tidy_name(column.name)] = _value(column, value, file, where)
            if row.get("map_seed") is None and row.get("kind") != "short":
                row["map_seed"] = _seed(r[2], file, where, "the trial's map_seed")
            out.setdefault(row.get("kind"), []).append(row)
    return out, keys


def _typed(df, pd, listed):
    """`df` with its columns typed by the store's list (see the module documentation)."""
    out = df.copy()
    for name in ("number", "id", "repeat"):
        out[name] = out[name].astype("Int64")
    for c in listed:
        name = tidy_name(c.name)
        if c.type == "object":
            for key, kind in key_types(c).items():
                column = c.prefix + key
                if column in out.columns:
                    try:
                        out[column] = out[column].astype(
                            "Int64" if kind == "integer" else "boolean")
                    except (TypeError, ValueError):
                        pass  # a value the key's type cannot hold: left as numbers
        elif name is None:
            continue
        elif name.startswith("datetime_"):
            seconds = pd.to_numeric(out[name]).where(lambda s: s > 0)
            out[name] = pd.to_datetime(seconds, unit="s", utc=True)
        elif c.type in ("integer", "seed", "real"):
            out[name] = out[name].astype(
                {"integer": "Int64", "seed": "UInt64", "real": "float64"}[c.type])
        elif c.type == "enum":
            out[name] = out[name].astype(pd.CategoricalDtype(c.names))
    return out


def _trials_frame(path, pd):
    """The trial table typed: best_params a dict per trial, finished a UTC datetime."""
    listed = {c.name: c for c in columns(path, "trial")}
    file = store_path(path)
    rows_ = trials(path)
    for row in rows_:
        for name, column in listed.items():
            if column.type == "object" and row[name] is not None:
                row[name] = json_field(row[name], file, row["id"], name, "trial")
    df = pd.DataFrame(rows_, columns=["id"] + list(listed))
    for name, column in listed.items():
        if column.type == "enum":
            df[name] = df[name].astype(pd.CategoricalDtype(column.names))
        elif column.type in ("integer", "seed"):
            df[name] = df[name].astype("Int64" if column.type == "integer" else "UInt64")
    if "finished" in df.columns:
        df["finished"] = pd.to_datetime(pd.to_numeric(df["finished"]), unit="s", utc=True)
    df["id"] = df["id"].astype("Int64")
    return df


def integer_parameters(path):
    """The names of the experiment's integer parameters (`type: integer` in its stored config);
    their params_<name> columns are Int64. Empty when the config cannot be read as YAML."""
    try:
        import yaml  # Debian: python3-yaml
        doc = yaml.safe_load(experiment(path).get("config") or "") or {}
        return [p["name"] for p in doc.get("parameters", []) or []
                if isinstance(p, dict) and p.get("type") == "integer" and "name" in p]
    except Exception:  # an experiment row without a readable config: nothing to type
        return []


def load(path):
    """Results of the store at `path` as typed pandas DataFrames (see the module
    documentation)."""
    import pandas as pd  # Debian: python3-pandas; only load() needs it

    by_kind, keys = tidy_rows(path)
    listed = columns(path)
    fixed = TIDY_KEYS + [tidy_name(c.name) for c in listed
                         if c.type != "object" and tidy_name(c.name) is not None]

    integers = integer_parameters(path)

    def frame(kind):
        names = list(fixed)
        for c in listed:
            if c.type == "object":
                names += [c.prefix + k for k in keys.get(kind, {}).get(c.name, [])]
        df = _typed(pd.DataFrame(by_kind.get(kind, []), columns=names), pd, listed)
        for name in integers:
            if "params_" + name in df.columns:
                try:
                    df["params_" + name] = df["params_" + name].astype("Int64")
                except (TypeError, ValueError):
                    pass  # a value that is not whole: left as numbers
        return df

    return Results(long=frame("long"), short=frame("short"), validation=frame("validation"),
                   recheck=frame("recheck"), race=frame("race"), incumbent=frame("incumbent"),
                   trials=_trials_frame(path, pd), experiment=pd.Series(experiment(path)))


# The names backed by the compiled module, imported on first use so that load() works from a
# copy of the package without it (e.g. PYTHONPATH=experiments/python in the source tree).
_COMPILED = {"BayesOpt": "tune", "PSO": "tune", "RandomSearch": "tune", "Study": "tune",
             "Complementary": "tune",
             "Best": "tune", "Point": "tune", "run": "engine", "resume": "engine",
             "register_planner": "engine", "Outcome": "engine"}


def __getattr__(name):
    if name not in _COMPILED:
        raise AttributeError(f"module 'quadtune' has no attribute {name!r}")
    import importlib
    try:
        module = importlib.import_module("." + _COMPILED[name], __name__)
    except ImportError as e:
        raise ImportError(
            f"quadtune.{name} needs the compiled module quadtune._core, which this copy of the "
            f"package ({os.path.dirname(__file__)}) lacks ({e}): build it (ninja -C build "
            "quadtune_python, then PYTHONPATH=build/python) or install quadtune (cmake --install "
            "build)") from None
    return getattr(module, name)
