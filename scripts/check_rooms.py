#!/usr/bin/python3
"""Checks the include rules of the rooms of planning/ and engine/; fails on a broken one.

Usage: scripts/check_rooms.py [ROOT]

ROOT is the repository root (default: the parent of this script's folder). A room is a folder of
a module: its sources in <module>/<room>/ and its headers in
<module>/include/quadtune/<module>/<room>/. The rules (docs/design.md, "Architecture"):

planning/  The core (every file outside ipopt/ and ego/: map, ESDF, A*, trajectories, query and
           outcome types, the back-end interface) includes no header of the ipopt/ or ego/ room,
           no Ipopt header (coin/..., Ip*.hpp, HSL*) and no L-BFGS header (lbfgs.h). ipopt/ and
           ego/ include the core and their own room only: ipopt/ no L-BFGS header, ego/ no Ipopt
           header.
engine/    Every file lies in a room of ENGINE_ROOMS and includes engine headers of its own room
           and of the rooms ENGINE_ROOMS lets it reach only. The table is acyclic (checked), so
           no two rooms include each other.
Both       No two units of a module include each other, a unit being a header and its source
           (one file name without its suffix, wherever the two lie).

An include is a line `#include "..."` or `#include <...>`; a quoted path is found next to the
including file first, then under the module's include/ folder. Exit status: 0 when every rule
holds, 1 when one does not (each broken rule listed as `path:line: ...`), 2 on bad usage.
"""

import argparse
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from check_code_shape import SUFFIXES  # noqa: E402

INCLUDE_RE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*([<"])([^>"]+)[>"]', re.MULTILINE)

# planning/: the rooms beside the core, and the third-party headers each room keeps to itself.
PLANNING_ROOMS = {"core": ("core",), "ipopt": ("core", "ipopt"), "ego": ("core", "ego")}
IPOPT_RE = re.compile(r"^(coin/|coin-or/|Ip[A-Z]\w*\.hpp$|HSL\w*\.h$)")
LBFGS_RE = re.compile(r"(^|/)lbfgs\.h$")
SOLVER_HEADERS = {"core": ("Ipopt", "L-BFGS"), "ipopt": ("L-BFGS",), "ego": ("Ipopt",)}

# engine/: room -> the other rooms it may include (arrows point down; no cycle).
ENGINE_ROOMS = {
    "api": (),                                              # the plug-in interface, the registry
    "planners": ("api",),                                   # built-in planners, the registry table
    "experiment": ("api", "planners"),                      # experiment files, objectives
    "store": ("api", "experiment"),                         # SQLite store, row codec
    "tuning": ("api", "experiment", "store"),               # tuner, racing, validation, sweep
    "adaptation": ("api", "experiment"),                    # online v_des adaptation, studies
    "distributed": ("api", "experiment", "store", "tuning"),  # runs over MPI
}


def Acyclic(table):
  """The rooms of a cycle in `table` (room -> rooms it may include), or [] when there is none."""
  state = {}

  def Visit(room, path):
    if state.get(room) == "done":
      return []
    if state.get(room) == "open":
      return path[path.index(room):] + [room]
    state[room] = "open"
    for target in table.get(room, ()):
      cycle = Visit(target, path + [room])
      if cycle:
        return cycle
    state[room] = "done"
    return []

  for room in table:
    cycle = Visit(room, [])
    if cycle:
      return cycle
  return []


def Includes(path):
  """(line, delimiter, included path) of every #include of the file at `path`."""
  text = path.read_text(encoding="utf-8", errors="replace")
  return [(text.count("\n", 0, m.start()) + 1, m.group(1), m.group(2))
          for m in INCLUDE_RE.finditer(text)]


def RoomOf(module, relative):
  """The room of `relative` (a path inside `module`/, as parts), or None outside every room."""
  parts = list(relative)
  if parts[:3] == ["include", "quadtune", module]:
    parts = parts[3:]
  if len(parts) < 2:
    return None
  return parts[0]


def Target(root, module, including, delimiter, included):
  """The room an include lands in: (room or None, True when it is a header of `module`)."""
  if delimiter == '"':
    beside = (including.parent / included).resolve()
    module_dir = (root / module).resolve()
    if beside.is_file() and module_dir in beside.parents:
      return RoomOf(module, beside.relative_to(module_dir).parts), True
  prefix = f"quadtune/{module}/"
  if included.startswith(prefix):
    return RoomOf(module, ["include"] + included.split("/")), True
  return None, False


def PlanningRoom(relative):
  room = RoomOf("planning", relative)
  return room if room in ("ipopt", "ego") else "core"


def CheckPlanning(root, path, relative, report):
  room = PlanningRoom(relative)
  for line, delimiter, included in Includes(path):
    target, ours = Target(root, "planning", path, delimiter, included)
    if ours:
      target = target if target in ("ipopt", "ego") else "core"
      if target not in PLANNING_ROOMS[room]:
        report(path, line, f"includes {included}: the planning room '{room}' may include "
               f"{' and '.join(PLANNING_ROOMS[room])} only")
      continue
    for solver, pattern in (("Ipopt", IPOPT_RE), ("L-BFGS", LBFGS_RE)):
      if pattern.search(included) and solver in SOLVER_HEADERS[room]:
        report(path, line, f"includes {included}: the planning room '{room}' includes no "
               f"{solver} header")


def CheckEngine(root, path, relative, report):
  room = RoomOf("engine", relative)
  if room not in ENGINE_ROOMS:
    report(path, 1, f"lies outside the engine's rooms ({', '.join(ENGINE_ROOMS)})")
    return
  allowed = (room,) + ENGINE_ROOMS[room]
  for line, delimiter, included in Includes(path):
    target, ours = Target(root, "engine", path, delimiter, included)
    if not ours:
      continue
    if target not in ENGINE_ROOMS:
      report(path, line, f"includes {included}, which lies outside the engine's rooms")
    elif target not in allowed:
      reach = ", ".join(ENGINE_ROOMS[room]) or "no other room"
      report(path, line, f"includes {included}: the engine room '{room}' may include {reach}, "
             f"not '{target}'")


def Mutual(root, module):
  """'path:line: ...' for each pair of units of `module` that include each other."""
  edges = {}  # (unit, included unit) -> first 'path:line'
  for path in sorted((root / module).rglob("*")):
    if not path.is_file() or path.suffix not in SUFFIXES:
      continue
    for line, delimiter, included in Includes(path):
      _, ours = Target(root, module, path, delimiter, included)
      target = pathlib.PurePosixPath(included).stem
      if ours and target != path.stem:
        edges.setdefault((path.stem, target), f"{path.relative_to(root).as_posix()}:{line}")
  return [f"{where}: units '{a}' and '{b}' include each other (also {edges[(b, a)]})"
          for (a, b), where in sorted(edges.items()) if a < b and (b, a) in edges]


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("root", nargs="?", default=str(pathlib.Path(__file__).resolve().parents[1]))
  args = parser.parse_args()
  root = pathlib.Path(args.root)
  broken = []

  def Report(path, line, what):
    broken.append(f"{path.relative_to(root).as_posix()}:{line}: {what}")

  cycle = Acyclic(ENGINE_ROOMS)
  if cycle:
    broken.append(f"scripts/check_rooms.py: ENGINE_ROOMS has a cycle: {' -> '.join(cycle)}")
  files = 0
  for module, check in (("planning", CheckPlanning), ("engine", CheckEngine)):
    folder = root / module
    if not folder.is_dir():
      continue
    for path in sorted(folder.rglob("*")):
      if path.is_file() and path.suffix in SUFFIXES:
        files += 1
        check(root, path, path.relative_to(folder).parts, Report)
    broken.extend(Mutual(root, module))
  for line in broken:
    print(line)
  if broken:
    print(f"{len(broken)} broken room rule(s)", file=sys.stderr)
    return 1
  print(f"the room rules hold in {files} files of planning/ and engine/", file=sys.stderr)
  return 0


if __name__ == "__main__":
  sys.exit(main())
