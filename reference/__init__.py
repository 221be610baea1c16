"""Ground truth from Mitsuba 3 / Dr.Jit for the very same scenes as ``approx``.

Scene export to Mitsuba, a volumetric light tracer for the caustic term,
single-scattering integrators for fog and direct light, an exact ray-segment
intersection oracle and exact photon tracer, and an on-disk cache of results.
Importing this package picks a libLLVM >= 16 for Dr.Jit (``reference.llvm``)
before anything imports drjit.
"""

from .llvm import ensure_libllvm

LIBLLVM_PATH, LIBLLVM_HOW = ensure_libllvm()
