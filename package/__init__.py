"""volcaustics: a validation harness for Real-time Volume Caustics with Image-based
Photon Tracing (Wang, Wang & Chen).

The installed namespace of the repository's top-level folders: ``volcaustics.scenes``,
``volcaustics.approx``, ``volcaustics.reference``, ``volcaustics.metrics``,
``volcaustics.experiment`` and ``volcaustics.reports`` are the folders ``scenes/``,
``approx/``, ``reference/``, ``metrics/``, ``experiment/`` and ``reports/`` (``setup.py``
maps them with setuptools' ``package-dir``), so no bare name that belongs to another distribution is installed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from volcaustics.reports.api import FrameCheck, frames, measure, render_approx, render_reference, sweep

__all__ = ["FrameCheck", "frames", "measure", "render_approx", "render_reference", "sweep"]


def __dir__() -> list[str]:
    """The module's names and the public functions, for ``dir(vc)`` and tab completion."""
    return sorted({*(n for n in globals() if n.startswith("__")), *__all__})


def __getattr__(name: str) -> Any:
    """The public functions, imported when first used (PEP 562), so that ``import
    volcaustics`` and ``volcaustics --help`` load no renderer."""
    if name in __all__:
        from volcaustics.reports import api

        return getattr(api, name)
    raise AttributeError(f"module 'volcaustics' has no attribute {name!r}")
