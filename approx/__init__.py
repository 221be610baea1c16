"""The paper's method on the GPU through moderngl/GLSL.

Multi-layer depth/normal maps from the spot light, image-space photon–geometry
intersection estimation, photon maps per interaction step, photon splatting,
volume fog and direct lighting, composed into one frame (docs/approx.md).
GLSL lives in ``approx/shaders/<pass>/`` and is loaded through ``approx.glsl``;
the one GL context comes from ``approx.context``. Never imports ``reference``.

The names below load on first use (PEP 562): importing ``approx.params`` for its
parameter table (every command's parser does) does not load moderngl and the renderer.
"""

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what mypy, editors and scripts/check_references.py see
    from .params import ApproxParams, ParamError
    from .renderer import Frame, Renderer, render

_WHERE = {"ApproxParams": ".params", "ParamError": ".params", "Frame": ".renderer", "Renderer": ".renderer",
          "render": ".renderer"}

__all__ = ["ApproxParams", "Frame", "ParamError", "Renderer", "render"]  # the keys of _WHERE


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name], __name__), name)
