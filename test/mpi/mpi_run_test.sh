#!/usr/bin/env bash
# Distributed runs over MPI, through the `quadtune` program (see engine/distributed/distributed.hpp).
#
#   mpi_run_test.sh equal QUADTUNE MPIEXEC WORKDIR
#       the toy experiment (10 trials) with 1 process and with 2 ranks: identical stores
#       (every evaluation's method, kind, iteration, index, params, terms, value, status and
#       message; every trial's id, status, best point and value).
#   mpi_run_test.sh kill QUADTUNE MPIEXEC WORKDIR
#       rank 1 is killed (SIGKILL) mid-run: rank 0 reports it, the store is partial and
#       `--resume` on 2 ranks completes it to the uninterrupted run's results.
#   mpi_run_test.sh batch QUADTUNE MPIEXEC WORKDIR
#       rank 1 is killed while a batch of its rows is in flight (sent, not acknowledged): every
#       evaluation rank 0 acknowledged is in the store, at most the in-flight ones besides, rank
#       0's count of committed evaluations is the store's, and `--resume` completes the store to
#       the uninterrupted run's rows, none missing and none twice.
#   mpi_run_test.sh ipopt QUADTUNE MPIEXEC WORKDIR SOURCE_DIR
#       as `equal`, with the real planner: experiments/tiny.yaml (Bullet flights, Ipopt solves),
#       three methods × two repeats.
#
# QUADTUNE is the program: quadtune_test_cli (test/support: with the test planner toy) for the
# toy modes, quadtune for ipopt.
# Runs as root too (--allow-run-as-root), and on fewer cores than ranks (--oversubscribe).
set -euo pipefail
mode=$1 quadtune=$2 mpiexec=$3 work=$4
rm -rf "$work"
mkdir -p "$work"
cd "$work"

mpi=("$mpiexec" -np 2 --oversubscribe)
if [[ $(id -u) == 0 ]]; then mpi+=(--allow-run-as-root); fi
# Libraries preloaded into the ranks only (the AddressSanitizer build sets it: CMakeLists.txt).
if [[ -n ${QUADTUNE_MPI_RANK_PRELOAD:-} ]]; then mpi+=(env "LD_PRELOAD=$QUADTUNE_MPI_RANK_PRELOAD"); fi

# The toy planner takes microseconds per flight; each mode slows its flights down. Rank 0 runs
# trials from the same queue as rank 1, so without a delay it could finish them all before rank 1
# asks for its first one (equal: 160 ms per trial, 1.6 s of trials); the kill test needs rank 0
# still working when rank 1 dies. Held-out validation (on rank 0, after the trials) keeps 20 maps
# where flights are fast.
delay=0 maps=20
[[ $mode == equal ]] && delay=0.02 maps=4
[[ $mode == kill ]] && delay=0.01
[[ $mode == batch ]] && delay=0.03  # several 50 ms batches before the kill
cat > toy.yaml <<YAML
name: mpi-toy
seed: 5
threads: 1
mode: reproducible
repeats: 2
methods: [default, random, pso, bo, bo_pso]
planner:
  type: toy
  toy: {length: 12, gates: 4, plan_interval: 1.0, flight_delay_s: $delay}
parameters:
  - {name: gain, lower: 0.05, upper: 1.5, default: 0.3}
  - {name: max_iter, lower: 2, upper: 40, type: integer, default: 20}
  - {name: speed, lower: 0.5, upper: 6.0, default: 2.0}
  - {name: margin, lower: 0.0, upper: 3.0, default: 0.5}
short_term: [gain, max_iter]
long_term: [speed, margin]
objective:
  short_term: {tau_t: 0.002}
budget: {flights: 8, flight_batch: 2, short_evals_per_flight: 4, queries_per_eval: 2, query_window: 50}
pso: {num_particles: 4}
bo: {initial_design_size: 2, acquisition_pool: 50, acquisition_starts: 1, hyper_restarts: 0}
validation: {maps: $maps}
YAML

# What must be identical: evaluations.csv without its wall-clock columns (wall_s, started,
# finished: plain numbers before the last two columns, map_seed and flight_seed) and trials.csv
# without its wall-clock column (finished, a plain number in the last column).
export_store() {  # export_store RUN_DIR → RUN_DIR/evaluations.txt, RUN_DIR/trials.txt
  "$quadtune" --log-level warn export "$1/results.sqlite" --csv "$1/csv"
  sed -E 's/,[^,]*,[^,]*,[^,]*(,[^,]*,[^,]*)$/\1/' "$1/csv/evaluations.csv" > "$1/evaluations.txt"
  sed -E 's/,[^,]*$//' "$1/csv/trials.csv" > "$1/trials.txt"
}

same_results() {  # same_results DIR_A DIR_B
  diff -u "$1/evaluations.txt" "$2/evaluations.txt" | head -20
  diff -u "$1/trials.txt" "$2/trials.txt" | head -20
  cmp -s "$1/evaluations.txt" "$2/evaluations.txt" && cmp -s "$1/trials.txt" "$2/trials.txt"
}

# killed_run R:N: toy.yaml on 2 ranks into cut/ with --test-kill-rank R:N; the run must fail,
# and rank 0 must name the lost rank and say how to resume.
killed_run() {
  set +e
  "${mpi[@]}" "$quadtune" --log-level warn run toy.yaml --out cut --threads 1 --quiet \
    --test-kill-rank "$1" > cut.log 2>&1
  local status=$?
  set -e
  cat cut.log
  if (( status == 0 )); then echo "the run survived the kill"; exit 1; fi
  grep -q "rank 1 (pid .*) was lost" cut.log || { echo "rank 0 did not name the lost rank"; exit 1; }
  grep -q "resume with: .*--resume" cut.log || { echo "rank 0 did not say how to resume"; exit 1; }
}

experiment=(toy.yaml)
if [[ $mode == ipopt ]]; then
  experiment=("$5/experiments/tiny.yaml" --set 'methods=[default, random, bo_pso]' --set repeats=2)
fi

# The single-process reference.
"$quadtune" --log-level warn run --no-plot "${experiment[@]}" --out one --threads 1 --quiet
export_store one
rows=$(($(wc -l < one/evaluations.txt) - 1))
echo "1 process: $rows evaluations"
(( rows > 30 ))

if [[ $mode == equal || $mode == ipopt ]]; then
  "${mpi[@]}" "$quadtune" --log-level debug run --no-plot "${experiment[@]}" --out two --threads 1 \
    --quiet > two.log 2>&1 || { cat two.log; exit 1; }
  export_store two
  # Both ranks ran trials (rank 0 logs the trials the other ranks finished).
  grep -q "(rank 1)" two.log || { cat two.log; echo "rank 1 ran no trial"; exit 1; }
  same_results one two
  echo "2 ranks: identical results"
  exit 0
fi

if [[ $mode == batch ]]; then
  # Rank 1 runs a bo_pso trial first (40 rows); at its 30th evaluation it waits for the
  # acknowledgement of every earlier batch, sends the batch holding the 30th and dies.
  killed_run 1:30
  hook=$(grep -o "rank 1: [0-9]* evaluations acknowledged by rank 0, [0-9]* sent in a batch not yet acknowledged (trials [0-9,]*)" cut.log) \
    || { echo "rank 1 did not report its batches"; exit 1; }
  acked=$(sed -E 's/rank 1: ([0-9]+) evaluations.*/\1/' <<< "$hook")
  in_flight=$(sed -E 's/.*acknowledged by rank 0, ([0-9]+) sent.*/\1/' <<< "$hook")
  trials=$(sed -E 's/.*\(trials ([0-9,]+)\)/\1/' <<< "$hook")
  committed=$(grep -o "[0-9]* evaluations committed" cut.log | grep -o "^[0-9]*") \
    || { echo "rank 0 did not report the store"; exit 1; }
  export_store cut
  stored=$(($(wc -l < cut/evaluations.txt) - 1))
  # Rows of rank 1's trials (the first column is the trial id).
  of_rank1=$(awk -F, -v ids=",$trials," 'NR > 1 && index(ids, "," $1 ",") { n++ } END { print n + 0 }' \
    cut/csv/evaluations.csv)
  echo "rank 1: $acked acknowledged, $in_flight in flight; stored of its trials: $of_rank1;" \
    "rank 0 committed $committed, the store holds $stored"
  (( acked > 0 && in_flight > 0 )) || { echo "no batch was acknowledged or in flight"; exit 1; }
  (( of_rank1 >= acked )) || { echo "an acknowledged evaluation is missing"; exit 1; }
  (( of_rank1 <= acked + in_flight )) || { echo "more rows than rank 1 sent"; exit 1; }
  (( committed == stored )) || { echo "rank 0's count differs from the store"; exit 1; }
  "${mpi[@]}" "$quadtune" --log-level warn run toy.yaml --out cut --threads 1 --quiet --resume \
    > resume.log 2>&1 || { cat resume.log; exit 1; }
  export_store cut
  same_results one cut
  echo "resumed on 2 ranks: every row once, identical to the uninterrupted run"
  exit 0
fi

# kill: rank 1 raises SIGKILL after sending the batch with its 3rd evaluation (mid-trial: a
# trial has >= 8).
killed_run 1:3
export_store cut
stored=$(($(wc -l < cut/evaluations.txt) - 1))
echo "killed run: $stored of $rows evaluations stored"
(( stored > 0 && stored < rows ))
"${mpi[@]}" "$quadtune" --log-level warn run toy.yaml --out cut --threads 1 --quiet --resume \
  > resume.log 2>&1 || { cat resume.log; exit 1; }
export_store cut
same_results one cut
echo "resumed on 2 ranks: identical to the uninterrupted run"
