#!/usr/bin/env bash
# The scale model of distributed runs (docs/cluster.md): experiments/scale_model.yaml (the sleep
# planner: the Ipopt planner's wall times, no core used) on 1, 2, 4, … ranks × 1 thread, two
# trials per rank; stored evaluations per second (the run's evaluations over rank 0's wall_s),
# against the ideal line (ranks × the single process's rate), and the peak resident memory of
# every rank and the CPU seconds of rank 0 and of all ranks together (/usr/bin/time). Writes
# OUT/scale_model.csv and OUT/scale_model.png. The sleep planner is a test planner: the program is
# build/test/support/quadtune_test_cli (`quadtune` with the test planners; $QUADTUNE overrides).
#
#   bash scripts/scale_model.sh [OUT [RANKS...]]      default: docs/results/cluster 1 2 4 … 256
#
# More ranks than cores run oversubscribed (--oversubscribe); as root --allow-run-as-root.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/docs/results/cluster}
shift || true
ranks_list=("$@")
(( ${#ranks_list[@]} )) || ranks_list=(1 2 4 8 16 32 64 128 256)
quadtune=${QUADTUNE:-$root/build/test/support/quadtune_test_cli}
work=$(mktemp -d /tmp/quadtune_scale.XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
csv=$out/scale_model.csv
cores=$(nproc)
mpi=(mpirun --oversubscribe --bind-to none)
if [[ $(id -u) == 0 ]]; then mpi+=(--allow-run-as-root); fi

echo "ranks,cores,trials,evaluations,wall_s,evals_per_s,ideal_per_s,rss_root_mib,rss_rank_mib,"\
"cpu_root_s,cpu_all_s,mpirun_rc" > "$csv"
single_rate=
for ranks in "${ranks_list[@]}"; do
  run=$work/r$ranks
  mkdir -p "$run/rss"
  trials=$((2 * ranks))
  # Each rank writes its peak RSS (KiB) and CPU seconds (user, system) to rss/RANK.
  cmd=(/usr/bin/time -o "$run/rss/\${OMPI_COMM_WORLD_RANK:-0}" -f "'%M %U %S'" "$quadtune"
       --log-level warn
       run --no-plot "$root/experiments/scale_model.yaml" --set "repeats=$trials" --threads 1
       --out "$run/out" --quiet)
  # A non-zero exit of mpirun after rank 0 wrote summary.json is recorded (column mpirun_rc);
  # without summary.json the run failed.
  rc=0
  if (( ranks == 1 )); then
    bash -c "${cmd[*]}" || rc=$?
  else
    "${mpi[@]}" -np "$ranks" bash -c "${cmd[*]}" || rc=$?
  fi
  [[ -f $run/out/summary.json ]] || { echo "the run on $ranks ranks failed (exit $rc)"; exit 1; }
  read -r evaluations wall <<< "$(python3 - "$run/out" <<'PY'
import json, sqlite3, sys
d = sys.argv[1]
n = sqlite3.connect(d + "/results.sqlite").execute("SELECT COUNT(*) FROM evaluation").fetchone()[0]
print(n, json.load(open(d + "/summary.json"))["wall_s"])
PY
)"
  rate=$(python3 -c "print($evaluations / $wall)")
  [[ -n $single_rate ]] || single_rate=$(python3 -c "print($rate / $ranks)")
  ideal=$(python3 -c "print($single_rate * $ranks)")
  read -r rss_root rss_rank cpu_root cpu_all <<< "$(python3 - "$run/rss" <<'PY'
import os, statistics, sys
d = sys.argv[1]
fields = {}
for f in os.listdir(d):
    words = open(os.path.join(d, f)).read().split()
    if len(words) >= 3 and words[-3].isdigit():  # a rank killed at exit leaves a note instead
        fields[int(f)] = words[-3:]
kib = {r: int(v[0]) for r, v in fields.items()}
cpu = {r: float(v[1]) + float(v[2]) for r, v in fields.items()}
others = [v for r, v in kib.items() if r != 0] or [kib[0]]
print(kib[0] / 1024, statistics.median(others) / 1024, cpu[0], sum(cpu.values()))
PY
)"
  printf '%d ranks: %d evaluations in %.2f s = %.0f stored/s (ideal %.0f); RSS rank 0 %.0f MiB, '\
'other ranks %.0f MiB (median); CPU rank 0 %.1f s, all ranks %.1f s\n' "$ranks" "$evaluations" \
    "$wall" "$rate" "$ideal" "$rss_root" "$rss_rank" "$cpu_root" "$cpu_all"
  echo "$ranks,$cores,$trials,$evaluations,$wall,$rate,$ideal,$rss_root,$rss_rank,$cpu_root,"\
"$cpu_all,$rc" >> "$csv"
done
/usr/bin/python3 "$root/experiments/plot/quadtune_plot.py" scale-model "$csv"
