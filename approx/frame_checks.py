"""What a frame must be before a command writes it: finite in every layer.

The parameter table's bounds keep what the shaders make of a value within float32
(``approx.params.FLOAT32_FLOOR``); this is the check behind them, run by every command
that writes an approximation's frame (``approx``, ``measure`` and the commands that
measure points, ``animate``), so that a value that still overflows or underflows is
refused, naming the parameters, instead of written as NaN with exit 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .params import ParamError

if TYPE_CHECKING:
    from collections.abc import Mapping

    from .params import ParamsMethods


class NonFiniteFrame(ParamError):
    """A frame holds NaN or ∞: the message names the layer, its first such pixel and the
    frame's float parameters (whose values float32 could not hold)."""


def check_finite_frame(images: Mapping[str, np.ndarray], params: ParamsMethods, what: str) -> None:
    """Raise :class:`NonFiniteFrame` unless every layer of ``images`` (name → H×W×3 or
    H×W float32, linear radiance) is finite; ``what`` names the frame (a file, a step).

    Example
    -------
    >>> check_finite_frame(frame.images, params, "OUT.exr")
    """
    for layer, image in images.items():
        bad = ~np.isfinite(np.asarray(image))
        if bad.any():
            y, x = np.argwhere(bad)[0][:2]
            floats = ", ".join(f"{p.name} = {getattr(params, p.name)!r}" for p in params.TABLE if p.kind is float)
            count = int(bad.reshape(bad.shape[0], bad.shape[1], -1).any(axis=2).sum())
            raise NonFiniteFrame(f"{what}: the {layer} layer has {count} pixel(s) with NaN or ∞ (the first at row {y}, "
                                 f"column {x}) at {floats}: a value float32 cannot hold; nothing was written. Move "
                                 f"the parameter away from the end of its range")
