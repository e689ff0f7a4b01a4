#!/usr/bin/python3
"""Tests of scripts/check_rooms.py on small made-up source trees.

Usage: check_rooms_test.py SOURCE_DIR. Exit status 0 when every case passes.
"""

import pathlib
import sys

import lint_util

CORE_H = "planning/include/quadtune/planning/a.hpp"
IPOPT_H = "planning/include/quadtune/planning/ipopt/b.hpp"
EGO_H = "planning/include/quadtune/planning/ego/c.hpp"
ENGINE_H = "engine/include/quadtune/engine"


def Check(tree):
  """(exit status, stdout) of the checker on `tree` (dict: relative path -> text)."""
  return lint_util.RunOnTree(CHECKER, tree)


def Expect(name, condition, detail=""):
  FAILURES.Expect(name, condition, detail)


def Include(path, quote='"'):
  return f"#include {quote}{path}{'>' if quote == '<' else quote}\n"


def PlanningCases():
  rooms = {CORE_H: "", IPOPT_H: Include("quadtune/planning/a.hpp"),
           EGO_H: Include("quadtune/planning/a.hpp")}
  rc, out = Check(rooms)
  Expect("rooms that include the core", rc == 0 and out == "", out)
  # The core includes no Ipopt or L-BFGS header, and no header of either room.
  for name, line in (("Ipopt header", Include("coin/IpTNLP.hpp", "<")),
                     ("Ipopt header, short path", Include("IpIpoptApplication.hpp", "<")),
                     ("HSL loader", Include("coin/HSLLoader.h", "<")),
                     ("L-BFGS header", Include("lbfgs.h", "<")),
                     ("ipopt room", Include("quadtune/planning/ipopt/b.hpp")),
                     ("ego room", Include("quadtune/planning/ego/c.hpp"))):
    rc, out = Check(dict(rooms, **{"planning/core.cpp": "// the core\n" + line}))
    Expect(f"core includes {name}", rc == 1 and out.startswith("planning/core.cpp:2: "), out)
  rc, out = Check(dict(rooms, **{CORE_H: Include("quadtune/planning/ego/c.hpp")}))
  Expect("core header includes a room", rc == 1 and "a.hpp:1: includes quadtune/planning/ego" in out,
         out)
  # A private header of a room, found next to the core file that includes it.
  rc, out = Check(dict(rooms, **{"planning/ipopt/t.hpp": "", "planning/core.cpp":
                                 Include("ipopt/t.hpp")}))
  Expect("core includes a room's private header", rc == 1 and "core.cpp:1:" in out, out)
  # The rooms keep their solvers and each other apart.
  rc, out = Check(dict(rooms, **{"planning/ipopt/s.cpp": Include("coin/IpTNLP.hpp", "<") +
                                 Include("t.hpp"), "planning/ipopt/t.hpp": ""}))
  Expect("ipopt room includes Ipopt", rc == 0 and out == "", out)
  rc, out = Check(dict(rooms, **{"planning/ipopt/s.cpp": Include("lbfgs.h", "<")}))
  Expect("ipopt room includes L-BFGS", rc == 1 and "s.cpp:1:" in out, out)
  rc, out = Check(dict(rooms, **{"planning/ego/s.cpp": Include("quadtune/planning/ipopt/b.hpp")}))
  Expect("ego room includes the ipopt room", rc == 1 and "s.cpp:1:" in out, out)
  # A line that mentions an include in a comment is not one.
  rc, out = Check(dict(rooms, **{CORE_H: "/// e.g. #include <coin/IpTNLP.hpp>\n"}))
  Expect("comment", rc == 0 and out == "", out)


def EngineCases():
  api = {f"{ENGINE_H}/api/p.hpp": "", "engine/api/p.cpp": Include("quadtune/engine/api/p.hpp")}
  rc, out = Check(dict(api, **{"engine/planners/q.cpp": Include("quadtune/engine/api/p.hpp")}))
  Expect("arrow down", rc == 0 and out == "", out)
  rc, out = Check(dict(api, **{f"{ENGINE_H}/planners/q.hpp": "",
                               "engine/api/r.cpp": Include("quadtune/engine/planners/q.hpp")}))
  Expect("arrow up", rc == 1 and "engine/api/r.cpp:1: " in out and "'planners'" in out, out)
  # Two rooms that include each other: the one whose arrow the table lacks fails.
  rc, out = Check({f"{ENGINE_H}/store/s.hpp": Include("quadtune/engine/tuning/t.hpp"),
                   f"{ENGINE_H}/tuning/t.hpp": Include("quadtune/engine/store/s.hpp")})
  Expect("mutual include", rc == 1 and out.startswith(f"{ENGINE_H}/store/s.hpp:1: includes") and
         f"{ENGINE_H}/tuning/t.hpp:1: includes" not in out, out)
  # A relative include into another room, a file or a header outside every room.
  rc, out = Check({"engine/experiment/u.hpp": "",
                   "engine/store/v.cpp": Include("../experiment/u.hpp"),
                   "engine/api/w.cpp": Include("../experiment/u.hpp")})
  Expect("relative include", rc == 1 and "engine/api/w.cpp:1:" in out and "store" not in out, out)
  rc, out = Check({"engine/loose.cpp": ""})
  Expect("file outside the rooms", rc == 1 and "engine/loose.cpp:1: lies outside" in out, out)
  rc, out = Check({f"{ENGINE_H}/loose.hpp": "", "engine/api/x.cpp":
                   Include("quadtune/engine/loose.hpp")})
  Expect("header outside the rooms", rc == 1 and "engine/api/x.cpp:1: includes" in out, out)
  rc, out = Check({"engine/nursery/y.cpp": ""})
  Expect("unknown room", rc == 1 and "engine/nursery/y.cpp:1: lies outside" in out, out)


def MutualCases():
  # Within one room: a header and its source are one unit; two units may not include each other.
  rc, out = Check({f"{ENGINE_H}/tuning/t.hpp": Include("quadtune/engine/tuning/v.hpp"),
                   f"{ENGINE_H}/tuning/v.hpp": "", "engine/tuning/t.cpp": Include("t.hpp"),
                   "engine/tuning/v.cpp": Include("quadtune/engine/tuning/t.hpp")})
  Expect("mutual units in a room", rc == 1 and "units 't' and 'v' include each other" in out, out)
  rc, out = Check({CORE_H: "", "planning/a.cpp": Include("quadtune/planning/a.hpp"),
                   "planning/d.cpp": Include("quadtune/planning/a.hpp")})
  Expect("one-way units", rc == 0 and out == "", out)


def main():
  PlanningCases()
  MutualCases()
  EngineCases()
  rc, out = Check({})
  Expect("empty tree", rc == 0 and out == "", out)
  # The real table has no cycle.
  sys.path.insert(0, str(CHECKER.parent))
  import check_rooms  # noqa: E402
  Expect("table acyclic", check_rooms.Acyclic(check_rooms.ENGINE_ROOMS) == [])
  Expect("cycle found", check_rooms.Acyclic({"a": ("b",), "b": ("a",)}) != [])

  for line in FAILURES:
    print(line)
  print(f"{len(FAILURES)} failure(s)" if FAILURES else "every case passed")
  return 1 if FAILURES else 0


CHECKER = pathlib.Path(sys.argv[1]) / "scripts" / "check_rooms.py"
FAILURES = lint_util.Failures()

if __name__ == "__main__":
  sys.exit(main())
