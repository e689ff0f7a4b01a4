"""Experiments and planners from Python: quadtune.run, quadtune.resume, quadtune.register_planner.

    outcome = quadtune.run("experiments/tiny.yaml", "results/tiny")        # or a dict
    outcome.summary["trials"]        # as OUT/summary.json of `quadtune run`
    outcome.results.validation       # quadtune.load(OUT): the store's tables as DataFrames

A dict is the experiment file's content (turned into the same text the YAML loader reads, so a
bad key raises ValueError naming it). The run is the engine's (engine::RunExperiment, as `quadtune
run` does, figures aside) with the GIL released; progress is printed, or handed to a callable.
"""

import collections
import json
import os
import sys

from . import _core


def _asset_dirs():
    """Where experiment files' drone and layout names are found, as for the `quadtune` program:
    $QUADTUNE_ASSETS, the installed package's assets (<prefix>/share/quadtune/assets), the source
    tree's assets/."""
    dirs = [os.environ["QUADTUNE_ASSETS"]] if os.environ.get("QUADTUNE_ASSETS") else []
    installed = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                              *[os.pardir] * 4, "share", "quadtune", "assets"))
    return dirs + [d for d in (installed, _core.source_assets) if os.path.isdir(d)]


_core.set_asset_dirs(_asset_dirs())

Outcome = collections.namedtuple("Outcome", "summary results store")
Outcome.__doc__ = """summary: the run's summary (a dict, as summary.json); results: quadtune.load
of the store (needs pandas); store: the path of OUT/results.sqlite."""


def print_progress(p):
    """The default progress: one line per round on stderr."""
    if p["method"] == "validation":  # the held-out validation after the trials
        print(f"validation on held-out maps: flights {p['flights_done']}/{p['flights_total']}, "
              f"elapsed {p['elapsed_s']:.0f} s", file=sys.stderr, flush=True)
        return
    print(f"trial {p['trials_done'] + 1}/{p['trials_total']} {p['method']} r{p['repeat']}: "
          f"flights {p['flights_done']}/{p['flights_total']}, best f_l {p['best_long']:.3f}, "
          f"elapsed {p['elapsed_s']:.0f} s", file=sys.stderr, flush=True)


def _source(config):
    """(source, is_file, origin, base_dir) of an experiment file path or dict."""
    if isinstance(config, (str, os.PathLike)):
        return os.fspath(config), True, os.fspath(config), os.path.dirname(os.fspath(config))
    if isinstance(config, dict):
        try:
            text = json.dumps(config, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"<dict>: not an experiment's content: {e}") from None
        return text, False, "<dict>", os.getcwd()
    raise ValueError(f"config: got {type(config).__name__}; allowed: a file path or a dict")


def run(config, out, *, resume=False, overwrite=False, threads=None, progress=True, load=True):
    """Runs (or with resume=True continues) the experiment `config` (a YAML file's path or a dict
    of its content) into the folder `out` (its results.sqlite and summary.json). progress: True
    prints a line per round, a callable gets a dict per round, False is silent (an exception in
    the callable, or Ctrl-C, stops the run after its round and is raised). Returns an Outcome."""
    source, is_file, origin, base_dir = _source(config)
    if threads is not None and (not isinstance(threads, int) or isinstance(threads, bool)
                                or threads < 1):
        raise ValueError(f"threads: got {threads!r}; allowed: None (the experiment's) or an "
                         "int >= 1")
    store = os.path.join(os.fspath(out), "results.sqlite")
    if resume and not os.path.isfile(store):
        raise ValueError(f"{out}: no run to resume (no results.sqlite there)")
    if os.path.exists(store) and not resume:
        if not overwrite:
            raise ValueError(f"{out}: holds a run already; pass resume=True to continue it or "
                             "overwrite=True to replace it")
        os.remove(store)
    os.makedirs(os.fspath(out), exist_ok=True)
    callback = print_progress if progress is True else (progress or None)
    summary = json.loads(_core.run(source, is_file, origin, base_dir, store, resume, threads or 0,
                                   callback))
    with open(os.path.join(os.fspath(out), "summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
    results = None
    if load:
        from . import load as load_store
        results = load_store(store)
    return Outcome(summary, results, store)


def resume(config, out, **kwargs):
    """run(config, out, resume=True, ...): continues the run stored in `out`."""
    return run(config, out, resume=True, **kwargs)


def register_planner(name, planner):
    """Makes `planner` fly as `planner.type: name` in quadtune's closed loop. `planner` has a method
    waypoints(query, params) returning the points to pass between query.start and query.goal
    (a list of (x, y, z)); quadtune joins them by quintic pieces at params["v_des"], checks them
    against the local map and the limits, and retries slower when they fail. query: start,
    velocity, acceleration, goal, goal_velocity, path (the A* path through the local map),
    occupied(point). params: w_col, w_dyn, n_pol (int), v_des, h_pl, t_pl, a_max, inflation,
    clearance. Calls come from the engine's worker threads one at a time (under the GIL)."""
    _core.register_planner(name, planner)
