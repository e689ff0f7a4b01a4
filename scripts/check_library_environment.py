#!/usr/bin/python3
"""Lists every place where quadtune's library code touches the process environment; fails on one.

Usage: scripts/check_library_environment.py [ROOT]

ROOT is the repository root (default: the parent of this script's folder). The library code is
every .cpp, .hpp, .h and .cc file below common/, physics/, planning/, sim/, optimizers/ and
engine/ (include/ folders included); the `quadtune` program (experiments/), the tests and the
examples may read the environment and hand what they read to the library as options. A use is
a call or mention of getenv, secure_getenv, setenv, putenv, unsetenv, clearenv or environ in the
code, comments and string literals left out (scripts/check_code_shape.py's Blank).

ALLOWED names the files whose uses the check lets pass for now; they are listed with
`(allowed)`. Exit status: 0 when no file outside ALLOWED touches the environment, 1 when one
does (each use listed as `path:line: name`), 2 on bad usage.
"""

import argparse
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from check_code_shape import Blank, SUFFIXES  # noqa: E402

LIBRARY = ("common", "physics", "planning", "sim", "optimizers", "engine")
ENVIRONMENT_RE = re.compile(
    r"\b(getenv|secure_getenv|setenv|putenv|unsetenv|clearenv|_?environ)\b")
# engine/distributed/distributed.cpp reads the MPI launch size (OMPI_COMM_WORLD_SIZE, PMI_SIZE,
# SLURM_*) in MpiLaunchSize; other work on issue 41 is rewriting that file, and the read moves to
# the program there; the entry goes with it.
ALLOWED = {"engine/distributed/distributed.cpp"}


def Uses(path):
  """(line, name) of every environment use in the file at `path`."""
  text = Blank(path.read_text(encoding="utf-8", errors="replace"))
  return [(text.count("\n", 0, m.start()) + 1, m.group(1)) for m in ENVIRONMENT_RE.finditer(text)]


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("root", nargs="?", default=str(pathlib.Path(__file__).resolve().parents[1]))
  args = parser.parse_args()
  root = pathlib.Path(args.root)
  failing = 0
  allowed_uses = 0
  files = 0
  for module in LIBRARY:
    folder = root / module
    if not folder.is_dir():
      continue
    for path in sorted(folder.rglob("*")):
      if path.suffix not in SUFFIXES or not path.is_file():
        continue
      files += 1
      relative = path.relative_to(root).as_posix()
      for line, name in Uses(path):
        allowed = relative in ALLOWED
        allowed_uses += 1 if allowed else 0
        failing += 0 if allowed else 1
        print(f"{relative}:{line}: {name}{' (allowed)' if allowed else ''}")
  if failing:
    print(f"{failing} use(s) of the environment in library code", file=sys.stderr)
    return 1
  but = f" but the {allowed_uses} allowed use(s)" if allowed_uses else ""
  print(f"no use of the environment in {files} library files{but}", file=sys.stderr)
  return 0


if __name__ == "__main__":
  sys.exit(main())
