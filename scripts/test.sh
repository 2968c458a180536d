#!/usr/bin/env bash
# Builds (installing dependencies if needed) and runs the whole test suite with CTest.
# Usage: bash scripts/test.sh [BUILD_DIR]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${1:-build}"
bash scripts/setup.sh "$build_dir"
cd "$build_dir"
ctest --output-on-failure -j 2
