#!/usr/bin/env bash
# Builds the project with AddressSanitizer + UndefinedBehaviorSanitizer (g++, its own build folder)
# and runs the unit tests: every CTest test except the accuracy gates and the end-to-end tests
# (labels `gate`, `e2e`: the same code at sizes that take too long under ASan). A finding aborts its
# test, so the script fails.
# Usage: bash scripts/sanitize.sh [CTEST_ARGS ...]   e.g. -R core_test; `-LE gate` adds the e2e tests
# Environment: PANOSCAN_SANITIZE_BUILD (build folder, default build-sanitize).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${PANOSCAN_SANITIZE_BUILD:-build-sanitize}"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
start=$(date +%s)
mkdir -p "$build_dir"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${launcher[@]}" \
  -DPANOSCAN_SANITIZE=ON -DPANOSCAN_BUILD_BENCHMARKS=OFF >"$build_dir/configure.log" 2>&1 ||
  { cat "$build_dir/configure.log" >&2; exit 1; }
cmake --build "$build_dir" -j 2 >"$build_dir/build.log" 2>&1 || { tail -40 "$build_dir/build.log" >&2; exit 1; }
built=$(date +%s)
# Leaks are findings too. Third-party libraries' own one-time allocations that are never freed are
# listed, with the reason, in scripts/lsan.supp. halt_on_error: the first finding fails the test.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
status=0
ctest_args=("$@")
[ ${#ctest_args[@]} -eq 0 ] && ctest_args=(-LE 'gate|e2e')
(cd "$build_dir" && ctest --output-on-failure -j 2 "${ctest_args[@]}") || status=$?
end=$(date +%s)
echo "sanitize.sh: build $((built - start)) s, tests $((end - built)) s: $([ $status -eq 0 ] && echo clean || echo FINDINGS)"
exit $status
