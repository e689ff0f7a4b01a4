#!/usr/bin/env bash
# install_example.sh BUILD SOURCE WORK GENERATOR CC CXX [LAUNCHER]
# Installs the quadtune build BUILD into WORK/prefix, configures and builds SOURCE's
# examples/own_planner against that prefix only (find_package(quadtune CONFIG)), runs its
# waypoint.yaml into WORK/results.sqlite and checks the stored evaluations: the budget's 3 flights,
# 3 × 2 short-term evaluations, and the held-out validation of the defaults and of the one trial
# on 1 map, all recorded without an error, and at least one tuning flight completed; then flies
# the first stored flight again (own_planner --fly), which must be the stored one (exit 0).
set -euo pipefail
build=$1 src=$2 work=$3 generator=$4 cc=$5 cxx=$6 launcher=${7:-}

rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix"
args=(-S "$src/examples/own_planner" -B "$work/build" -G "$generator"
      -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix"
      -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx")
if [[ -n "$launcher" ]]; then
  args+=(-DCMAKE_CXX_COMPILER_LAUNCHER="$launcher")
fi
cmake "${args[@]}"
cmake --build "$work/build" -j 2
"$work/build/own_planner" "$src/examples/own_planner/waypoint.yaml" "$work/results.sqlite"

count() { sqlite3 "$work/results.sqlite" "SELECT count(*) FROM evaluation WHERE $1"; }
fail=0
expect() {
  local got
  got=$(count "$2")
  if [[ "$got" != "$1" ]]; then
    echo "install_example: expected $1 evaluations with $2, found $got" >&2
    fail=1
  fi
}
expect 3 "kind = 'long'"
expect 6 "kind = 'short'"
expect 2 "kind = 'validation'"
expect 0 "status != 'ok'"
if [[ $(count "kind = 'long' AND message = 'completed'") -lt 1 ]]; then
  echo "install_example: no tuning flight of the waypoint planner completed" >&2
  fail=1
fi
first=$(sqlite3 "$work/results.sqlite" "SELECT min(id) FROM evaluation WHERE kind = 'long'")
if ! "$work/build/own_planner" --fly "$work/results.sqlite" "$first" "$work/flight"; then
  echo "install_example: evaluation $first of the waypoint planner did not fly again the same" >&2
  fail=1
fi
exit $fail
