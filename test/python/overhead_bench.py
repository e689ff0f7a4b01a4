#!/usr/bin/python3
"""The Python call overhead of quadtune's ask/tell optimisers (a benchmark, not a test).

Tunes a 3-parameter quadratic for ROUNDS ask/tell rounds with BayesOpt (20 × ROUNDS with PSO
and RandomSearch) and compares
the wall time of the Python loop (study.ask(), f, study.tell()) with the time spent inside the C++
Optimizer::Ask and Tell (measured by quadtune._core around those calls). The overhead per round
is (loop - C++ Ask - C++ Tell - f) / rounds, stated as a share of the C++ Ask time per round.

    PYTHONPATH=build/python /usr/bin/python3 test/python/overhead_bench.py [ROUNDS]
"""

import sys
import time

import quadtune

SPACE = {"x": (-5.0, 5.0), "y": (-5.0, 5.0), "n": (1, 8, int)}


def f(p):
    return (p["x"] - 1) ** 2 + (p["y"] + 2) ** 2 + abs(p["n"] - 3)


def measure(cls, rounds, **options):
    study = cls(SPACE, seed=1, **options)
    f_s = 0.0
    start = time.perf_counter()
    for _ in range(rounds):
        x = study.ask()
        t = time.perf_counter()
        value = f(x)
        f_s += time.perf_counter() - t
        study.tell(x, value)
    loop = time.perf_counter() - start
    ask, tell = study._core.ask_seconds, study._core.tell_seconds
    overhead = (loop - ask - tell - f_s) / rounds
    return ask / rounds, tell / rounds, overhead


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    print(f"BayesOpt {rounds} rounds, PSO and RandomSearch {20 * rounds}; 3 parameters")
    print("| optimiser | C++ Ask per round | C++ Tell per round | Python overhead per round | "
          "overhead / C++ Ask |")
    print("|---|---|---|---|---|")
    # PSO and random search ask in microseconds: 20 × the rounds, for a steadier mean.
    for cls, n, options in ((quadtune.BayesOpt, rounds, {}),
                            (quadtune.PSO, 20 * rounds, {"num_particles": 10}),
                            (quadtune.RandomSearch, 20 * rounds, {})):
        ask, tell, overhead = measure(cls, n, **options)
        print(f"| {cls.__name__} | {ask * 1e6:.1f} µs | {tell * 1e6:.1f} µs | "
              f"{overhead * 1e6:.1f} µs | {100 * overhead / ask:.2f}% |")


if __name__ == "__main__":
    main()
