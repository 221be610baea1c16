"""Import Mitsuba with the right libLLVM and variant, once per process.

The variant is ``cuda_ad_rgb`` where it renders, else ``llvm_ad_rgb``
(``reference.variant`` probes in child processes); ``VOLCAUSTICS_MI_VARIANT``
overrides the choice (tests use it to skip probing). The versions and the
variants a cached reference may come from are known without importing Mitsuba,
so a cache hit costs no Mitsuba start-up.
"""

from __future__ import annotations

import functools
import os
from types import ModuleType
from typing import cast

from .variant import PREFERRED, VariantError, reference_variant

VARIANT_ENV = "VOLCAUSTICS_MI_VARIANT"
_THREADS: list = []  # Dr.Jit's threads in this process, when a pool set its share (share_cores)


def variant_override() -> str | None:
    """``VOLCAUSTICS_MI_VARIANT`` when set, checked: the light tracer is a Dr.Jit
    ``AdjointIntegrator`` in RGB, so only the JIT RGB variants render it."""
    variant = os.environ.get(VARIANT_ENV)
    if not variant:
        return None
    if variant not in PREFERRED:
        raise VariantError(f"{VARIANT_ENV} = {variant!r}: expected one of {', '.join(PREFERRED)} (the reference's "
                           f"integrators need a JIT RGB variant); unset it to let volcaustics choose")
    return variant


def render_variant() -> str:
    """The variant this process renders with: the override, else the probed choice."""
    variant = variant_override()
    if variant:
        return variant
    return reference_variant()


def served_variants() -> tuple[str, ...]:
    """Variants whose cached references this process serves, in order of preference:
    the override alone when set, else every variant the reference may render with
    (so a cache hit needs no probe)."""
    variant = variant_override()
    if variant:
        return (variant,)
    return PREFERRED


@functools.lru_cache(maxsize=1)
def mitsuba() -> ModuleType:
    """The ``mitsuba`` module with the reference variant set."""
    from .llvm import MIN_MAJOR, ensure_libllvm, libllvm_major

    path, how = ensure_libllvm()
    override = variant_override()
    # checked before the probe, which would only report that no variant renders
    if how == "environment" and not (override or "llvm").startswith("cuda") and (
            not _shared_library(cast(str, path)) or (libllvm_major(cast(str, path)) or MIN_MAJOR) < MIN_MAJOR):
        raise VariantError(f"DRJIT_LIBLLVM_PATH = {path!r}: not a libLLVM {MIN_MAJOR} or newer file (Dr.Jit's LLVM "
                           f"backend needs one); unset it to let volcaustics find one, or apt-get install libllvm19")
    variant = render_variant()
    import mitsuba as mi

    try:
        mi.set_variant(variant)
    except (ImportError, RuntimeError) as exc:  # e.g. cuda_ad_rgb where no CUDA driver initialises
        raise VariantError(f"{'VOLCAUSTICS_MI_VARIANT = ' + repr(override) if override else variant}: Mitsuba "
                           f"cannot start this variant here ({exc}); unset VOLCAUSTICS_MI_VARIANT or set it to "
                           f"llvm_ad_rgb") from None
    if _THREADS:
        _set_threads(_THREADS[-1])
    return mi


def share_cores(threads: int) -> None:
    """This process is one of a pool's workers: Dr.Jit renders on ``threads`` threads, its
    share of the cores (with one, a light-tracer batch is the same bytes on every run)."""
    _THREADS.append(max(1, int(threads)))
    if mitsuba.cache_info().currsize:
        _set_threads(_THREADS[-1])


def _set_threads(threads: int) -> None:
    import drjit as dr

    dr.set_thread_count(threads)


def _shared_library(path: str) -> bool:
    """A regular file that starts as an ELF object does (what Dr.Jit can load)."""
    try:
        if not os.path.isfile(path):
            return False
        with open(path, "rb") as fh:
            return fh.read(4) == b"\x7fELF"
    except OSError:
        return False


def variant_name() -> str:
    return mitsuba().variant()


def _installed_version(package: str) -> str:
    """Version of an installed distribution without importing it: from the name of
    its wheel's ``<name>-<version>.dist-info`` folder (PEP 427) beside the package,
    else from ``importlib.metadata`` (slower to import, ~20 ms)."""
    import glob
    import importlib.util

    spec = importlib.util.find_spec(package)
    if spec is not None and spec.origin:
        site = os.path.dirname(os.path.dirname(spec.origin))
        found = glob.glob(os.path.join(site, f"{package}-*.dist-info"))
        if len(found) == 1:
            return os.path.basename(found[0])[len(package) + 1:-len(".dist-info")]
    from importlib.metadata import version

    return version(package)


@functools.lru_cache(maxsize=1)
def library_versions() -> dict:
    """Installed versions of Mitsuba and Dr.Jit (nothing imported)."""
    return {"mitsuba": _installed_version("mitsuba"), "drjit": _installed_version("drjit")}


def mitsuba_version() -> str:
    return library_versions()["mitsuba"]


def drjit_version() -> str:
    return library_versions()["drjit"]
