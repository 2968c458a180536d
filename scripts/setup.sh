#!/usr/bin/env bash
# Installs PanoScan's Debian 12 dependencies (as root), configures and builds Release with 2 jobs.
# Safe to run twice: apt-get skips what is installed, CMake rebuilds only what changed.
# Usage: bash scripts/setup.sh [BUILD_DIR]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${1:-build}"

# clang-14 + libfuzzer-14-dev: the fuzz build (scripts/fuzz.sh); the tests replay the corpora with g++.
# pybind11-dev, python3-dev, python3-pytest: the Python module (python/) and its pytest tests, for
# Debian's python3 (python3-numpy above).
# colmap: export_test checks `export colmap` with COLMAP's own model_analyzer.
# chromium: report_browser_test opens `panoscan report`'s page in headless Chromium (images loaded, tables there).
# snakemake, slurm-wlm, munge: the workflow (workflow/Snakefile) and its Slurm test, which starts a one-node
# cluster of its own (tests/cluster/run_cluster_test.sh).
# libdeflate-dev: PNG encoding (core/src/png_encode.cpp), 3x faster than libpng + zlib.
# libopenblas0-pthread: the BLAS/LAPACK alternative for CHOLMOD in the tracking solve (2x faster than
# ATLAS, which libceres-dev pulls in; see CMakeLists.txt).
packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libembree-dev libopencv-dev libassimp-dev libopenexr-dev libtbb-dev
  libcli11-dev nlohmann-json3-dev libyaml-cpp-dev libspdlog-dev libfmt-dev libdeflate-dev
  libceres-dev libopen3d-dev libpcl-dev
  libopenblas0-pthread
  libgtest-dev libgmock-dev libbenchmark-dev libnanoflann-dev
  python3-matplotlib python3-numpy
  pybind11-dev python3-dev python3-pytest
  clang-14 libfuzzer-14-dev
  snakemake slurm-wlm munge
  colmap
  chromium
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup.sh: missing packages (${missing[*]}); run as root to install them" >&2
    exit 1
  fi
  echo "setup.sh: installing ${#missing[@]} Debian packages"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j 2
echo "setup.sh: built into $build_dir (program: $build_dir/app/panoscan)"
