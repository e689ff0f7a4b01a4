#!/usr/bin/env bash
# Installs quadtune's Debian 12 packages (idempotent: a no-op when all are present), then
# configures and builds quadtune in Release mode and, as root, installs it (cmake --install, prefix
# /usr/local: `import quadtune` then works in any python3).
#
#   scripts/setup.sh                # install + configure + build everything into ./build
#   QUADTUNE_BUILD_DIR=/tmp/b scripts/setup.sh
#   QUADTUNE_CMAKE_ARGS="-DQUADTUNE_SANITIZE=address" scripts/setup.sh
#   QUADTUNE_NO_INSTALL=1 scripts/setup.sh     # build only
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${QUADTUNE_BUILD_DIR:-$root/build}"

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libbullet-dev coinor-libipopt-dev liblapack-dev libblas-dev
  liblbfgs-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libtbb-dev libyaml-cpp-dev libcli11-dev libspdlog-dev libfmt-dev
  libsqlite3-dev sqlite3 nlohmann-json3-dev libmimalloc-dev
  libopenmpi-dev openmpi-bin
  libgtest-dev libgmock-dev libbenchmark-dev
  python3 python3-matplotlib python3-numpy python3-pandas python3-scipy python3-yaml
  npm chromium python3-pil clang libclang-rt-14-dev
  python3-optuna r-cran-irace
  pybind11-dev python3-pybind11 python3-dev
)

missing=()
for p in "${packages[@]}"; do
  # npm also comes inside NodeSource's nodejs package, which conflicts with Debian's npm.
  [[ "$p" == npm ]] && command -v npm >/dev/null && continue
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} > 0)); then
  echo "quadtune setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo=""
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || { echo "quadtune setup: run as root, or install sudo" >&2; exit 1; }
    sudo="sudo"
  fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -q
  $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "quadtune setup: all ${#packages[@]} Debian packages present"
fi

# The report's JavaScript libraries (three, plotly.js), pinned by package-lock.json.
js="$root/experiments/report/js"
if ! cmp -s "$js/package-lock.json" "$js/node_modules/.quadtune-lock"; then
  (cd "$js" && npm ci --no-audit --no-fund && cp package-lock.json node_modules/.quadtune-lock)
fi

jobs="$(nproc)"
# CGAL/Eigen translation units need ~1.5 GiB each; keep the build within memory on small machines.
mem_gib=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1048576 ))
if (( mem_gib / 2 < jobs )); then jobs=$(( mem_gib / 2 > 0 ? mem_gib / 2 : 1 )); fi

# shellcheck disable=SC2086
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release ${QUADTUNE_CMAKE_ARGS:-}
cmake --build "$build_dir" -j "$jobs"
echo "quadtune setup: built into $build_dir"

# The Python package quadtune (with its compiled module), the program, libraries and assets go
# under the install prefix (default /usr/local), where Debian's python3 finds `import quadtune`
# without PYTHONPATH (docs/python.md). Only as root, not for sanitizer builds;
# QUADTUNE_NO_INSTALL=1 skips it.
if [[ "${QUADTUNE_NO_INSTALL:-0}" != 1 && "${QUADTUNE_CMAKE_ARGS:-}" != *SANITIZE* ]]; then
  if [[ $(id -u) -eq 0 ]]; then
    cmake --install "$build_dir" >/dev/null
    echo "quadtune setup: installed (cmake --install $build_dir): import quadtune works without PYTHONPATH"
  else
    echo "quadtune setup: not root, so not installed; PYTHONPATH=$build_dir/python finds the Python package"
  fi
fi
