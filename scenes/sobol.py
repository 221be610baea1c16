"""Owen-scrambled Sobol points in the unit square, ``sobol_2d(seed, index)``: the
low-discrepancy draw of ``emission_jitter`` = sobol (where in its texel a photon
starts). The GLSL twin is ``approx/shaders/common/sobol.glsl``; the two agree bit for
bit (``tests/approx/test_emission_jitter.py``).

Specification (uint32 arithmetic with wrap-around):

* The first two Sobol dimensions of ``index``: x₀ = the bits of ``index`` reversed (van
  der Corput); x₁ = XOR of the direction numbers v_k for every set bit k of ``index``,
  v₀ = 2³¹, v_k = v_{k−1} XOR (v_{k−1} >> 1) (primitive polynomial x + 1).
* Each dimension is Owen-scrambled by Burley's hash-based nested uniform scramble
  (B. Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020, with its
  Laine–Karras-style permutation): reverse the bits, ``x += s; x ^= x·0x6c50b47c;
  x ^= x·0xb82f1e52; x ^= x·0xc7afe638; x ^= x·0x8d22f6e6``, reverse again, with
  s = pcg(seed + d + 1) for dimension d (``scenes.rng.pcg_hash``).
* ``u = (x >> 8)·2⁻²⁴``, as ``scenes.rng.uniform``: exactly representable floats.

Owen scrambling keeps the net's stratification (every aligned block of 4^k indices
covers the square's 4^k cells of each elementary shape once) and makes every point
uniform on the square: an estimator that is unbiased with independent uniform points
stays unbiased. A new seed is a new scramble. ``morton(x, y)`` orders texels so that
every aligned 2^k × 2^k block of them holds consecutive indices, so their points are
stratified over the block.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .rng import pcg_hash

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

_PERMUTATION = tuple(np.uint32(c) for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6))


def reverse_bits(x: np.ndarray) -> np.ndarray:
    """The 32 bits of each uint32 reversed (GLSL ``bitfieldReverse``)."""
    x = np.asarray(x, np.uint32)
    for shift, mask in ((1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF)):
        s, m = np.uint32(shift), np.uint32(mask)
        x = ((x >> s) & m) | ((x & m) << s)
    return (x >> np.uint32(16)) | (x << np.uint32(16))


def _scramble(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    x = reverse_bits(x)
    with np.errstate(over="ignore"):
        x = x + seed
        for c in _PERMUTATION:
            x = x ^ (x * c)
    return reverse_bits(x)


def _sobol_dim1(index: np.ndarray) -> np.ndarray:
    x = np.zeros_like(index)
    v = np.uint32(1 << 31)
    for bit in range(32):
        x ^= np.where((index >> np.uint32(bit)) & np.uint32(1), v, np.uint32(0))
        v ^= v >> np.uint32(1)
    return x


def sobol_2d(seed: ArrayLike, index: ArrayLike) -> np.ndarray:
    """…×2 float32 points in [0, 1)²: the Owen-scrambled Sobol points ``index`` (uint32)
    of the scramble ``seed`` (module docstring); arguments broadcast."""
    seed, index = np.broadcast_arrays(np.asarray(seed, np.uint32), np.asarray(index, np.uint32))
    with np.errstate(over="ignore"):
        seeds = [pcg_hash(seed + np.uint32(d + 1)) for d in range(2)]
    dims = (_scramble(reverse_bits(index), seeds[0]), _scramble(_sobol_dim1(index), seeds[1]))
    return np.stack([(x >> np.uint32(8)).astype(np.float32) * np.float32(2.0**-24) for x in dims], axis=-1)


def morton(x: ArrayLike, y: ArrayLike) -> np.ndarray:
    """The Z-order index of texel (x, y) (each < 2¹⁶): x's bits at the even positions."""
    def spread(v):
        v = np.asarray(v, np.uint32) & np.uint32(0xFFFF)
        for shift, mask in ((8, 0x00FF00FF), (4, 0x0F0F0F0F), (2, 0x33333333), (1, 0x55555555)):
            v = (v | (v << np.uint32(shift))) & np.uint32(mask)
        return v
    return spread(x) | (spread(y) << np.uint32(1))
