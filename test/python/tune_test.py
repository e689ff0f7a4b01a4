#!/usr/bin/python3
"""quadtune's ask/tell optimisers from Python (quadtune.BayesOpt, PSO, RandomSearch): the same
seed gives the same points, integer parameters come as int, batches, noise, saved state, and bad
input raises ValueError naming the key and what is allowed. PYTHONPATH names the built package."""

import math
import unittest

import quadtune

SPACE = {"x": (-5.0, 5.0), "n": (1, 8, int), "w": (0.01, 10.0, "log")}


def f(p):
    return (p["x"] - 1) ** 2 + abs(p["n"] - 3) + math.log(p["w"]) ** 2


def tune(cls, seed, rounds=12, **options):
    study = cls(SPACE, seed=seed, **options)
    points = []
    for _ in range(rounds):
        x = study.ask()
        points.append(dict(x))
        study.tell(x, f(x))
    return study, points


class Determinism(unittest.TestCase):
    def test_same_seed_same_points_other_seed_other_points(self):
        for cls in (quadtune.BayesOpt, quadtune.PSO, quadtune.RandomSearch):
            with self.subTest(cls=cls.__name__):
                a, pa = tune(cls, 5)
                b, pb = tune(cls, 5)
                _, pc = tune(cls, 6)
                self.assertEqual(pa, pb)
                self.assertEqual(a.best, b.best)
                self.assertNotEqual(pa, pc)

    def test_saved_state_continues_alike(self):
        a, _ = tune(quadtune.BayesOpt, 2, rounds=6)
        b = quadtune.BayesOpt(SPACE, seed=99)
        b.restore_state(a.save_state())
        self.assertEqual([dict(a.ask()) for _ in range(3)], [dict(b.ask()) for _ in range(3)])


class Points(unittest.TestCase):
    def test_types_bounds_and_best(self):
        study, points = tune(quadtune.PSO, 1, rounds=20, num_particles=5)
        for p in points:
            self.assertIsInstance(p["n"], int)
            self.assertIsInstance(p["x"], float)
            self.assertTrue(1 <= p["n"] <= 8 and -5 <= p["x"] <= 5 and 0.01 <= p["w"] <= 10)
        self.assertEqual(len(study), 20)
        self.assertEqual(study.best.value, min(f(p) for p in points))

    def test_batch_noise_discount_and_plain_dict_tell(self):
        study = quadtune.BayesOpt(SPACE, seed=3, initial_design_size=4)
        batch = study.ask(4)
        self.assertEqual(len({tuple(p.values()) for p in batch}), 4)
        for p in batch:
            study.tell(dict(p), f(p), noise=0.01)  # a plain dict is matched to its pending point
        study.notify_context_changed()
        study.advance_age(2.0)
        mean, variance = study.predict(batch[0])
        self.assertTrue(math.isfinite(mean) and variance >= 0)
        self.assertEqual(len(study.ask(3)), 3)


class ComplementaryTuner(unittest.TestCase):
    LONG = {"v": (0.5, 4.0)}
    SHORT = {"w": {"lower": 0.05, "upper": 5.0, "log": True, "default": 0.5}, "n": (2, 8, int)}

    def tune(self, seed):
        tuner = quadtune.Complementary(self.LONG, self.SHORT, seed=seed,
                                       bo={"initial_design_size": 3}, pso={"num_particles": 4})
        flown = []
        for _ in range(6):
            x = tuner.ask()
            flown.append(dict(x))
            tuner.tell(x, (x["v"] - 2.5) ** 2 + math.log(x["w"]) ** 2)
            for _ in range(4):
                s = tuner.ask_short()
                tuner.tell_short(s, math.log(s["w"] / 2) ** 2 + abs(s["n"] - 4))
        return tuner, flown

    def test_flies_the_best_short_point_and_discounts_when_it_changes(self):
        tuner, flown = self.tune(4)
        self.assertEqual({k: flown[0][k] for k in ("w", "n")}, {"w": 0.5, "n": 5})  # defaults
        self.assertIsInstance(flown[0]["n"], int)
        for x in flown[1:]:  # later flights fly PSO's best short-term point at the time
            self.assertIn(x["n"], range(2, 9))
        changes = sum(1 for a, b in zip(flown, flown[1:])
                      if (a["w"], a["n"]) != (b["w"], b["n"]))
        self.assertGreater(changes, 0)
        self.assertEqual(tuner.context_changes, changes)
        self.assertEqual(tuner.best.params["n"], tuner.short.best.params["n"])
        self.assertEqual(self.tune(4)[1], flown)
        self.assertNotEqual(self.tune(5)[1], flown)

    def test_errors(self):
        with self.assertRaisesRegex(ValueError, "'v' is in long_space too"):
            quadtune.Complementary(self.LONG, {"v": (0.0, 1.0)}, seed=1)
        tuner = quadtune.Complementary(self.LONG, self.SHORT, seed=1)
        x = tuner.ask()
        with self.assertRaisesRegex(ValueError, "unknown parameter 'q'; allowed: v, w, n"):
            tuner.tell({**x, "q": 1.0}, 1.0)


class Errors(unittest.TestCase):
    def check(self, call, *words):
        with self.assertRaises(ValueError) as e:
            call()
        for w in words:
            self.assertIn(w, str(e.exception))

    def test_bad_space(self):
        self.check(lambda: quadtune.BayesOpt({"x": (5.0, -5.0)}, seed=1), "space['x']", "upper")
        self.check(lambda: quadtune.BayesOpt({"x": ("a", "b")}, seed=1), "space['x']",
                   "allowed: (lower, upper)")
        self.check(lambda: quadtune.BayesOpt({"x": (0.0, 1.0, "cubic")}, seed=1), "allowed: int")
        self.check(lambda: quadtune.BayesOpt({"x": {"lower": 0, "uper": 1}}, seed=1),
                   "space['x']", "uper", "allowed")
        self.check(lambda: quadtune.BayesOpt({}, seed=1), "space", "non-empty")

    def test_bad_options_and_seed(self):
        self.check(lambda: quadtune.BayesOpt(SPACE, seed=1, initial_designs=3),
                   "bo.initial_designs", "allowed", "initial_design_size")
        self.check(lambda: quadtune.PSO(SPACE, seed=1, num_particles=0), "pso.num_particles")
        self.check(lambda: quadtune.RandomSearch(SPACE, seed=1, anything=1), "random.anything",
                   "no options")
        self.check(lambda: quadtune.BayesOpt(SPACE, seed=-1), "seed", "allowed")
        self.check(lambda: quadtune.BayesOpt(SPACE, seed=1.5), "seed", "allowed")

    def test_bad_tell(self):
        study = quadtune.RandomSearch(SPACE, seed=1)
        x = study.ask()
        self.check(lambda: study.tell({"x": 0.0, "n": 1, "q": 2.0}, 1.0), "unknown parameter 'q'",
                   "allowed: x, n, w")
        self.check(lambda: study.tell({"x": 0.0, "n": 1, "w": 1.0}, 1.0), "waiting for its value")
        self.check(lambda: study.tell(x, float("nan")), "finite")
        self.check(lambda: study.tell(x, "1.0"), "finite")
        study.tell(x, 1.0)
        self.check(lambda: study.tell(x, 1.0), "id")  # told already
        self.check(lambda: study.ask(0), "ask", "int >= 1")

    def test_pso_with_every_particle_pending(self):
        study = quadtune.PSO(SPACE, seed=1, num_particles=2)
        self.assertEqual(len(study.ask(5)), 2)  # never a particle twice at once
        with self.assertRaisesRegex(RuntimeError, "tell or cancel"):
            study.ask()


if __name__ == "__main__":
    unittest.main()
