#!/usr/bin/env bash
# The README's main job: installs what is missing, builds quadtune, and runs the default
# experiment, ending in results and figures under results/main/ (or $QUADTUNE_RESULTS).
#
# Current default experiment (until the tuning engine lands): closed-loop go-and-return flights
# (24 m out and back) through CGAL forests of the paper's four densities, 3.0 / 2.1 / 1.3 / 0.9 m
# average spacing, with the default planner parameters. Each flight runs the real stack: Bullet
# physics and controller, depth sensor, local map, A* front end, Ipopt minimum-jerk back end,
# replanning and emergency stop.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${QUADTUNE_BUILD_DIR:-$root/build}"
results="${QUADTUNE_RESULTS:-$root/results/main}"
# QUADTUNE_SKIP_SETUP=1 reuses an existing build (for development).
[[ "${QUADTUNE_SKIP_SETUP:-0}" == 1 ]] || "$root/scripts/setup.sh"

quadtune="$build_dir/experiments/quadtune"
mkdir -p "$results"
dirs=()
for density in 3p0 2p1 1p3 0p9; do
  out="$results/forest_$density"
  echo "== go-and-return through the ${density/p/.} m forest -> $out"
  status=0
  "$quadtune" fly --layout-options "$root/assets/layouts/forest_$density.yaml" --seed 1 \
    --out "$out" || status=$?
  # Exit status 3: the flight ran but did not complete the mission (recorded in its summary).
  if [[ $status -ne 0 && $status -ne 3 ]]; then exit "$status"; fi
  dirs+=("$out")
done
"$quadtune" plot flights "${dirs[@]}" --out "$results"
echo
echo "Results in $results:"
echo "  flights.md                  table: flight time, collisions, emergency stops, plans per density"
echo "  flights_topdown.png         the four flights seen from above"
echo "  flight_time_vs_spacing.png  flight time and mean speed against obstacle spacing"
echo "  forest_*/flight_topdown.png one figure per flight; forest_*/flight.csv, plans.csv, summary.json logs"
cat "$results/flights.md"
