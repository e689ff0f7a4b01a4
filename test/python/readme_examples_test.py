#!/usr/bin/python3
"""The README's two Python examples (test/python/example_*.py): each stands in README.md word for
word, runs (in a fresh folder, with the repository's examples/ beside it) and prints what it
should.

Usage: readme_examples_test.py SOURCE_DIR ask_tell|planner
(PYTHONPATH names the built package: build/python.)
"""

import ast
import os
import re
import subprocess
import sys
import tempfile


def run_example(source_dir, name):
    path = os.path.join(source_dir, "test", "python", f"example_{name}.py")
    text = open(path).read()
    readme = open(os.path.join(source_dir, "README.md")).read()
    assert text.strip() in readme, f"README.md does not hold {path} word for word"
    with tempfile.TemporaryDirectory() as cwd:
        os.symlink(os.path.join(source_dir, "examples"), os.path.join(cwd, "examples"))
        done = subprocess.run([sys.executable, path], cwd=cwd, capture_output=True, text=True,
                              check=False)
    assert done.returncode == 0, f"{path} failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def check_ask_tell(out):
    m = re.fullmatch(r"Best\(params=(\{.*\}), value=(\S+), observed=(\S+)\)\n", out)
    assert m, f"unexpected output: {out!r}"
    params = ast.literal_eval(m.group(1))
    assert abs(params["x"] - 1) < 0.5 and abs(params["y"] + 2) < 0.5, params
    assert params["n"] == 3 and isinstance(params["n"], int), params
    assert float(m.group(3)) < 0.5, out


def check_planner(out):
    rows = re.findall(r"^(\w+) held-out f_l (\S+) (\{.*\})$", out, re.M)
    assert [r[0] for r in rows] == ["default", "bo_pso"], f"unexpected output: {out!r}"
    for method, value, params in rows:
        # 1000 is the failure value: below it, the held-out flight reached its goal and back.
        assert 0 < float(value) <= 1000, (method, value)
        assert set(ast.literal_eval(params)) >= {"n_pol", "v_des", "t_pl"}, params
    # The Python planner flies the held-out map with its defaults (a 3-flight tuning's point may
    # fail there).
    assert float(rows[0][1]) < 1000, rows[0]


def main():
    source_dir, name = sys.argv[1], sys.argv[2]
    out = run_example(source_dir, name)
    {"ask_tell": check_ask_tell, "planner": check_planner}[name](out)
    print(out, end="")
    print(f"example_{name}.py: ok")


if __name__ == "__main__":
    main()
