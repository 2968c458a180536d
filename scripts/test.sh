#!/usr/bin/env bash
# Builds (installing dependencies if needed) and runs the whole test suite with CTest.
# Usage: bash scripts/test.sh [BUILD_DIR]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${1:-build}"
bash scripts/setup.sh "$build_dir"
cd "$build_dir"
# Open3D's OpenMP threads must not spin while oneTBB works (libgomp reads this at load time).
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-PASSIVE}"
ctest --output-on-failure -j 2
