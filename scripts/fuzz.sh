#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang-14, AddressSanitizer + UBSan, its own build folder) and
# runs each for SECONDS, starting from the committed seed corpus. One line per target; exit 1 if any
# target found something (crash, hang, leak, out-of-memory, an Error not naming its file).
# Usage: bash scripts/fuzz.sh [SECONDS (default 60)] [TARGET ...]   (targets: the folders of fuzz/corpus)
# Environment: PANOSCAN_FUZZ_BUILD (build folder, default build-fuzz).
# New inputs found go to BUILD/corpus/<target>/ (kept between runs, not committed); a finding's input
# goes to BUILD/findings/<target>/ and its log to BUILD/logs/<target>.log. Replay a finding with
# BUILD/fuzz/fuzz_<target> FILE; once fixed, copy it into fuzz/corpus/<target>/ (the CTest replay then
# keeps it fixed).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
[ $# -gt 0 ] && shift
build_dir="${PANOSCAN_FUZZ_BUILD:-build-fuzz}"
command -v clang++-14 >/dev/null || { echo "fuzz.sh: clang++-14 missing (bash scripts/setup.sh installs it)" >&2; exit 1; }

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
mkdir -p "$build_dir"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 "${launcher[@]}" \
  -DPANOSCAN_FUZZ=ON -DPANOSCAN_BUILD_TESTS=OFF -DPANOSCAN_BUILD_BENCHMARKS=OFF >"$build_dir/configure.log" 2>&1 ||
  { cat "$build_dir/configure.log" >&2; exit 1; }
cmake --build "$build_dir" --target fuzz_all -j 2 >"$build_dir/build.log" 2>&1 ||
  { tail -40 "$build_dir/build.log" >&2; exit 1; }

if [ $# -gt 0 ]; then targets=("$@"); else
  targets=(); for d in fuzz/corpus/*/; do targets+=("$(basename "$d")"); done
fi
mkdir -p "$build_dir/logs"
found=0
for t in "${targets[@]}"; do
  [ -x "$build_dir/fuzz/fuzz_$t" ] || { echo "fuzz.sh: no target '$t'" >&2; exit 1; }
  mkdir -p "$build_dir/corpus/$t" "$build_dir/findings/$t"
  log="$build_dir/logs/$t.log"
  # -timeout: an input taking 10 s is a hang; -rss_limit_mb / -malloc_limit_mb: a reader that
  # allocates what a header claims without checking it against the file is a finding.
  status=0
  "$build_dir/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -print_final_stats=1 -artifact_prefix="$build_dir/findings/$t/" \
    "$build_dir/corpus/$t" "fuzz/corpus/$t" >"$log" 2>&1 || status=$?
  runs=$(grep -oE '^stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo "?")
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+' || echo "?")
  corpus=$(ls "$build_dir/corpus/$t" | wc -l)
  if [ "$status" -eq 0 ]; then
    echo "fuzz_$t: ${seconds} s, $runs runs, coverage $cov, corpus $corpus: no finding"
  else
    found=1
    echo "fuzz_$t: FINDING after $runs runs (exit $status): $(grep -m1 -E 'ERROR|finding|deadly|timeout|leak' "$log" || echo 'see log'); input in $build_dir/findings/$t/, log $log"
  fi
done
exit $found
