#!/usr/bin/env bash
# Remakes the README's "Results": the full-scale runs of every paper experiment, their figures
# and tables, copied into docs/results/ (the raw outputs stay in results/full/). Runs one after
# another on all cores; on the 2-core development machine it took about an hour in all (the
# README gives each run's wall time). Reuses the build in build/ (scripts/setup.sh makes it).
#
#   bash scripts/full_results.sh                 # everything
#   bash scripts/full_results.sh benchmark adapt # only these (benchmark benchmark_ego
#                                                # benchmark_ce benchmark_jc density
#                                                # density_ego planners
#                                                # definition speed sweep adapt refinement
#                                                # scaling mpi)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
q="${QUADTUNE_BUILD_DIR:-$root/build}/experiments/quadtune"
raw="$root/results/full"
docs="$root/docs/results"
mkdir -p "$raw" "$docs"
cd "$root"

# timed NAME CMD...: runs CMD; appends "NAME wall_s" to results/full/wall_times.txt and
# replaces NAME's line in docs/results/wall_times.txt (the other steps' lines stay).
timed() {
  local name=$1
  shift
  local start
  start=$(date +%s)
  "$@"
  local line
  line="$name $(($(date +%s) - start))"
  echo "$line" >> "$raw/wall_times.txt"
  touch "$docs/wall_times.txt"
  { grep -v "^$name " "$docs/wall_times.txt" || true; echo "$line"; } > "$docs/wall_times.txt.new"
  mv "$docs/wall_times.txt.new" "$docs/wall_times.txt"
}

# tuning NAME FILE [ARGS...]: `quadtune run FILE ARGS` into results/full/NAME, timed, then its
# figures; tables and figures copied to docs/results/NAME.
tuning() {
  local name=$1 file=$2
  shift 2
  rm -rf "${raw:?}/$name"
  timed "$name" "$q" run --no-plot "$file" --out "$raw/$name" "$@"
  "$q" plot run "$raw/$name"
  mkdir -p "$docs/$name"
  cp "$raw/$name/"{tuning.png,tuning.md,tuning.csv,validation.png,validation.csv,summary.json} \
    "$docs/$name/"
}

# study NAME FILE: `quadtune study FILE` into results/full/NAME, timed; tables and figures
# copied to docs/results/NAME.
study() {
  local name=$1 file=$2
  rm -rf "${raw:?}/$name"
  timed "$name" "$q" study "$file" --out "$raw/$name"
  mkdir -p "$docs/$name"
  cp "$raw/$name/"{study.md,study.csv,study_sweep.png,validation.csv,study_validation.csv} \
    "$raw/$name/summary.json" "$docs/$name/"
}

run_benchmark() { tuning benchmark experiments/benchmark.yaml; }

run_benchmark_jc() {  # BO+PSO with the clearance term in f_s, against the same defaults
  tuning benchmark_jc experiments/benchmark.yaml --set objective.short_term.w_c=0.1 \
    --set 'methods=[default, bo_pso]'
}

run_benchmark_ce() {  # BO alone and BO+PSO with the changing-environment f_s (predicts f_l)
  tuning benchmark_ce experiments/benchmark.yaml \
    --set objective.short_term.kind=changing_environment --set 'methods=[default, bo, bo_pso]'
}

run_benchmark_ego() { tuning benchmark_ego experiments/benchmark_ego.yaml; }  # EGO back end

run_density() { study density experiments/density_study.yaml; }

run_density_ego() { study density_ego experiments/density_study_ego.yaml; }

run_planners() {  # both planners at their defaults on map seeds 1-200 at 1.3 m, and side by side
  timed planners python3 scripts/speed_table.py --planners ipopt ego --speeds 2 --spacings 1.3 \
    --seeds 1 200 --out "$docs/planners"
  /usr/bin/python3 scripts/planner_comparison.py \
    --benchmark ipopt="$raw/benchmark" ego="$raw/benchmark_ego" \
    --density ipopt="$raw/density" ego="$raw/density_ego" --out "$docs/planners"
}

run_sweep() {  # parameter importance at the benchmark's 1.3 m forest
  rm -rf "$raw/sweep"
  timed sweep "$q" sweep experiments/benchmark.yaml --out "$raw/sweep" --points 192 --maps 1 \
    --queries 64
  mkdir -p "$docs/sweep"
  cp "$raw/sweep/"{indices.md,indices.csv,points.csv,sweep.png,summary.json} "$docs/sweep/"
}

run_definition() {  # obstacle counts and default flight times under both density definitions
  timed definition python3 scripts/density_table.py --seeds 10
}

run_speed() {  # collisions and clearance against v_des at the defaults (why re-flights)
  timed speed python3 scripts/speed_table.py --out "$docs/speed"
}

run_adapt() {
  rm -rf "$raw/adapt" "$raw/corridors" "$raw/corridors_ego"
  mkdir -p "$docs/adapt"
  # The context policies, one per planner: each density's v_des chosen by flying a grid on 32
  # maps of the density study's forests (the experiment file holds the Ipopt one, and
  # changing_environment_ego_policy.yaml the EGO one).
  local grid=2,2.5,3,3.5,4,4.5,5
  "$q" policy experiments/changing_environment.yaml --study "$raw/density" --grid "$grid" \
    --maps 32 --threads 2 --out "$raw/policy.yaml"
  "$q" policy experiments/changing_environment.yaml --set planner.type=ego --study "$raw/density" \
    --grid "$grid" --maps 32 --threads 2 --out "$raw/policy_ego.yaml"
  cp "$raw/policy_grid.csv" "$docs/adapt/policy_grid.csv"
  cp "$raw/policy_ego_grid.csv" "$docs/adapt/policy_ego_grid.csv"
  timed adapt "$q" adapt experiments/changing_environment.yaml --policy "$raw/policy.yaml" \
    --threads 2 --out "$raw/adapt"
  cp "$raw/adapt/"{adapt.png,summary.md,summary.json} "$docs/adapt/"
  # Every policy (adapted, context, fixed v_des) on ten held-out corridors, seeds 101-110.
  timed corridors "$q" adapt experiments/changing_environment.yaml --policy "$raw/policy.yaml" \
    --corridors 10 --threads 2 --out "$raw/corridors"
  cp "$raw/corridors/"{corridors.csv,corridors.md} "$docs/adapt/"
  "$q" adapt experiments/changing_environment.yaml --set planner.type=ego \
    --policy "$raw/policy_ego.yaml" --corridors 10 --threads 2 --out "$raw/corridors_ego"
  cp "$raw/corridors_ego/corridors.csv" "$docs/adapt/corridors_ego.csv"
  cp "$raw/corridors_ego/corridors.md" "$docs/adapt/corridors_ego.md"
}

run_refinement() {
  rm -rf "$raw/refinement"
  timed refinement "$q" study experiments/refinement_study.yaml --out "$raw/refinement"
  mkdir -p "$docs/refinement"
  cp "$raw/refinement/"{study.md,study.csv,validation.csv,study_validation.csv,summary.json} \
    "$docs/refinement/"
  cp "$raw/refinement/"refinement_*.png "$docs/refinement/"
}

run_scaling() {
  mkdir -p "$raw/scaling"
  timed scaling "$q" bench experiments/benchmark.yaml --max-threads "$(nproc)" --flights 8 \
    --resolves 2000 --csv "$raw/scaling/bench.csv" --plot
  mkdir -p "$docs/scaling"
  cp "$raw/scaling/"{bench.csv,bench.png} "$docs/scaling/"
}

run_mpi() {  # 2 ranks × 1 thread against 1 rank × 2 threads, same experiment, same results
  local mpi=(mpirun -np 2 --oversubscribe)
  [[ $(id -u) == 0 ]] && mpi+=(--allow-run-as-root)
  rm -rf "$raw/mpi_threads" "$raw/mpi_ranks"
  timed mpi_1rank_2threads "$q" run --no-plot experiments/mpi_scaling.yaml --out "$raw/mpi_threads" \
    --threads 2
  timed mpi_2ranks_1thread "${mpi[@]}" "$q" run --no-plot experiments/mpi_scaling.yaml \
    --out "$raw/mpi_ranks" --threads 1
  mkdir -p "$docs/mpi"
  cp "$raw/mpi_threads/summary.json" "$docs/mpi/summary_1rank_2threads.json"
  cp "$raw/mpi_ranks/summary.json" "$docs/mpi/summary_2ranks_1thread.json"
}

steps=("$@")
((${#steps[@]} > 0)) || steps=(benchmark benchmark_ce benchmark_ego density density_ego planners definition speed sweep
                                adapt refinement scaling mpi)
for step in "${steps[@]}"; do
  echo "== $step"
  "run_$step"
done
echo "figures and tables in $docs; raw outputs in $raw"
