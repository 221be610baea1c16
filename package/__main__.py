"""``python -m volcaustics COMMAND``: the ``volcaustics`` command."""

import sys

from volcaustics.reports.cli import main

sys.exit(main())
