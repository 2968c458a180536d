#!/usr/bin/env bash
# Runs the module's pytest tests with the given interpreter; exit 77 (CTest: skipped) without pytest or numpy.
set -u
python="$1"
tests="$2"
if ! "$python" -c "import pytest, numpy" 2>/dev/null; then
  echo "python_test: $python has no pytest or numpy (Debian: python3-pytest python3-numpy); skipped"
  exit 77
fi
exec "$python" -m pytest -q -p no:cacheprovider "$tests"
