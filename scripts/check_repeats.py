#!/usr/bin/python3
"""Finds blocks of six or more code lines that stand twice in quadtune's production code.

Usage: scripts/check_repeats.py [--min-lines N] [--shape] [ROOT]

ROOT is the repository root (default: the parent of this script's folder). The production code is
every .cpp, .hpp and .h file below common/, physics/, planning/, sim/, optimizers/, engine/ and
experiments/. Before comparing, each line loses its comments and surrounding white space, runs of
white space fold to one, and lines that carry no code of their own are passed over: blank lines,
comment lines, preprocessor lines, lone punctuation (`}`, `});`, ...), access labels and plain
declarations without a call (`double flight_time = 0.0;`: the layout of a struct is data, not
logic that could be shared).

Two blocks repeat when N consecutive remaining lines (default 6) are the same text in two places
(two files, or two places of one file that do not overlap). With --shape, lines are compared by
shape: every identifier that is not a C++ keyword, every number and every string or character
literal stand for themselves only by kind, so a block copied with other names is found too. A
table is not a repeat: shape mode passes over the rows of field lists and enum name tables and
over a window whose lines have at most three shapes between them (the same call with other
arguments, row after row).

Exit status: 0 when nothing repeats, 1 when a block does (each pair as
`path:first-last ~ path:first-last`), 2 on bad usage.
"""

import argparse
import pathlib
import re
import sys

MODULES = ("common", "physics", "planning", "sim", "optimizers", "engine", "experiments")
SUFFIXES = (".cpp", ".hpp", ".h")
SKIP_PARTS = ("node_modules",)
KEYWORDS = set("""
alignas alignof auto bool break case catch char class const consteval constexpr constinit
const_cast continue co_await co_return co_yield decltype default delete do double dynamic_cast
else enum explicit export extern false float for friend goto if inline int long mutable namespace
new noexcept nullptr operator override final private protected public register reinterpret_cast
requires return short signed sizeof static static_assert static_cast struct switch template this
thread_local throw true try typedef typeid typename union unsigned using virtual void volatile
wchar_t while std size_t
""".split())
TOKEN_RE = re.compile(r'''R"(?P<d>[^(\s]{0,16})\(.*?\)(?P=d)"|"(?:\\.|[^"\\])*"|'(?:\\.|[^'\\])*'|'''
                      r"[A-Za-z_]\w*|\d[\w.']*|\S")
NO_CODE_RE = re.compile(r"^[\s{}()\[\];,:]*$|^(public|private|protected)\s*:$")
# A declaration without a call: `double flight_time = 0.0;`, `std::string message;` (data layout).
DECLARATION_RE = re.compile(r"^(static |const |constexpr |inline |mutable )*[\w:]+(<[\w:<>, *&]*>)?[*&]? "
                            r"[*&]?\w+(\[\w*\])?( = [^;()]*| ?\{[^;()]*\})?;$")


def StripComments(text):
  """Returns `text` with // and /* */ comments removed (string literals are respected)."""
  out = []
  i, n = 0, len(text)
  while i < n:
    if text.startswith("//", i):
      while i < n and text[i] != "\n":
        i += 1
      continue
    if text.startswith("/*", i):
      end = text.find("*/", i + 2)
      end = n if end < 0 else end + 2
      out.append("\n" * text.count("\n", i, end))
      i = end
      continue
    c = text[i]
    if c == '"' or (c == "'" and not (i > 0 and text[i - 1].isalnum())):
      j = i + 1
      while j < n and text[j] != c and text[j] != "\n":
        j += 2 if text[j] == "\\" else 1
      out.append(text[i:j + 1])
      i = j + 1
      continue
    out.append(c)
    i += 1
  return "".join(out)


def Shape(line):
  """The line with identifiers, numbers and literals replaced by their kind."""
  parts = []
  for m in TOKEN_RE.finditer(line):
    t = m.group(0)
    if t[0] in "\"'R" and len(t) > 1 and (t[0] != "R" or t[1] == '"'):
      parts.append("S")
    elif t[0].isalpha() or t[0] == "_":
      parts.append(t if t in KEYWORDS else "I")
    elif t[0].isdigit():
      parts.append("N")
    else:
      parts.append(t)
  return " ".join(parts)


# Shape mode passes over the rows of the project's declarative tables: field-list chains
# (`.Number("key", ...)` and their continuation lines), enum name tables and enumerators. Their
# shape is prescribed (common/fields.hpp, common/enum_names.hpp); their content differs.
TABLE_ROW_RE = re.compile(r'^(\.\w+\(|.*\bEnumName\{|k\w+( = [^,]*)?,?$|(S ?[,;)]* ?)+$|'
                          r'\{ ?S(, S)* ?,?$)')


def CodeLines(path, shape=False):
  """(line number, folded text) for every line of `path` that carries code."""
  text = StripComments(path.read_text(encoding="utf-8", errors="replace"))
  lines = []
  for number, raw in enumerate(text.split("\n"), start=1):
    line = " ".join(raw.split())
    if not line or line.startswith("#") or NO_CODE_RE.match(line) or DECLARATION_RE.match(line):
      continue
    if shape:
      line = Shape(line)
      if TABLE_ROW_RE.match(line) or TABLE_ROW_RE.match(" ".join(raw.split())):
        continue
    lines.append((number, line))
  return lines


def SourceFiles(root):
  for module in MODULES:
    base = root / module
    if not base.is_dir():
      continue
    for path in sorted(base.rglob("*")):
      if path.suffix in SUFFIXES and path.is_file() and not set(path.parts) & set(SKIP_PARTS):
        yield path


def FindRepeats(root, min_lines, shape):
  """Pairs ((path, first, last), (path, first, last)) of repeated blocks, one per file pair run."""
  seen = {}  # window key → (path, index, first line, last line) of its first place
  pairs = []
  reported = set()  # (path a, path b, index a - index b): one row per aligned run
  for path in SourceFiles(root):
    lines = CodeLines(path, shape)
    keys = [t for _, t in lines]
    rel = path.relative_to(root).as_posix()
    for i in range(len(lines) - min_lines + 1):
      window = tuple(keys[i:i + min_lines])
      if shape and len(set(window)) <= 3:
        continue
      place = (rel, i, lines[i][0], lines[i + min_lines - 1][0])
      first = seen.get(window)
      if first is None:
        seen[window] = place
        continue
      if first[0] == rel and i - first[1] < min_lines:
        continue  # overlaps its first place
      run = (first[0], rel, first[1] - i)
      if run in reported:
        continue
      reported.add(run)
      pairs.append((first, place))
  return pairs


def main(argv):
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--min-lines", type=int, default=6)
  parser.add_argument("--shape", action="store_true")
  parser.add_argument("root", nargs="?", default=str(pathlib.Path(__file__).resolve().parent.parent))
  args = parser.parse_args(argv)
  if args.min_lines < 2:
    parser.error("--min-lines must be at least 2")
  root = pathlib.Path(args.root)
  pairs = FindRepeats(root, args.min_lines, args.shape)
  for a, b in pairs:
    print(f"{a[0]}:{a[2]}-{a[3]} ~ {b[0]}:{b[2]}-{b[3]}")
  kind = "same-shape" if args.shape else "identical"
  print(f"{len(pairs)} {kind} blocks of {args.min_lines} code lines repeated", file=sys.stderr)
  return 1 if pairs else 0


if __name__ == "__main__":
  sys.exit(main(sys.argv[1:]))
