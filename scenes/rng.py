"""The shared counter-based random numbers ``u(seed, photon, step, dim)``.

Both renderers draw every random number from this one stateless hash so that an
exact tracer can replay the very same free-flight samples as the GPU tracer. The
GLSL twin is ``approx/shaders/common/rng.glsl``; the two must agree bit for bit
(``tests/approx/test_rng_glsl.py`` checks 100,000 tuples).

Specification (all arithmetic in uint32 with wrap-around):

* ``pcg(v)``: the PCG hash of Jarzynski & Olano, "Hash Functions for GPU
  Rendering", JCGT 9(3), 2020::

      state = v * 747796405 + 2891336453
      word  = ((state >> ((state >> 28) + 4)) ^ state) * 277803737
      pcg   = (word >> 22) ^ word

* ``hash(seed, photon, step, dim) = pcg(pcg(pcg(pcg(seed) + photon) + step) + dim)``
* ``u = (hash >> 8) * 2**-24``: a float32 in [0, 1) on a 2**-24 grid, exactly
  representable, so GLSL and numpy produce identical floats.
* ``stratified(seed, photon, step, dim) = ((hash(seed, 2**32 − 1, step, dim) + photon *
  0x9E3779B9) >> 8) * 2**-24``: the golden-ratio Weyl sequence over the photon index,
  rotated by one random number per (seed, step, dim) (2**32 − 1 is no photon's index).
  Each photon's number is uniform and those of different steps independent, as ``u``'s,
  but any run of consecutive photons covers [0, 1) evenly (Weyl's equidistribution; the
  golden ratio's gaps are the most even, Knuth TAOCP 3 §6.4): n photons of equal
  probability R choose within a few of n·R (≤ 2 measured for n ≤ 1000), where independent
  numbers scatter by √(n·R(1 − R)) (``fresnel = stratified``, docs/decisions.md "Points against beams").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

PCG_MULT, PCG_INC, PCG_WORD = 747796405, 2891336453, 277803737  # the hash's constants (its twins read them)
GOLDEN = 0x9E3779B9          # 2**32 / golden ratio, rounded: the Weyl sequence's step (its twins read it)
ROTATION_PHOTON = 2**32 - 1  # the "photon" whose hash rotates a stratified sequence (no photon has this index)
FRESNEL_MODES = ("deterministic", "stochastic", "stratified")  # the parameter fresnel's values
FRESNEL_DIM = 1              # the dimension a Fresnel choice draws (0: free flight, 2–3: emission jitter)
# heterogeneous media: tentative collision k of a delta-tracked free flight draws its distance
# from dim TRACKING_DIM + 2k and whether it is real from TRACKING_DIM + 2k + 1 (4: splitting);
# a flight stops, without a collision, after MAX_TENTATIVE tentative ones
TRACKING_DIM = 8
MAX_TENTATIVE = 4096
_MULT, _INC, _WORD = np.uint32(PCG_MULT), np.uint32(PCG_INC), np.uint32(PCG_WORD)


def pcg_hash(v: np.ndarray | np.unsignedinteger) -> np.ndarray:
    """PCG hash (Jarzynski & Olano 2020) of uint32 values, elementwise.

    Parameters
    ----------
    v : array_like of uint32, any shape

    Returns
    -------
    ndarray of uint32, same shape
    """
    v = np.asarray(v, dtype=np.uint32)
    with np.errstate(over="ignore"):
        state = v * _MULT + _INC
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * _WORD
    return (word >> np.uint32(22)) ^ word


def hash4(seed: ArrayLike, photon: ArrayLike, step: ArrayLike, dim: ArrayLike) -> np.ndarray:
    """uint32 hash of (seed, photon, step, dim); arguments broadcast."""
    seed, photon, step, dim = (np.asarray(a, dtype=np.uint32) for a in (seed, photon, step, dim))
    with np.errstate(over="ignore"):
        h = pcg_hash(seed)
        h = pcg_hash(h + photon)
        h = pcg_hash(h + step)
        return pcg_hash(h + dim)


def uniform(seed: ArrayLike, photon: ArrayLike, step: ArrayLike, dim: ArrayLike) -> np.ndarray:
    """Uniform float32 in [0, 1) for (seed, photon, step, dim); arguments broadcast.

    Returns
    -------
    ndarray of float32, values k * 2**-24 with integer k in [0, 2**24)
    """
    h = hash4(seed, photon, step, dim)
    return (h >> np.uint32(8)).astype(np.float32) * np.float32(2.0**-24)


def stratified(seed: ArrayLike, photon: ArrayLike, step: ArrayLike, dim: ArrayLike) -> np.ndarray:
    """The stratified float32 in [0, 1) for (seed, photon, step, dim) (module docstring):
    uniform for each photon, evenly spread over any run of consecutive photons;
    arguments broadcast.

    Returns
    -------
    ndarray of float32, values k * 2**-24 with integer k in [0, 2**24)
    """
    photon = np.asarray(photon, dtype=np.uint32)
    with np.errstate(over="ignore"):
        h = hash4(seed, ROTATION_PHOTON, step, dim) + photon * np.uint32(GOLDEN)
    return (h >> np.uint32(8)).astype(np.float32) * np.float32(2.0**-24)


def stochastic_fresnel(fresnel: str) -> bool:
    """Whether ``fresnel`` (one of FRESNEL_MODES) chooses reflection or refraction by R
    (stochastic, stratified) rather than weighting the refracted power (deterministic)."""
    return fresnel != "deterministic"


def fresnel_uniform(fresnel: str, seed: ArrayLike, photon: ArrayLike, step: ArrayLike) -> np.ndarray:
    """The number photon ``photon`` compares with R at ``step`` under ``fresnel``: the
    stratified one for ``stratified``, else ``uniform``'s (the twin of
    ``fresnel_uniform`` in approx/shaders/common/interaction.glsl)."""
    draw = stratified if fresnel == "stratified" else uniform
    return draw(seed, photon, step, FRESNEL_DIM)
