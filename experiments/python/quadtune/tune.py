"""quadtune's ask/tell optimisers for any Python function (they minimise).

    study = quadtune.BayesOpt({"x": (-5.0, 5.0), "n": (1, 8, int)}, seed=1)
    for _ in range(30):
        x = study.ask()                # {"x": 0.37, "n": 4}: a dict, integers as int
        study.tell(x, f(x))
    study.best                         # Best(params={...}, value=..., observed=...)

The space maps each name to (lower, upper) (continuous), (lower, upper, int) (integer),
(lower, upper, "log") (log scale), or a dict with the keys of an experiment file's parameter
(lower, upper, type, log, default). Options are the keys of the experiment file's `bo:` or `pso:`
map (docs/config.md), e.g. BayesOpt(space, seed=1, initial_design_size=5). Every check is the
C++ loader's: bad input raises ValueError naming the key and what is allowed.
"""

import collections
import json
import math
import numbers
import re

from . import _core

Best = collections.namedtuple("Best", "params value observed")
Best.__doc__ = """The optimiser's best estimate: params (dict), value (BayesOpt: the posterior mean
at params; the others: the value told), observed (the value told at params)."""


class Point(dict):
    """A point ask() returned: a dict of parameter values; `id` names it for tell()."""

    __slots__ = ("id",)


def _parameter(name, bounds):
    """The experiment-file form of one parameter of the space."""
    if isinstance(bounds, dict):
        return dict(bounds, name=name)
    if isinstance(bounds, (tuple, list)) and len(bounds) in (2, 3) and all(
            isinstance(b, numbers.Real) and not isinstance(b, bool) for b in bounds[:2]):
        item = {"name": name, "lower": float(bounds[0]), "upper": float(bounds[1])}
        kind = bounds[2] if len(bounds) == 3 else float
        if kind in (int, "int", "integer"):
            item.update(type="integer", lower=bounds[0], upper=bounds[1])
        elif kind == "log":
            item["log"] = True
        elif kind is not float:
            raise ValueError(f"space[{name!r}]: the third item is {kind!r}; allowed: int, 'log'")
        return item
    raise ValueError(
        f"space[{name!r}]: got {bounds!r}; allowed: (lower, upper), (lower, upper, int), "
        "(lower, upper, 'log') or a dict with keys lower, upper, type, log, default")


def _space_yaml(space):
    if not isinstance(space, dict) or not space:
        raise ValueError(f"space: got {space!r}; allowed: a non-empty dict of "
                         "name -> (lower, upper)")
    for name in space:
        if not isinstance(name, str):
            raise ValueError(f"space: the name {name!r} is not a string")
    return json.dumps({"parameters": [_parameter(n, b) for n, b in space.items()]})


def _named(error, names):
    """A loader's message with `parameters[I]` replaced by the parameter's name."""
    return re.sub(r"parameters\[(\d+)\]",
                  lambda m: f"space[{names[int(m.group(1))]!r}]" if int(m.group(1)) < len(names)
                  else m.group(0), str(error))


class Study:
    """An ask/tell optimiser over a named space; see the module's docstring."""

    method = None

    def __init__(self, space, seed, **options):
        if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**64:
            raise ValueError(f"seed: got {seed!r}; allowed: an int in [0, 2**64) (explicit, so "
                             "that the same seed gives the same points)")
        names = list(space) if isinstance(space, dict) else []
        try:
            self._core = _core.Optimizer(self.method, _space_yaml(space),
                                         json.dumps({self.method: options}), seed)
        except ValueError as e:
            raise ValueError(_named(e, names)) from None
        self.names = self._core.names
        self._integer = self._core.integer
        self._pending = {}  # values -> id, for tell() with a plain dict

    def _point(self, cid, values):
        p = Point((n, int(v) if i else v) for n, v, i in zip(self.names, values, self._integer))
        p.id = cid
        self._pending[tuple(values)] = cid
        return p

    def ask(self, n=None):
        """One point (a dict), or with n a list of up to n points asked together (a batch)."""
        if n is not None and (not isinstance(n, int) or isinstance(n, bool) or n < 1):
            raise ValueError(f"ask: n is {n!r}; allowed: None (one point) or an int >= 1")
        points = [self._point(cid, values) for cid, values in self._core.ask(1 if n is None else n)]
        if n is None and not points:  # PSO: every particle waits for its value
            raise RuntimeError("ask: every point asked waits for its value; tell or cancel one")
        return points if n is not None else points[0]

    def _values(self, x):
        if not isinstance(x, dict):
            raise ValueError(f"tell: x is {type(x).__name__}; allowed: a point ask() returned")
        unknown = [k for k in x if k not in self.names]
        missing = [k for k in self.names if k not in x]
        if unknown or missing:
            raise ValueError(f"tell: x has {'unknown' if unknown else 'no'} parameter "
                             f"{(unknown or missing)[0]!r}; allowed: {', '.join(self.names)}")
        return tuple(float(x[k]) for k in self.names)

    def tell(self, x, value, noise=None):
        """Reports f(x) for a point ask() returned; `noise` is the value's noise variance
        (BayesOpt; squared objective units)."""
        values = self._values(x)
        cid = getattr(x, "id", None)
        if cid is None:
            cid = self._pending.get(values)
        if cid is None:
            raise ValueError(f"tell: {dict(x)} is not a point of this study waiting for its value")
        if not isinstance(value, numbers.Real) or not math.isfinite(value):
            raise ValueError(f"tell: value {value!r} is not a finite number")
        self._core.tell(cid, float(value), noise)
        self._pending.pop(values, None)

    def cancel(self, x):
        """Withdraws a point whose evaluation failed (PSO asks it again)."""
        values = self._values(x)
        self._core.cancel(getattr(x, "id", self._pending.get(values, -1)))
        self._pending.pop(values, None)

    @property
    def best(self):
        """Best(params, value, observed), or None before the first tell."""
        b = self._core.best()
        if b is None:
            return None
        params = {n: int(v) if i else v for n, v, i in zip(self.names, b[0], self._integer)}
        return Best(params, b[1], b[2])

    @property
    def best_params(self):
        return None if self.best is None else self.best.params

    @property
    def best_value(self):
        return None if self.best is None else self.best.value

    def save_state(self):
        """The whole state (RNG included) as a JSON string; restore_state continues from it."""
        return self._core.save_state()

    def restore_state(self, state):
        self._core.restore_state(state)
        self._pending.clear()

    def __len__(self):
        return self._core.num_told


class BayesOpt(Study):
    """quadtune's Gaussian-process Bayesian optimisation: batches (ask(n)), per-observation noise
    (tell(..., noise=)), discounting (notify_context_changed) and ageing (advance_age)."""

    method = "bo"

    def notify_context_changed(self):
        """Divides the weight of every observation so far by bo.discount once more."""
        self._core.notify_context_changed()

    def advance_age(self, amount=1.0):
        self._core.advance_age(amount)

    def predict(self, x):
        """(mean, variance) of the objective at x under the model."""
        return self._core.predict(list(self._values(x)))


class PSO(Study):
    """quadtune's asynchronous particle swarm (the short-term optimiser)."""

    method = "pso"


class RandomSearch(Study):
    """Uniform random search in the space's unit cube."""

    method = "random"


class Complementary:
    """quadtune's complementary tuner (paper Sec. III) as ask/tell, for two objectives: Bayesian
    optimisation of the long-term parameters on an expensive value f_l (a flight), particle swarm
    optimisation of the short-term ones on a cheap value f_s (a re-solved planning query), the best
    short-term point so far flying in every long-term evaluation.

        tuner = quadtune.Complementary({"v_des": (0.5, 4.0)}, {"w_col": (0.05, 5.0, "log")}, seed=1)
        for _ in range(flights):
            for _ in range(10):                       # the cheap loop, as often as it is cheap
                s = tuner.ask_short(); tuner.tell_short(s, f_s(s))
            x = tuner.ask(); tuner.tell(x, f_l(x))    # x: long-term point + best short-term one

    As the engine's `bo_pso` method does, BO discounts its older observations once for each ask()
    whose short-term point differs from the last one flown (notify_context_changed: their noise
    is divided by bo.discount). The short-term point flown is the defaults until the first
    tell_short. Options: `bo` and `pso`, dicts of the experiment file's `bo:` and `pso:` keys.
    """

    def __init__(self, long_space, short_space, seed, bo=None, pso=None):
        common = set(long_space or ()) & set(short_space or ())
        if common:
            raise ValueError(f"short_space: {sorted(common)[0]!r} is in long_space too; a "
                             "parameter is long-term or short-term")
        if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**63:
            raise ValueError(f"seed: got {seed!r}; allowed: an int in [0, 2**63)")
        # The two optimisers draw from distinct seeds derived from the one given.
        self.long = BayesOpt(long_space, seed=2 * seed, **(bo or {}))
        self.short = PSO(short_space, seed=2 * seed + 1, **(pso or {}))
        self._defaults = {n: int(v) if i else v for n, v, i in
                          zip(self.short.names, self.short._core.defaults, self.short._integer)}
        self._flying = None  # the short-term point of the last ask()
        self.context_changes = 0

    def flying(self):
        """The short-term point the next ask() flies: PSO's best so far, else the defaults."""
        best = self.short.best
        return dict(best.params) if best is not None else dict(self._defaults)

    def ask_short(self, n=None):
        return self.short.ask(n)

    def tell_short(self, s, value):
        self.short.tell(s, value)

    def ask(self):
        """A point to evaluate with f_l: BO's long-term point and the flying short-term one."""
        flying = self.flying()
        if self._flying is not None and flying != self._flying:
            self.long.notify_context_changed()
            self.context_changes += 1
        self._flying = flying
        x = self.long.ask()
        point = Point(x, **flying)
        point.id = x.id
        return point

    def tell(self, x, value, noise=None):
        """Reports f_l(x) for a point ask() returned."""
        if not isinstance(x, dict):
            raise ValueError(f"tell: x is {type(x).__name__}; allowed: a point ask() returned")
        long_x = Point((k, x[k]) for k in self.long.names if k in x)
        long_x.id = getattr(x, "id", None)
        unknown = [k for k in x if k not in self.long.names and k not in self.short.names]
        if unknown:
            raise ValueError(f"tell: x has unknown parameter {unknown[0]!r}; allowed: "
                             f"{', '.join(self.long.names + self.short.names)}")
        self.long.tell(long_x, value, noise)

    @property
    def best(self):
        """Best(params, value, observed): BO's best long-term point with the flying short-term
        one; value and observed are BO's (f_l). None before the first tell."""
        b = self.long.best
        return None if b is None else Best({**b.params, **self.flying()}, b.value, b.observed)
