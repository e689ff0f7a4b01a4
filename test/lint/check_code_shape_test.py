#!/usr/bin/python3
"""Tests of scripts/check_code_shape.py on small made-up source trees.

Usage: check_code_shape_test.py SOURCE_DIR. Exit status 0 when every case passes.
"""

import pathlib
import sys

import lint_util


def Body(lines, indent="  "):
  return "".join(f"{indent}x += {i};\n" for i in range(lines))


def Check(tree, *extra):
  """(exit status, stdout) of the checker on `tree` (dict: relative path -> text)."""
  return lint_util.RunOnTree(CHECKER, tree, *extra)


def Expect(name, condition, detail=""):
  FAILURES.Expect(name, condition, detail)


def main():
  # A function of exactly 100 lines passes, one of 101 fails (signature to closing brace).
  at_limit = "int F() {\n  int x = 0;\n" + Body(96) + "  return x;\n}\n"
  rc, out = Check({"engine/a.cpp": at_limit})
  Expect("100 lines pass", rc == 0 and out == "", f"rc {rc}, output {out!r}")
  over = "namespace q {\nint G(int a,\n      int b) {\n  int x = a + b;\n" + Body(96) + \
         "  return x;\n}\n}  // namespace q\n"
  rc, out = Check({"planning/b.cpp": over})
  Expect("101 lines fail", rc == 1 and "planning/b.cpp:2: G 101 lines" in out, out)

  # A lambda's lines count towards the function that holds it; braces in strings, comments and
  # character literals are not code.
  lambda_inside = ("void H() {\n  auto f = [](int v) {\n    int x = v;\n" + Body(120, "    ") +
                   "    return x;\n  };\n  const char* s = \"}}{\";\n  // }\n  char c = '}';\n"
                   "  (void)f; (void)s; (void)c;\n}\n")
  rc, out = Check({"optimizers/c.cpp": lambda_inside})
  Expect("lambda counts", rc == 1 and ": H " in out, out)

  # Member functions inside a class, functions inside extern "C" and a constructor with brace
  # member initialisers are found; a long class with short methods passes.
  klass = ("class K {\n public:\n  K() : a_{1}, b_(2) {\n" + Body(125) + "  }\n" +
           "".join(f"  int M{i}() {{ return {i}; }}\n" for i in range(200)) +
           " private:\n  int a_, b_;\n  int x = 0;\n};\n")
  rc, out = Check({"sim/d.hpp": klass})
  Expect("constructor found", rc == 1 and ": K " in out and "M1" not in out, out)
  extern_c = 'extern "C" {\nvoid E() {\n  int x = 0;\n' + Body(130) + "}\n}\n"
  rc, out = Check({"engine/e.cpp": extern_c})
  Expect("extern C", rc == 1 and ": E " in out, out)

  # Every production module counts, experiments/ (the program) included; tests, examples and the
  # report's JavaScript packages do not.
  for module in ("common", "physics", "physics/layout", "sim", "optimizers", "experiments"):
    rc, out = Check({f"{module}/f.cpp": over})
    Expect(f"{module} checked", rc == 1 and f"{module}/f.cpp:2: G 101 lines" in out, out)
  rc, out = Check({"test/f.cpp": over, "examples/own/f.cpp": over,
                   "experiments/report/js/node_modules/x/f.h": over})
  Expect("other folders ignored", rc == 0 and out == "", out)
  # --max-lines moves the limit.
  rc, out = Check({"engine/a.cpp": at_limit}, "--max-lines", "80")
  Expect("--max-lines", rc == 1 and ": F 100 lines" in out, out)

  for line in FAILURES:
    print(line)
  print(f"{len(FAILURES)} failure(s)" if FAILURES else "every case passed")
  return 1 if FAILURES else 0


CHECKER = pathlib.Path(sys.argv[1]) / "scripts" / "check_code_shape.py"
FAILURES = lint_util.Failures()

if __name__ == "__main__":
  sys.exit(main())
