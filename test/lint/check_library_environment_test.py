#!/usr/bin/python3
"""Tests of scripts/check_library_environment.py on small made-up source trees.

Usage: check_library_environment_test.py SOURCE_DIR. Exit status 0 when every case passes.
"""

import pathlib
import sys

import lint_util


def Check(tree):
  """(exit status, stdout) of the checker on `tree` (dict: relative path -> text)."""
  return lint_util.RunOnTree(CHECKER, tree)


def Expect(name, condition, detail=""):
  FAILURES.Expect(name, condition, detail)


def main():
  reads = '#include <cstdlib>\nconst char* Home() {\n  return std::getenv("HOME");\n}\n'
  # A read in any library module fails, with its file and line.
  for module in ("common", "physics", "planning", "sim", "optimizers", "engine"):
    rc, out = Check({f"{module}/a.cpp": reads})
    Expect(f"getenv in {module}", rc == 1 and f"{module}/a.cpp:3: getenv" in out, out)
  header = "engine/include/quadtune/engine/b.hpp"
  rc, out = Check({header: "inline char** E() { return environ; }\n"})
  Expect("environ in a header", rc == 1 and "b.hpp:1: environ" in out, out)
  rc, out = Check({"sim/c.cpp": 'void S() { setenv("A", "1", 1); }\n'})
  Expect("setenv", rc == 1 and "sim/c.cpp:1: setenv" in out, out)
  # The program, the tests and the examples may read it; comments and strings are not code.
  rc, out = Check({"experiments/main.cpp": reads, "test/engine/t.cpp": reads,
                   "examples/own/main.cpp": reads})
  Expect("outside the library", rc == 0 and out == "", out)
  rc, out = Check({"engine/d.cpp": '// std::getenv("X") is not called here\n'
                                   'const char* kWhy = "getenv";\nint environment = 0;\n'})
  Expect("comments, strings, longer names", rc == 0 and out == "", out)
  # An allowed file is listed and passes.
  rc, out = Check({"engine/distributed/distributed.cpp": reads})
  Expect("allowed file",
         rc == 0 and "engine/distributed/distributed.cpp:3: getenv (allowed)" in out, out)

  for line in FAILURES:
    print(line)
  print(f"{len(FAILURES)} failure(s)" if FAILURES else "every case passed")
  return 1 if FAILURES else 0


CHECKER = pathlib.Path(sys.argv[1]) / "scripts" / "check_library_environment.py"
FAILURES = lint_util.Failures()

if __name__ == "__main__":
  sys.exit(main())
