#!/usr/bin/env bash
# install_example.sh BUILD SOURCE WORK GENERATOR CC CXX [LAUNCHER]
# Installs the quadtune build BUILD into WORK/prefix, configures and builds SOURCE's
# examples/own_planner against that prefix only (find_package(quadtune CONFIG)), runs its
# waypoint.yaml into WORK/run/results.sqlite and checks the stored evaluations: the budget's 3
# flights, 3 × 2 short-term evaluations, and the held-out validation of the defaults and of the
# one trial on 1 map, all recorded without an error, and at least one tuning flight completed;
# then flies the first stored flight again (own_planner --fly) into WORK/flight, which must be
# the stored one (exit 0). From WORK, with the installed program only (WORK/prefix/bin/quadtune,
# its scripts under the prefix): `quadtune plot run` and `quadtune report` of the run (the
# report without a 3-D replay, saying that `own_planner --fly` flies the waypoint planner
# again), and `quadtune plot flight` and `quadtune report` of the flight flown again.
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
mkdir -p "$work/run"
store=$work/run/results.sqlite
"$work/build/own_planner" "$src/examples/own_planner/waypoint.yaml" "$store"

count() { sqlite3 "$store" "SELECT count(*) FROM evaluation WHERE $1"; }
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
first=$(sqlite3 "$store" "SELECT min(id) FROM evaluation WHERE kind = 'long'")
if ! "$work/build/own_planner" --fly "$store" "$first" "$work/flight"; then
  echo "install_example: evaluation $first of the waypoint planner did not fly again the same" >&2
  fail=1
fi

# The figures and the report from the install alone.
unset QUADTUNE_ASSETS QUADTUNE_PLOT_SCRIPT QUADTUNE_REPORT_SCRIPT QUADTUNE_REPORT_JS
quadtune=$work/prefix/bin/quadtune
cd "$work"
check() {  # check WHAT COMMAND...: runs COMMAND (debug log in WORK/WHAT.log), which must pass
  local what=$1
  shift
  if ! "$quadtune" --log-level debug "$@" > "$work/$what.log" 2>&1; then
    echo "install_example: quadtune $* failed: $(tail -3 "$work/$what.log")" >&2
    fail=1
  elif grep -qE "$src/(experiments|assets)/" "$work/$what.log"; then
    echo "install_example: quadtune $* used the source tree's files:" \
      "$(grep -E "$src/(experiments|assets)/" "$work/$what.log" | head -2)" >&2
    fail=1
  elif ! grep -q "running .*'$work/prefix/share/quadtune/experiments/" "$work/$what.log"; then
    echo "install_example: quadtune $* ran no installed script" >&2
    fail=1
  fi
}
check plot_run plot run run
check report_run report run
if ! grep -q "planner.type 'waypoint' .* not registered in this program.*own_planner --fly" \
    "$work/report_run.log"; then
  echo "install_example: quadtune report run does not say that own_planner --fly replays" >&2
  fail=1
fi
[[ -s run/report.html && -s run/tuning.png ]] || {
  echo "install_example: no run/report.html or run/tuning.png" >&2
  fail=1
}
check plot_flight plot flight flight
check report_flight report flight
[[ -s flight/report.html && -s flight/flight_topdown.png ]] || {
  echo "install_example: no flight/report.html or flight/flight_topdown.png" >&2
  fail=1
}
exit $fail
