#!/usr/bin/python3
"""Optuna's TPE sampler (Debian: python3-optuna) tuning an experiment's parameter box with its
flight budget, as a researcher would: trial k flies tuning map k of the repeat, and the
recommendation is `study.best_params` (the best single flight).

    scripts/peers/optuna_tpe.py experiments/benchmark.yaml --repeat 0 --budget 100 \
        --out recommended.json
"""
import argparse
import json
import sys

import optuna

import peerlib


def tune(experiment, repeat, budget, seed, sets):
    params = peerlib.box(experiment)

    def objective(trial):
        point = {}
        for p in params:
            if p["integer"]:
                point[p["name"]] = trial.suggest_int(p["name"], int(p["lower"]), int(p["upper"]))
            else:
                point[p["name"]] = trial.suggest_float(p["name"], p["lower"], p["upper"],
                                                       log=p["log"])
        row = peerlib.evaluate(experiment, point, "tuning", trial.number, repeat=repeat,
                               sets=sets)[0]
        return row["value"]

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    study.optimize(objective, n_trials=budget)
    return {"tuner": "optuna_tpe", "repeat": repeat, "flights": budget,
            "best_value": study.best_value, "params": study.best_params}


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("experiment")
    ap.add_argument("--repeat", type=int, default=0)
    ap.add_argument("--budget", type=int, default=100, help="flights")
    ap.add_argument("--seed", type=int, default=None, help="sampler seed (default: 1000 + repeat)")
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE for the experiment")
    ap.add_argument("--out", required=True, help="JSON file for the recommended point")
    a = ap.parse_args(argv)
    seed = a.seed if a.seed is not None else 1000 + a.repeat
    result = tune(a.experiment, a.repeat, a.budget, seed, a.set)
    with open(a.out, "w") as f:
        json.dump(result, f, indent=1, sort_keys=True)
    print(json.dumps(result, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
