"""The shared hash in numpy against an independent pure-Python (big-int) model, and its statistics."""

from __future__ import annotations

import numpy as np
from scipy import stats

from volcaustics.scenes.rng import hash4, pcg_hash, uniform

M = 0xFFFFFFFF


def pcg_python(v: int) -> int:
    """Jarzynski & Olano (2020) PCG hash with explicit 32-bit masking."""
    state = (v * 747796405 + 2891336453) & M
    word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) & M
    return ((word >> 22) ^ word) & M


def hash_python(seed, photon, step, dim) -> int:
    h = pcg_python(seed)
    h = pcg_python((h + photon) & M)
    h = pcg_python((h + step) & M)
    return pcg_python((h + dim) & M)


def test_numpy_matches_python_model():
    rng = np.random.default_rng(1)
    tuples = rng.integers(0, 2**32, size=(2000, 4), dtype=np.uint64)
    tuples[:4] = [[0, 0, 0, 0], [M, M, M, M], [1, 2, 3, 4], [M, 0, M, 0]]
    expected = [hash_python(*map(int, t)) for t in tuples]
    got = hash4(*(tuples[:, k].astype(np.uint32) for k in range(4)))
    assert got.dtype == np.uint32 and got.tolist() == expected
    assert pcg_hash(np.uint32(0)) == pcg_python(0)


def test_uniform_grid_range_and_determinism():
    photon = np.arange(100_000, dtype=np.uint32)
    u = uniform(7, photon, 2, 1)
    assert u.dtype == np.float32 and u.min() >= 0.0 and u.max() < 1.0
    k = u.astype(np.float64) * 2**24
    assert np.array_equal(k, np.floor(k))  # exactly on the 2^-24 grid
    assert np.array_equal(u, uniform(7, photon, 2, 1))
    assert not np.array_equal(u, uniform(8, photon, 2, 1))
    assert not np.array_equal(u, uniform(7, photon, 2, 2))


def test_uniform_is_uniform_and_dims_uncorrelated():
    photon = np.arange(200_000, dtype=np.uint32)
    u0, u1 = uniform(3, photon, 0, 0), uniform(3, photon, 0, 1)
    # Kolmogorov–Smirnov at alpha = 1e-4: a correct hash fails with probability 1e-4.
    assert stats.kstest(u0, "uniform").pvalue > 1e-4
    # Correlation of independent uniforms has sd 1/sqrt(n) ~ 0.0022; 5 sd bound.
    assert abs(np.corrcoef(u0, u1)[0, 1]) < 5 / np.sqrt(len(photon))
