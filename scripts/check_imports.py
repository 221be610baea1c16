"""The import-resolution check (``make lint``): a type checker (mypy) must resolve every
``volcaustics.*`` import of the package and of its tests and benchmarks, as an editor built
on a static analyser would. Its other rules are out of scope here: only unresolved imports
of the project fail the check (third-party libraries without stubs are not ours to fix).

Exits 1 and prints each unresolved import, else prints how many files were checked.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
UNRESOLVED = re.compile(r'error: (?:Cannot find implementation or library stub for module named|Module) '
                        r'"(volcaustics[\w.]*)"'
                        r'|error: Module "(volcaustics[\w.]*)" has no attribute')


def main() -> int:
    output = []
    for target in (["-p", "volcaustics"], ["tests", "bench"]):  # mypy takes a package or files, not both
        command = [sys.executable, "-m", "mypy", *target, "--no-error-summary", "--follow-imports=silent",
                   "--cache-dir", os.path.join(ROOT, ".mypy_cache")]
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
        if done.returncode not in (0, 1):  # 2: mypy itself failed (a bad option, a crash)
            print(done.stdout[-3000:], done.stderr[-3000:], file=sys.stderr)
            return 1
        output += done.stdout.splitlines()
    wrong = [line for line in output if UNRESOLVED.search(line)]
    for line in wrong:
        print(line)
    checked = len({line.split(":")[0] for line in output if ": " in line})
    print(f"check_imports: {len(wrong)} unresolved volcaustics import(s) (mypy reported on {checked} files)",
          file=sys.stderr)
    return 1 if wrong else 0


if __name__ == "__main__":
    sys.exit(main())
