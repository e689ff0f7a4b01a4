#!/usr/bin/env bash
# Builds and runs the test suite under AddressSanitizer + UndefinedBehaviorSanitizer and under
# ThreadSanitizer (with test/engine/tsan.supp), each in its own build folder.
#
#   scripts/sanitize.sh                  # both, whole suite
#   scripts/sanitize.sh address -R yaml  # one sanitizer; further arguments go to ctest
#
# Build folders: build-asan/ and build-tsan/ (QUADTUNE_SANITIZE_BUILD_PREFIX changes "build").
# Exits non-zero when a build fails or a test fails or reports.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
prefix="${QUADTUNE_SANITIZE_BUILD_PREFIX:-$root/build}"
kinds=(address thread)
if [[ $# -gt 0 && ( "$1" == address || "$1" == thread ) ]]; then
  kinds=("$1")
  shift
fi
jobs="$(nproc)"
mem_gib=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1048576 ))
# Sanitized CGAL/Eigen translation units need ~3 GiB each.
if (( mem_gib / 3 < jobs )); then jobs=$(( mem_gib / 3 > 0 ? mem_gib / 3 : 1 )); fi

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
export TSAN_OPTIONS="suppressions=$root/test/engine/tsan.supp:halt_on_error=1:second_deadlock_stack=1:${TSAN_OPTIONS:-}"
status=0
for kind in "${kinds[@]}"; do
  dir="$prefix-${kind/address/asan}"
  dir="${dir/thread/tsan}"
  echo "sanitize: $kind in $dir"
  # shellcheck disable=SC2086
  # -O1: the optimisation level the sanitizers' authors recommend; assertions stay on.
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" \
    -DQUADTUNE_SANITIZE="$kind" -DQUADTUNE_BUILD_BENCHMARKS=OFF -DQUADTUNE_WITH_MIMALLOC=OFF \
    ${QUADTUNE_CMAKE_ARGS:-} >/dev/null
  cmake --build "$dir" -j "$jobs"
  if ! ctest --test-dir "$dir" --output-on-failure -j "$jobs" --timeout 1800 "$@"; then
    echo "sanitize: $kind: tests failed or reported" >&2
    status=1
  fi
done
exit "$status"
