#!/usr/bin/env bash
# Fuzzes every file reader of quadtune with libFuzzer (clang, ASan+UBSan) for a bounded time.
#
#   scripts/fuzz.sh                 # each target QUADTUNE_FUZZ_RUNS inputs (default 20000) from
#                                   # libFuzzer seed QUADTUNE_FUZZ_SEED (default 1), at most
#                                   # QUADTUNE_FUZZ_SECONDS (default 60) seconds
#   QUADTUNE_FUZZ_SECONDS=60 scripts/fuzz.sh experiment store   # chosen targets only
#   QUADTUNE_FUZZ_MODE=full scripts/fuzz.sh                      # instrument the libraries too
#
# Two modes:
# - quick (default): only the fuzz harnesses are compiled with clang (libFuzzer, ASan, UBSan)
#   and linked with the libraries of the ordinary build in build/ (QUADTUNE_BUILD_DIR), which
#   must be built; a minute of compiling. Crashes, hangs, uncaught exceptions and heap misuse
#   seen by ASan's allocator are found; coverage guidance and ASan/UBSan checks cover the
#   harness only.
# - full: a separate build in build-fuzz/ (QUADTUNE_FUZZ_BUILD_DIR) compiles the fuzz targets and
#   every library they read with under clang with coverage, ASan and UBSan (long: the whole
#   engine is compiled again).
# Each target starts from its seed corpus in
# test/fuzz/corpus/<target>/; what libFuzzer learns goes to build-fuzz/corpus/<target>/ (not
# into the sources). A crash, hang (> 10 s on one input) or sanitizer report stops the script
# with a non-zero status and leaves the input in build-fuzz/findings/; add it to
# test/fuzz/corpus/<target>/ once fixed, so the ordinary test suite replays it.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${QUADTUNE_FUZZ_BUILD_DIR:-$root/build-fuzz}"
# A fixed seed and a fixed number of runs make a pass reproducible: the same inputs in the same
# order from the seed corpus (a slower machine that hits the time cap runs a prefix of them).
seconds="${QUADTUNE_FUZZ_SECONDS:-60}"
runs="${QUADTUNE_FUZZ_RUNS:-20000}"
seed="${QUADTUNE_FUZZ_SEED:-1}"
targets=("$@")
if ((${#targets[@]} == 0)); then
  targets=(experiment study adapt drone layout_options saved_layout store)
fi
command -v clang++ >/dev/null || { echo "fuzz: clang++ not found (Debian package clang)" >&2; exit 1; }
mode="${QUADTUNE_FUZZ_MODE:-quick}"
main_build="${QUADTUNE_BUILD_DIR:-$root/build}"

if [[ "$mode" == quick ]]; then
  [[ -f "$main_build/build.ninja" ]] || { echo "fuzz: build $main_build first (scripts/setup.sh)" >&2; exit 1; }
  build_dir="${QUADTUNE_FUZZ_BUILD_DIR:-$main_build/fuzz}"
  mkdir -p "$build_dir/test/fuzz"
  cmake --build "$main_build" --target quadtune_engine quadtune_sim quadtune_layout quadtune_physics \
    quadtune_common \
    quadtune_test_planners
  includes=()
  for m in engine sim planning common physics physics/layout optimizers; do includes+=(-I"$root/$m/include"); done
  for t in "${targets[@]}"; do
    # The link line of the ordinary build's replay target, without its replay main.
    link=$(awk -v t="build test/fuzz/fuzz_$t:" 'index($0, t) == 1 {f = 1}
             f && /LINK_LIBRARIES/ {sub(/^ *LINK_LIBRARIES = /, ""); print; exit}' "$main_build/build.ninja")
    [[ -n "$link" ]] || { echo "fuzz: no target fuzz_$t in $main_build" >&2; exit 1; }
    echo "fuzz: compiling fuzz_$t"
    # shellcheck disable=SC2086
    (cd "$main_build" && clang++ -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined \
       -fno-sanitize-recover=undefined "${includes[@]}" -isystem /usr/include/eigen3 \
       -isystem /usr/include/bullet -DQUADTUNE_SOURCE_DIR="\"$root\"" \
       "$root/test/fuzz/fuzz_$t.cpp" -o "$build_dir/test/fuzz/fuzz_$t" $link)
  done
else
flags="-fsanitize=address,undefined,fuzzer-no-link -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
# shellcheck disable=SC2086
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_C_FLAGS="$flags" -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DQUADTUNE_FUZZ=ON -DQUADTUNE_BUILD_BENCHMARKS=OFF -DQUADTUNE_WITH_MPI=OFF \
  -DQUADTUNE_WITH_MIMALLOC=OFF ${QUADTUNE_CMAKE_ARGS:-} >/dev/null
cmake --build "$build_dir" -j "$(nproc)" --target "${targets[@]/#/fuzz_}"
fi

mkdir -p "$build_dir/findings"
export ASAN_OPTIONS="detect_leaks=0:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
status=0
for t in "${targets[@]}"; do
  corpus="$build_dir/corpus/$t"
  mkdir -p "$corpus"
  echo "fuzz: $t for $seconds s"
  if ! (cd "$build_dir/findings" && "$build_dir/test/fuzz/fuzz_$t" "$corpus" "$root/test/fuzz/corpus/$t" \
          -seed="$seed" -runs="$runs" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 \
          -max_len=65536 \
          -artifact_prefix="$build_dir/findings/$t-" -print_final_stats=1 2>"$build_dir/fuzz_$t.log"); then
    echo "fuzz: $t FOUND A PROBLEM; see $build_dir/fuzz_$t.log and $build_dir/findings/" >&2
    tail -n 40 "$build_dir/fuzz_$t.log" >&2
    status=1
  else
    grep -E "stat::number_of_executed_units|stat::new_units_added" "$build_dir/fuzz_$t.log" | tr '\n' ' '
    echo
  fi
done
exit "$status"
