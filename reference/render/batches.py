"""Running statistics of independent batch images, and the noise floor they give.

A reference renders independent streams of batches: the light tracer's
(``caustic``), the camera integrator's (``fog``, ``direct``) and, with K > 1
scattering orders, the higher orders' (``reference.render.orders``). Each stream
keeps, per image, the float64 sums of the batch images and of their squares, in
batch order, so a cached render can be continued batch by batch and gives
exactly what rendering all its batches at once gives (same seeds, same order of
additions). The variance of the mean is the batches' sample variance over n.

The noise floor of a component is Σ var / Σ mean² over the pixels that do not
see glass (DESIGN.md "Noise": the relative MSE an exact renderer would get
against this reference).
"""

from __future__ import annotations

import numpy as np

from volcaustics.scenes.rng import pcg_hash

LIGHT, CAMERA, ORDERS = "light", "camera", "orders"
STREAM_IMAGES = {LIGHT: ("caustic",), CAMERA: ("fog", "direct", "fog_direct")}  # ORDERS: orders.stream_images(K)
# Salt of each stream's batch seeds, so that no two streams share one.
_STREAM_SALT = {LIGHT: 1, CAMERA: 2, ORDERS: 3}


def batch_seed(seed: int, stream: str, batch: int) -> int:
    """Mitsuba seed (uint32) of batch ``batch`` of ``stream`` for the settings' ``seed``:
    a PCG hash chain (scenes.rng), independent of how many batches are rendered, so that
    batch b is the same image whether it is rendered first or as a continuation."""
    v = pcg_hash(np.uint32(seed) + pcg_hash(np.uint32(_STREAM_SALT[stream])))
    return int(pcg_hash(v + np.uint32(batch)))


class BatchStats:
    """Sums over n batches of named H×W×3 images (float64) and of their squares."""

    def __init__(self, names, n: int = 0, sums: dict | None = None, squares: dict | None = None):
        self.names = tuple(names)
        self.n = n
        self.sums = sums or {}
        self.squares = squares or {}

    def add(self, images: dict) -> None:
        """Add one batch: ``images`` maps every name to an H×W×3 array."""
        for name in self.names:
            x = np.asarray(images[name], np.float64)
            if name in self.sums:
                self.sums[name] += x
                self.squares[name] += x * x
            else:
                self.sums[name], self.squares[name] = x.copy(), x * x
        self.n += 1

    def mean(self, name: str) -> np.ndarray:
        return self.sums[name] / self.n

    def var(self, name: str) -> np.ndarray:
        """Variance of the mean per pixel (needs n ≥ 2), float64, ≥ 0."""
        n = self.n
        spread = self.squares[name] - self.sums[name] * self.sums[name] / n
        return np.maximum(spread, 0.0) / (n - 1) / n

    def arrays(self, prefix: str) -> dict:
        """The state as flat arrays (for an .npz file)."""
        out = {f"{prefix}/n": np.asarray(self.n)}
        for name in self.sums:
            out[f"{prefix}/sum/{name}"] = self.sums[name]
            out[f"{prefix}/square/{name}"] = self.squares[name]
        return out

    @classmethod
    def from_arrays(cls, names, arrays, prefix: str) -> "BatchStats":
        n = int(arrays[f"{prefix}/n"])
        if n == 0:
            return cls(names)
        return cls(names, n, {k: np.array(arrays[f"{prefix}/sum/{k}"], np.float64) for k in names},
                   {k: np.array(arrays[f"{prefix}/square/{k}"], np.float64) for k in names})


def noise_floor(mean: np.ndarray, var: np.ndarray, keep: np.ndarray) -> float | None:
    """Σ var / Σ mean² over the pixels ``keep`` (H×W bool); None where the component
    has no energy there (nothing to estimate: vacuum fog, no diffuse surface)."""
    energy = float(np.sum(mean[keep] ** 2))
    return float(np.sum(var[keep]) / energy) if energy > 0 else None
