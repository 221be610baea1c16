#!/usr/bin/env bash
# Run the test suite; pytest's exit code 5 ("no tests collected") is a failure.
set -uo pipefail
cd "$(dirname "$0")/.."
.venv/bin/python -m pytest -q "$@"
rc=$?
if [ "$rc" = 5 ]; then
  echo "run_tests: pytest collected no tests -- treated as a failure" >&2
  exit 1
fi
exit "$rc"
