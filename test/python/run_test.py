#!/usr/bin/python3
"""Experiments run from Python (quadtune.run / resume) with a planner written in Python
(quadtune.register_planner), flown in quadtune's closed loop: a dict and a YAML file give the same
run, the same seed the same store, resume replays, progress reaches a callable, and failures
(a bad key, a planner or a callback that raises) say what failed.

Usage: run_test.py SOURCE_DIR (PYTHONPATH names the built package)."""

import copy
import os
import sys
import tempfile
import unittest

import yaml

import quadtune

SOURCE_DIR = sys.argv.pop(1) if len(sys.argv) > 1 else "."


class Path:
    """Every vertex of the A* path: the simplest waypoint planner."""

    def __init__(self):
        self.calls = 0

    def waypoints(self, query, params):
        self.calls += 1
        assert isinstance(params["n_pol"], int) and params["v_des"] > 0
        return query.path


class Broken:
    def waypoints(self, query, params):
        raise ZeroDivisionError("planner bug")


def config(planner="py_path", **budget):
    with open(os.path.join(SOURCE_DIR, "examples", "own_planner", "waypoint.yaml")) as f:
        c = yaml.safe_load(f)
    c["planner"]["type"] = planner
    del c["planner"]["waypoint"]
    c["methods"] = ["random"]
    c["budget"].update(flights=2, **budget)
    return c


class Run(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.planner = Path()
        quadtune.register_planner("py_path", cls.planner)
        quadtune.register_planner("py_broken", Broken())
        cls.seen = []
        cls.first = quadtune.run(config(), cls.out("first"), progress=cls.seen.append)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def out(cls, name):
        return os.path.join(cls.tmp.name, name)

    def test_outcome_progress_and_planner_calls(self):
        s, r = self.first.summary, self.first.results
        self.assertEqual(s["status"], "completed")
        self.assertEqual([t["method"] for t in s["trials"]], ["random"])
        self.assertEqual(len(r.long), 2)
        self.assertEqual(sorted(r.validation["trial_id"].unique().tolist())[:1], [0])
        self.assertEqual([v["method"] for v in s["validation"]], ["default", "random"])
        self.assertTrue(os.path.isfile(os.path.join(self.out("first"), "summary.json")))
        self.assertGreater(self.planner.calls, 0)
        self.assertTrue(self.seen and self.seen[-1]["flights_done"] == 2, self.seen)

    def test_same_seed_same_store_yaml_file_and_one_thread_alike(self):
        path = self.out("experiment.yaml")
        with open(path, "w") as f:
            yaml.safe_dump(config(), f)
        again = quadtune.run(path, self.out("again"), progress=False)
        # Reproducible mode: the same store on one thread as on the experiment's two.
        one_thread = quadtune.run(config(), self.out("one_thread"), threads=1, progress=False)
        for b in (again, one_thread):
            self.assertEqual(self.first.results.long["value"].tolist(),
                             b.results.long["value"].tolist())
            self.assertEqual(self.first.summary["validation"], b.summary["validation"])

    def test_resume_replays(self):
        out = self.out("resumed")
        quadtune.run(config(), out, progress=False)
        resumed = quadtune.resume(config(), out, progress=False)
        self.assertEqual(resumed.summary["trials"][0]["replayed"], 2)
        self.assertEqual(resumed.summary["trials"][0]["best_value"],
                         self.first.summary["trials"][0]["best_value"])
        with self.assertRaisesRegex(ValueError, "holds a run already.*resume=True"):
            quadtune.run(config(), out, progress=False)

    def test_bad_key_is_named(self):
        c = config()
        c["budget"]["flightz"] = 3
        with self.assertRaisesRegex(ValueError, r"<dict>.*budget\.flightz.*allowed"):
            quadtune.run(c, self.out("bad"), progress=False)
        c = copy.deepcopy(config("no_such_planner"))
        with self.assertRaisesRegex(ValueError, "planner.type.*py_path"):
            quadtune.run(c, self.out("bad2"), progress=False)

    def test_registration_errors(self):
        with self.assertRaisesRegex(ValueError, "ipopt"):
            quadtune.register_planner("ipopt", Path())
        with self.assertRaisesRegex(ValueError, r"waypoints\(query, params\)"):
            quadtune.register_planner("py_none", object())

    def test_python_planner_failure_stops_the_run(self):
        with self.assertRaisesRegex(RuntimeError, "Python planner 'py_broken'.*planner bug"):
            quadtune.run(config("py_broken"), self.out("broken"), progress=False)
        # The failing round was cancelled: nothing of it is stored, so a fixed planner resumes.
        self.assertEqual(len(quadtune.load(self.out("broken")).long), 0)
        quadtune.register_planner("py_broken", Path())  # the same name, a fixed planner
        fixed = quadtune.resume(config("py_broken"), self.out("broken"), progress=False)
        self.assertEqual(fixed.summary["status"], "completed")
        self.assertEqual(fixed.results.long["value"].tolist(),
                         self.first.results.long["value"].tolist())

    def test_progress_callback_failure_is_raised(self):
        def progress(p):
            raise KeyError("from the callback")
        with self.assertRaisesRegex(KeyError, "from the callback"):
            quadtune.run(config(), self.out("callback"), progress=progress)


if __name__ == "__main__":
    unittest.main()
