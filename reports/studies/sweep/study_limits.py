"""What the studies' command lines show before anything loads: the grid's point limit,
the best search's criteria and the frame check's seeds. The parsers of ``sweep`` and
``frames`` read them here, so that ``--help`` and a bad flag import no study machinery
(pandas, the renderers); ``spec``, ``best_spec`` and ``frames`` use the same values."""

from __future__ import annotations

# Points a sweep runs without --yes: about 3 days at the quick preset's 25 s a point on 2
# cores (docs/sweeps.md); a larger grid is a typo more often than a plan, and expanding
# and checking 10^6 points alone takes minutes.
MAX_POINTS = 10_000

# criterion → (the ratio it ranks by, the error column, the goal: at most that many times the paper's on every
# scene): one frame's error, what a viewer sees, at half; the mean image's bias at a quarter
CRITERIA = {"frame": ("frame_ratio", "frame_relmse", 0.5), "bias": ("relmse_ratio", "caustic_relmse_debiased", 0.25)}

FRAME_CHECK_SEEDS = 6  # frames per point of the frame check: as the report and the budgets
