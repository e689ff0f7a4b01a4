#!/usr/bin/python3
"""Tests of scripts/check_repeats.py on small made-up source trees.

Usage: check_repeats_test.py SOURCE_DIR. Exit status 0 when every case passes.
"""

import pathlib
import sys

import lint_util


def Block(names, lines=6):
  """A function of `lines` code lines (its signature and up to 6 statements), over `names`."""
  a, b = names
  statements = [f"  int {a}0 = Step({b});\n", f"  if ({a}0 > 3) return;\n",
                f"  for (int i = 0; i < {a}0; ++i) Use({b}, i);\n",
                f"  auto {a}1 = Make({b}, {a}0);\n", f"  {a}1.Apply({b});\n",
                f"  Finish({a}1);\n"]
  return f"void Run{a}() {{\n" + "".join(statements[:lines - 1]) + "}\n"


def Check(tree, *extra):
  """(exit status, stdout) of the checker on `tree` (dict: relative path -> text)."""
  return lint_util.RunOnTree(CHECKER, tree, *extra)


def Expect(name, condition, detail=""):
  FAILURES.Expect(name, condition, detail)


def main():
  # Six identical code lines in two files are a repeat; five are not.
  same = Block(("x", "y"))
  rc, out = Check({"engine/a.cpp": same, "planning/b.cpp": "// other\n" + same})
  Expect("six identical lines fail", rc == 1 and "planning/b.cpp:2-7 ~ engine/a.cpp:1-6" in out,
         f"rc {rc}, output {out!r}")
  five = Block(("x", "y"), lines=5)
  rc, out = Check({"engine/a.cpp": five, "planning/b.cpp": five})
  Expect("five lines pass", rc == 0 and out == "", f"rc {rc}, output {out!r}")

  # Comments, blank lines, lone braces and white space do not hide a repeat.
  spaced = same.replace("(x, ", "(x,   ").replace(";\n", ";  // note\n\n").replace("}\n", "\n}\n")
  rc, out = Check({"sim/c.cpp": same, "sim/d.cpp": spaced})
  Expect("comments and spaces folded", rc == 1, f"rc {rc}, output {out!r}")

  # Two places of one file count; a block does not repeat with itself.
  rc, out = Check({"optimizers/e.cpp": same + Block(("p", "q")) + same})
  Expect("same file", rc == 1 and out.count("optimizers/e.cpp") == 2, out)

  # The same block with other names is found by shape only.
  renamed = Block(("p", "q")).replace("Step", "Do")
  Expect("renamed differs", renamed != same.replace("x", "p").replace("y", "q"))
  rc, out = Check({"engine/a.cpp": same, "engine/f.cpp": renamed})
  Expect("renamed passes exact", rc == 0, out)
  rc, out = Check({"engine/a.cpp": same, "engine/f.cpp": renamed}, "--shape")
  Expect("renamed fails by shape", rc == 1 and "engine/f.cpp" in out, out)

  # Struct members and field-list rows are data, not repeats; tests and other folders are not
  # production code.
  members = "struct S {\n" + "".join(f"  double v{i} = {i}.0;\n" for i in range(8)) + "};\n"
  rc, out = Check({"engine/g.hpp": members, "sim/h.hpp": members.replace("S {", "T {")})
  Expect("declarations pass", rc == 0, out)
  fields = ("const Fields<S>& F() {\n  static const Fields<S> f = Fields<S>()\n" +
            "".join(f'      .Number("k{i}", &S::v{i}, Range::Positive(), "m{i}")\n'
                    for i in range(8)) + "  ;\n  return f;\n}\n")
  rc, out = Check({"engine/g.cpp": fields, "sim/h.cpp": fields.replace("S", "T")}, "--shape")
  Expect("field lists pass by shape", rc == 0, out)
  rc, out = Check({"test/a.cpp": same, "test/b.cpp": same})
  Expect("tests are not production code", rc == 0, out)


if __name__ == "__main__":
  SOURCE = pathlib.Path(sys.argv[1])
  CHECKER = SOURCE / "scripts" / "check_repeats.py"
  FAILURES = lint_util.Failures()
  main()
  for failure in FAILURES:
    print("FAIL", failure)
  print(f"check_repeats_test: {'all passed' if not FAILURES else f'{len(FAILURES)} failed'}")
  sys.exit(1 if FAILURES else 0)
