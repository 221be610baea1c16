#!/usr/bin/env bash
# Run the test suite; pytest's exit code 5 ("no tests collected") is a failure. The 25
# slowest tests are printed at the end (--durations), so that growth is seen in CI's output.
set -uo pipefail
cd "$(dirname "$0")/.."
.venv/bin/python -m pytest -q --durations=25 "$@"
rc=$?
if [ "$rc" = 5 ]; then
  echo "run_tests: pytest collected no tests -- treated as a failure" >&2
  exit 1
fi
exit "$rc"
