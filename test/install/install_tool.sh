#!/usr/bin/env bash
# install_tool.sh BUILD SOURCE WORK PYTHONDIR
# Installs the quadtune build BUILD into P = WORK/prefix and uses it as a user would, from WORK
# (not the source tree), with PATH=P/bin:$PATH and PYTHONPATH=P/PYTHONDIR:
# - `quadtune paths` names the installed prefix and only files under it, each present;
# - `quadtune run` of a copy of experiments/tiny.yaml (drone and layout from the installed
#   assets) completes and draws its figures and report.html with the installed scripts and
#   JavaScript libraries (the debug log names the scripts it runs; none is in SOURCE);
# - `python3 -c 'import quadtune'` imports the installed package, which reads the run's store;
# - the prefix moved to another folder still finds its own files (`paths`, `plot run`).
set -euo pipefail
build=$1 src=$2 work=$3 pydir=$4

fail() {
  echo "install_tool: $*" >&2
  exit 1
}

rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" > "$work/install.log"
unset QUADTUNE_ASSETS QUADTUNE_PLOT_SCRIPT QUADTUNE_REPORT_SCRIPT QUADTUNE_REPORT_JS
export PATH="$prefix/bin:$PATH" PYTHONPATH="$prefix/$pydir"
cd "$work"

[[ $(command -v quadtune) == "$prefix/bin/quadtune" ]] ||
  fail "quadtune on PATH is not $prefix/bin/quadtune"
quadtune paths > paths.txt
grep -qx "prefix: $prefix" paths.txt ||
  fail "quadtune paths does not name the prefix: $(cat paths.txt)"
while IFS=': ' read -r name path; do
  [[ $path == "$prefix"/* ]] || fail "quadtune paths: $name is $path, not under $prefix"
  [[ -e $path ]] || fail "quadtune paths: $name $path does not exist"
done < <(grep -v '^prefix: ' paths.txt)

# The experiment's drone and layout files resolve in the installed assets.
cp "$src/experiments/tiny.yaml" tiny.yaml
quadtune --log-level debug run tiny.yaml --out run --set validation.maps=1 > run.log 2>&1 ||
  fail "quadtune run failed: $(tail -5 run.log)"
for script in plot/quadtune_plot.py report/quadtune_report.py; do
  grep -q "running .*'$prefix/share/quadtune/experiments/$script'" run.log ||
    fail "the run did not run the installed $script"
done
# The source tree's scripts, assets or package (WORK itself may lie inside the source tree).
if grep -qE "$src/(experiments|assets)/" run.log; then
  fail "the installed program used the source tree:" \
    "$(grep -E "$src/(experiments|assets)/" run.log | head -3)"
fi
[[ -s run/report.html ]] || fail "no run/report.html"
grep -q "plotly" run/report.html || fail "run/report.html holds no plotly.js"
ls run/*.png > /dev/null 2>&1 || fail "no figures (PNG) in run/"

# The installed package, with the interpreter the program runs its scripts with.
python=python3
[[ -x /usr/bin/python3 ]] && python=/usr/bin/python3
"$python" -c 'import quadtune; print(quadtune.__file__)' > import.txt ||
  fail "python3 -c 'import quadtune' failed"
[[ $(cat import.txt) == "$prefix/$pydir/quadtune/"* ]] ||
  fail "import quadtune found $(cat import.txt), not the installed package"
"$python" - <<'EOF' || fail "the installed package could not read the run's store"
import quadtune
r = quadtune.load("run/results.sqlite")
assert len(r.long) == 3, f"{len(r.long)} tuning flights, expected 3"
print("install_tool: quadtune.load read", len(r.long), "tuning flights")
EOF
"$python" - "$prefix/$pydir" <<'EOF' || fail "the installed compiled module quadtune._core did not tune"
import sys
import quadtune
import quadtune._core as core
assert core.__file__.startswith(sys.argv[1]), f"quadtune._core came from {core.__file__}"
study = quadtune.BayesOpt({"x": (-2.0, 2.0)}, seed=3)
for _ in range(8):
    x = study.ask()
    study.tell(x, (x["x"] - 0.5) ** 2)
assert abs(study.best.params["x"] - 0.5) < 0.5, study.best
print("install_tool: the installed quadtune._core tuned x to", study.best.params["x"])
EOF
# The install is relocatable: moved elsewhere, the program finds everything under its new prefix.
mv "$prefix" "$work/moved"
moved=$work/moved
"$moved/bin/quadtune" paths > moved_paths.txt
grep -qx "prefix: $moved" moved_paths.txt ||
  fail "the moved install names $(head -1 moved_paths.txt)"
"$moved/bin/quadtune" --log-level debug plot run run > moved_plot.log 2>&1 ||
  fail "the moved install's quadtune plot run failed: $(tail -3 moved_plot.log)"
grep -q "running .*'$moved/share/quadtune/experiments/plot/quadtune_plot.py'" moved_plot.log ||
  fail "the moved install did not run its own figure script"
echo "install_tool: ok"
