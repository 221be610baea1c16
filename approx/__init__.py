"""The paper's method on the GPU through moderngl/GLSL.

Multi-layer depth/normal maps from the spot light, image-space photon–geometry
intersection estimation, photon maps per interaction step, photon splatting,
volume fog and direct lighting, composed into one frame (docs/approx.md).
GLSL lives in ``approx/shaders/<pass>/`` and is loaded through ``approx.glsl``;
the one GL context comes from ``approx.context``. Never imports ``reference``.
"""

from .params import ApproxParams, ParamError
from .renderer import Frame, Renderer, render

__all__ = ["ApproxParams", "Frame", "ParamError", "Renderer", "render"]
