#!/usr/bin/env bash
# The README's main job: installs what is missing, builds quadtune, and runs the default
# experiment, ending in results, figures and a browser report under results/main/ (or
# $QUADTUNE_RESULTS).
#
# 1. The default experiment (experiments/default.yaml): the paper's complementary tuner (BO on the
#    long-term parameters from flights, PSO on the short-term parameters from recorded planning
#    queries) against BO alone and against the planner's defaults, on go-and-return flights
#    through a 1.3 m forest, two random maps. Results in SQLite, a convergence figure and a table.
# 2. Closed-loop go-and-return flights at default parameters through CGAL forests of the paper's
#    four densities, 3.0 / 2.1 / 1.3 / 0.9 m average spacing, with figures and a table.
# Each flight runs the real stack: Bullet physics and controller, depth sensor, local map, A* front
# end, Ipopt minimum-jerk back end, replanning and emergency stop.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${QUADTUNE_BUILD_DIR:-$root/build}"
results="${QUADTUNE_RESULTS:-$root/results/main}"
# QUADTUNE_SKIP_SETUP=1 reuses an existing build (for development).
[[ "${QUADTUNE_SKIP_SETUP:-0}" == 1 ]] || "$root/scripts/setup.sh"

quadtune="$build_dir/experiments/quadtune"
mkdir -p "$results"

echo "== tuning: BO+PSO against BO and the defaults (experiments/default.yaml) -> $results/tuning"
rm -rf "$results/tuning"
# The run ends by drawing its figures, table and browser report (report.html) into the folder.
"$quadtune" run "$root/experiments/default.yaml" --out "$results/tuning"
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
echo "  tuning/tuning.png           best-so-far f_l per method, f_l per flight, re-solves"
echo "  tuning/tuning.md            final best f_l per method, the tuned parameters, held-out validation"
echo "  tuning/validation.png       held-out validation: mean f_l (95% CI) per method and the defaults"
echo "  tuning/report.html          browser report: convergence, importance, slices, 3-D flight replay"
echo "  tuning/results.sqlite       every evaluation (export: quadtune export tuning/results.sqlite --csv DIR)"
echo "  flights.md                  table: flight time, collisions, emergency stops, plans per density"
echo "  flights_topdown.png         the four flights seen from above"
echo "  flight_time_vs_spacing.png  flight time and mean speed against obstacle spacing"
echo "  forest_*/flight_topdown.png one figure per flight; forest_*/flight.csv, plans.csv, summary.json logs"
cat "$results/tuning/tuning.md"
echo
cat "$results/flights.md"
echo
echo "Report (opens offline in a browser): $results/tuning/report.html"
