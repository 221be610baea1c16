"""One reference render, resolved once: exactly what will be rendered and keyed.

Image size lives in one place, the settings (docs/architecture.md. A request
fills the settings' width/height from the scene camera where they are unset, then
puts the scene's camera at that size, so a scene passed at any camera size with
settings naming a size, and the same scene already resized, are one request: one
render, one cache key.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

from .settings import ReferenceSettings, check_mode

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

    from .description import Description


@dataclass(frozen=True)
class RenderRequest:
    """scene: the scene as rendered, its camera at ``settings.width × settings.height``.
    settings: resolved (width and height set). mode: the light tracer's (settings.MODES)."""

    scene: Any  # scenes.Scene (its camera at the request's size)
    settings: ReferenceSettings
    mode: str = "caustic"

    @functools.cached_property
    def description(self) -> Description:
        """The Mitsuba scene as plain data (reference.description), built once per request."""
        from .description import describe

        return describe(self.scene)


def resolve(scene: Scene, settings: ReferenceSettings | None = None, mode: str = "caustic") -> RenderRequest:
    """The request for ``scene`` with ``settings`` (default :class:`ReferenceSettings`) and ``mode``."""
    settings = (settings or ReferenceSettings()).resolved(scene)
    camera = dataclasses.replace(scene.camera, width=cast(int, settings.width), height=cast(int, settings.height))
    return RenderRequest(dataclasses.replace(scene, camera=camera), settings, check_mode(mode))
