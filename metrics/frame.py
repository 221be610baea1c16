"""The error one frame shows (``frame_relative_mse``): what a real-time viewer sees is a
single frame, its bias plus that frame's own noise, not the mean over seeds whose bias
``metrics.noise.seed_relative_mse`` debiases.

For S frames A_s (different seeds) and a reference R with per-pixel variance var_R,
each frame's relative MSE Σ(A_s − R)²/Σ R² has expectation (Σ b² + Σ var_A + Σ var_R)
/ Σ R². Less the reference's floor Σ var_R/Σ R², the mean over the frames estimates
(Σ b² + Σ var_A)/Σ R² without bias: the one-frame error against a noise-free
reference. Its standard error has the frames' spread over S (they are independent
given R) and what R's noise adds, R being the same for every frame: 4 Σ m var_R +
2 Σ var_R² over (Σ R²)², m = E[(A − R)²] − var_R per pixel (the mean over the frames of
d², less var_R, clipped at 0 as a sum); docs/decisions.md "The one-frame error".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .noise import masked_pixels

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


@dataclass(frozen=True)
class FrameRelMSE:
    """``debiased``: the mean over the frames of their relative MSE less
    ``reference_floor``; ``per_seed``: each frame's own (not debiased);
    ``standard_error`` and the Student-t ``interval`` at ``level`` over the frames
    (nan / None with one frame)."""

    debiased: float
    reference_floor: float
    per_seed: tuple
    standard_error: float
    interval: tuple | None
    level: float


def frame_relative_mse(reference: ArrayLike, reference_var: ArrayLike, frames: ArrayLike, *,
                       mask: ArrayLike | None = None, level: float = 0.95) -> FrameRelMSE:
    """The one-frame error (module docstring) of S frames (S×H×W×C) against a reference
    (H×W×C) and the variance of its mean per pixel; ``mask`` (H×W) selects pixels."""
    r = np.asarray(reference, np.float64)
    rv = np.asarray(reference_var, np.float64)
    a = np.asarray(frames, np.float64)
    if a.ndim != r.ndim + 1 or a.shape[1:] != r.shape or rv.shape != r.shape or len(a) < 1:
        raise ValueError(f"shapes: reference {r.shape}, reference_var {rv.shape}, frames {a.shape} "
                         "(expected H×W×C, H×W×C, S×H×W×C with S ≥ 1)")
    sel_r, sel_rv = masked_pixels(r, mask), masked_pixels(rv, mask)
    energy = float(np.sum(sel_r * sel_r))
    if energy == 0.0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    d2 = np.stack([(masked_pixels(x, mask) - sel_r) ** 2 for x in a])  # S×N×C
    per_seed = d2.reshape(len(a), -1).sum(axis=1) / energy
    floor = float(sel_rv.sum()) / energy
    debiased = float(per_seed.mean()) - floor
    if len(a) < 2:
        return FrameRelMSE(debiased, floor, tuple(map(float, per_seed)), float("nan"), None, level)
    from scipy.special import stdtrit

    m = max(float(np.sum((d2.mean(axis=0) - sel_rv) * sel_rv)), 0.0)
    reference_part = (4.0 * m + 2.0 * float(np.sum(sel_rv**2))) / energy**2
    se = float(np.sqrt(per_seed.var(ddof=1) / len(a) + reference_part))
    half = float(stdtrit(len(a) - 1, 0.5 + level / 2.0)) * se
    return FrameRelMSE(debiased, floor, tuple(map(float, per_seed)), se, (debiased - half, debiased + half), level)
