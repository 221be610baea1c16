"""The main job's reference budget (``make report``, ``volcaustics report``).

Batches of 2^18 photons (4 per pixel at 256²) and 4 camera samples per pixel,
at least 16 per stream (15 degrees of freedom for the per-pixel variance: a
z-test on 3, from 4 batches, means little), then more until the noise floors
meet the issue's targets — caustic 0.5%, fog and direct 0.2% — or 2 minutes
per scene pass.
"""

from __future__ import annotations

from volcaustics.reference.settings import ReferenceSettings

REPORT_TARGET = "caustic=0.005,fog=0.002,direct=0.002"
REPORT_REFERENCE = ReferenceSettings(photons=1 << 22, spp=64, batches=16, target_noise=REPORT_TARGET,
                                     max_seconds=120.0)
