#!/usr/bin/python3
"""Tests of the report's importance (experiments/report/quadtune_importance.py) and of the method
naming the figures, tuning.md and the report share (experiments/plot/quadtune_methods.py):

- the Sobol' estimator on the Ishigami function gives its analytic indices;
- the Gaussian-process surrogate, fitted to seeded samples of a function with known indices,
  ranks its parameters and gives their indices, and the irrelevant one scores about 0;
- the marginal likelihood's gradient is the finite-difference one;
- scale() and unscale() are inverse, on a log parameter too;
- partial_dependence() of an additive function is its two terms plus the others' mean;
- every method has one label and one colour, and final_value() is the defaults' mean and the
  others' best.

    report_importance_test.py        exit 0 pass, 1 fail (Debian: python3-numpy, python3-scipy)
"""
import math
import os
import sys

import numpy as np
from scipy import optimize

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "experiments", "report"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "experiments", "plot"))
import quadtune_importance as qi  # noqa: E402
import quadtune_methods as qm  # noqa: E402

failures = []


def check(condition, message):
    print(("ok: " if condition else "FAIL: ") + message)
    if not condition:
        failures.append(message)


def ishigami(u):
    x = -math.pi + 2 * math.pi * u
    return np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])


def test_sobol_ishigami():
    # Analytic indices of Ishigami (a = 7, b = 0.1).
    first_exact = [0.3139, 0.4424, 0.0]
    total_exact = [0.5576, 0.4424, 0.2437]
    first, total = qi.sobol(ishigami, 3, 40000, seed=3)
    for i in range(3):
        check(abs(first[i] - first_exact[i]) < 0.03,
              f"Ishigami S_{i + 1} = {first[i]:.3f} (exact {first_exact[i]})")
        check(abs(total[i] - total_exact[i]) < 0.03,
              f"Ishigami S_T{i + 1} = {total[i]:.3f} (exact {total_exact[i]})")


def test_surrogate_indices():
    # log y = 2 u0 + 0.5 u1 (u2 does nothing): variances 4/12 and 0.25/12, so S_0 = 4/4.25,
    # S_1 = 0.25/4.25, S_2 = 0, and no interactions (S_T = S).
    rng = np.random.default_rng(11)
    X = rng.random((60, 3))
    y = np.exp(2.0 * X[:, 0] + 0.5 * X[:, 1])
    result = qi.importance(X, y, seed=5)
    exact = [4 / 4.25, 0.25 / 4.25, 0.0]
    check(result["loo_r2"] > 0.95, f"surrogate leave-one-out R² = {result['loo_r2']:.3f}")
    for i in range(3):
        check(abs(result["first"][i] - exact[i]) < 0.05,
              f"surrogate S_{i} = {result['first'][i]:.3f} (exact {exact[i]:.3f})")
        check(abs(result["total"][i] - exact[i]) < 0.05,
              f"surrogate S_T{i} = {result['total'][i]:.3f} (exact {exact[i]:.3f})")
    check(list(np.argsort(-result["total"])) == [0, 1, 2], "the ranking is u0, u1, u2")


def test_gradient():
    rng = np.random.default_rng(2)
    X = rng.random((25, 3))
    z = np.sin(3 * X[:, 0]) + X[:, 1] ** 2 + 0.1 * rng.standard_normal(25)
    theta = np.array([-0.5, 0.2, 0.3, 0.1, -2.0])
    _, grad = qi._negative_log_likelihood(theta, X, z)
    numeric = optimize.approx_fprime(theta, lambda t: qi._negative_log_likelihood(t, X, z)[0],
                                     1e-6)
    check(np.allclose(grad, numeric, rtol=1e-4, atol=1e-4),
          f"likelihood gradient {np.round(grad, 4)} equals finite differences "
          f"{np.round(numeric, 4)}")


def test_scale():
    v = np.array([0.05, 0.5, 5.0])
    u = qi.scale(v, 0.05, 5.0, True)
    check(np.allclose(u, [0.0, 0.5, 1.0]), f"log scaling puts 0.5 mid-way in [0.05, 5]: {u}")
    check(np.allclose(qi.unscale(u, 0.05, 5.0, True), v), "unscale inverts scale (log)")
    check(np.allclose(qi.unscale(qi.scale([1.0, 2.5], 1.0, 6.0, False), 1.0, 6.0, False),
                      [1.0, 2.5]), "unscale inverts scale (linear)")


def test_partial_dependence():
    grid, values = qi.partial_dependence(lambda x: x[:, 0] + 2 * x[:, 1] + x[:, 2], 3, 0, 1,
                                         points=5, samples=4000, seed=1)
    expected = grid[None, :] + 2 * grid[:, None] + 0.5
    check(np.allclose(values, expected, atol=0.02),
          "partial dependence of x0 + 2 x1 + x2 over (x0, x1) is x0 + 2 x1 + 0.5")


def test_methods():
    keys = ["default", "random", "pso", "bo", "bo_pso"]
    check(len({qm.label(k) for k in keys}) == 5 and len({qm.colour(k) for k in keys}) == 5,
          "five methods, five labels, five colours")
    check(qm.label("bo_pso") == "BO+PSO" and qm.label("default") == "Default",
          "labels as tuning.md prints them")
    check(qm.order(["bo_pso", "zeta", "default"]) == ["default", "bo_pso", "zeta"],
          "display order: known methods first, then the rest")
    check(qm.colour("zeta") not in {qm.colour(k) for k in keys},
          "an unknown method gets a colour of its own")
    check(qm.final_value("default", [29.0, 31.0, 30.0]) == 30.0,
          "the defaults' final value is the mean of their flights")
    check(qm.final_value("bo", [29.0, 31.0, 30.0]) == 29.0,
          "a tuner's final value is its best flight")


def main():
    test_sobol_ishigami()
    test_surrogate_indices()
    test_gradient()
    test_scale()
    test_partial_dependence()
    test_methods()
    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
