"""Image error metrics (pure numpy, float64 accumulation)."""

from __future__ import annotations

import numpy as np


def _check(reference, test, mask):
    r = np.asarray(reference, dtype=np.float64)
    t = np.asarray(test, dtype=np.float64)
    if r.shape != t.shape:
        raise ValueError(f"shape mismatch: reference {r.shape}, test {t.shape}")
    if mask is None:
        return r, t
    m = np.asarray(mask, dtype=bool)
    if m.shape != r.shape[: m.ndim]:
        raise ValueError(f"mask shape {m.shape} does not match image shape {r.shape}")
    return r[m], t[m]


def relative_mse(reference, test, *, mask=None) -> float:
    """Σ(test − reference)² / Σ reference²: the mean squared error relative to the
    reference's energy (0 for identical images).

    Parameters
    ----------
    reference, test : H×W×C arrays, linear radiance.
    mask : optional H×W (or H×W×C) boolean array of the pixels to compare.
    """
    r, t = _check(reference, test, mask)
    energy = float(np.sum(r * r))
    if energy == 0.0:
        raise ValueError("reference is zero everywhere: relative error undefined")
    return float(np.sum((t - r) ** 2) / energy)
