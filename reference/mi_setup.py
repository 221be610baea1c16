"""Import Mitsuba with the right libLLVM and variant, once per process.

The variant is ``cuda_ad_rgb`` where it renders, else ``llvm_ad_rgb``
(``reference.variant`` probes in child processes); ``VOLCAUSTICS_MI_VARIANT``
overrides the choice (tests use it to skip probing).
"""

from __future__ import annotations

import functools
import os


@functools.lru_cache(maxsize=1)
def mitsuba():
    """The ``mitsuba`` module with the reference variant set."""
    from .llvm import ensure_libllvm

    ensure_libllvm()
    variant = os.environ.get("VOLCAUSTICS_MI_VARIANT")
    if not variant:
        from .variant import reference_variant

        variant = reference_variant()
    import mitsuba as mi

    mi.set_variant(variant)
    return mi


def variant_name() -> str:
    return mitsuba().variant()


def mitsuba_version() -> str:
    return mitsuba().__version__
