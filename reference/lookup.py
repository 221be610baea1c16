"""Cached references found without rendering: by key (a sweep's workers use exactly
the reference the sweep resolved) or by request (a sweep's resumed run uses the entry
as it is, never continued). Kept apart from ``render.py``, whose source is part of
the reference code version (``cache.code_version``): finding an entry changes no
rendered pixel, so it must not change the cache keys."""

from __future__ import annotations

from . import cache
from .render import ReferenceResult, _for_caller
from .request import resolve


def cached_reference(key: str, scene) -> ReferenceResult | None:
    """The complete cache entry ``key`` (EXR hash checked) as a result for ``scene``,
    or None if this cache does not hold it."""
    manifest = cache.load(key)
    return None if manifest is None else ReferenceResult(key, _for_caller(manifest, scene), cached=True)


def existing_reference(scene, settings=None, *, mode: str = "caustic") -> ReferenceResult | None:
    """The cache entry for ``scene`` and ``settings`` as it is (whatever its batches or
    floors), or None when there is none."""
    served = cache.lookup(resolve(scene, settings, mode))
    if served is None:
        return None
    key, manifest = served
    return ReferenceResult(key, _for_caller(manifest, scene), cached=True)
