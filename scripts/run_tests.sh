#!/usr/bin/env bash
# Run the test suite; pytest's exit code 5 ("no tests collected") is a failure. The 25
# slowest tests are printed at the end (--durations), so that growth is seen in CI's output.
# One pytest-xdist worker per core, idle workers stealing queued tests (measured faster
# than one file per worker: docs/decisions.md); "-n 0" in the arguments runs one process.
# pytest runs from an empty temporary folder, so that a test which assumes the working
# directory (a relative path, a bare top-level import) fails here, not on a user's machine.
# Arguments are pytest options; the suite is the repository's tests/.
set -uo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
RUN_DIR="$(mktemp -d -t volcaustics-tests-XXXXXX)"
trap 'rm -rf "$RUN_DIR"' EXIT
cd "$RUN_DIR"
"$ROOT/.venv/bin/python" -m pytest -q --durations=25 -n auto --dist worksteal --rootdir "$ROOT" \
  -c "$ROOT/pyproject.toml" "$@" "$ROOT/tests"
rc=$?
if [ "$rc" = 5 ]; then
  echo "run_tests: pytest collected no tests -- treated as a failure" >&2
  exit 1
fi
exit "$rc"
